// The real sensor data the tests and benchmarks read: tests/data/real/ in this repository (origin and
// licence of every file: tests/data/real/SOURCES.md). The folder is compiled in (add_unit_test and
// add_teamscan_benchmark define TEAMSCAN_TEST_DATA_DIR), so a fresh clone tests itself.
#pragma once

#include <string>

namespace teamscan::test {

inline std::string real_data_path(const std::string& name) { return std::string{TEAMSCAN_TEST_DATA_DIR} + "/real/" + name; }

}  // namespace teamscan::test
