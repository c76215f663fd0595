// Whether this robot's clock is synchronised (systemd-timesyncd, chrony, ntpd), for RobotStatus.clock_sync:
// the kernel's NTP state from adjtimex(2) (read only: modes 0; STA_UNSYNC / TIME_ERROR), and where the
// service's sandbox refuses that call (ProtectClock=yes filters @clock, reads included) the flag file
// systemd-timesyncd keeps (/run/systemd/timesync/synchronized). No allocation: two system calls.
#pragma once

#include <cstdint>

namespace teamscan::onboard {

enum class ClockSync : std::uint8_t { kUnknown = 0, kSynchronised = 1, kNotSynchronised = 2 };

[[nodiscard]] ClockSync read_clock_sync() noexcept;
[[nodiscard]] const char* to_string(ClockSync s) noexcept;

}  // namespace teamscan::onboard
