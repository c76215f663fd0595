// A DDS domain id of this test process, so that tests running at the same time on one host (ctest -j,
// other modules' HIL tests, other developers on a shared machine) never see each other's robots.
// All share the loopback config (its Domain Id="any"); ports are 7400 + 250 * domain + ...
// Child processes get the id on their command line (--domain).
#pragma once

#include <unistd.h>

#include <cstdint>
#include <cstdlib>
#include <string>

namespace teamscan::test {

inline std::uint32_t test_domain_id() {
  static const std::uint32_t id = [] {
    if (const char* e = std::getenv("TEAMSCAN_TEST_DOMAIN")) return static_cast<std::uint32_t>(std::atoi(e));
    return static_cast<std::uint32_t>(1 + ::getpid() % 230);  // 1..230 (Cyclone allows 0..232)
  }();
  return id;
}

inline std::string test_domain_arg() { return std::to_string(test_domain_id()); }

}  // namespace teamscan::test
