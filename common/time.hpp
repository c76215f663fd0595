// Time on the wire and in the code: int64 nanoseconds (DESIGN.md "Frames, units, time").
// A strong type so that a time stamp is never confused with a duration or a count.
#pragma once

#include <chrono>
#include <cstdint>

namespace teamscan {

using Duration = std::chrono::nanoseconds;
using namespace std::chrono_literals;

// A point in time as int64 nanoseconds since the epoch of some clock (CLOCK_REALTIME on the wire,
// CLOCK_MONOTONIC for deadlines and latencies). Which clock is the caller's contract.
class Time {
 public:
  constexpr Time() = default;
  static constexpr Time from_ns(std::int64_t ns) { return Time{ns}; }
  static constexpr Time from_us(std::int64_t us) { return Time{us * 1000}; }
  static constexpr Time from_seconds(double s) { return Time{static_cast<std::int64_t>(s * 1e9)}; }
  [[nodiscard]] constexpr std::int64_t ns() const { return ns_; }
  [[nodiscard]] constexpr std::int64_t us() const { return ns_ / 1000; }
  [[nodiscard]] constexpr double seconds() const { return static_cast<double>(ns_) * 1e-9; }

  constexpr Time& operator+=(Duration d) { ns_ += d.count(); return *this; }
  constexpr Time& operator-=(Duration d) { ns_ -= d.count(); return *this; }
  friend constexpr Time operator+(Time t, Duration d) { return Time{t.ns_ + d.count()}; }
  friend constexpr Time operator-(Time t, Duration d) { return Time{t.ns_ - d.count()}; }
  friend constexpr Duration operator-(Time a, Time b) { return Duration{a.ns_ - b.ns_}; }
  friend constexpr auto operator<=>(Time, Time) = default;

 private:
  constexpr explicit Time(std::int64_t ns) : ns_{ns} {}
  std::int64_t ns_ = 0;
};

[[nodiscard]] constexpr double to_seconds(Duration d) { return static_cast<double>(d.count()) * 1e-9; }
[[nodiscard]] constexpr Duration from_seconds(double s) { return Duration{static_cast<std::int64_t>(s * 1e9)}; }

// Time to move `bytes` over an 8N1 serial link (10 bits per byte on the wire).
[[nodiscard]] constexpr Duration serial_transmission_time(std::int64_t bytes, std::int64_t baud) {
  return Duration{bytes * 10 * 1'000'000'000 / baud};
}

}  // namespace teamscan
