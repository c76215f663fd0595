// The only place that reads the system clocks. Parsers and state machines take time as an argument.
#pragma once

#include <ctime>

#include "common/time.hpp"

namespace teamscan {

[[nodiscard]] inline Time read_clock(clockid_t id) {
  timespec ts{};
  ::clock_gettime(id, &ts);
  return Time::from_ns(static_cast<std::int64_t>(ts.tv_sec) * 1'000'000'000 + ts.tv_nsec);
}
[[nodiscard]] inline Time now_monotonic() { return read_clock(CLOCK_MONOTONIC); }
[[nodiscard]] inline Time now_realtime() { return read_clock(CLOCK_REALTIME); }

}  // namespace teamscan
