// sd_notify wrappers over libsystemd (DDS_SYSTEMD.md 5.1).
#include "dds/notify.hpp"

#include <cstdint>

#include <systemd/sd-daemon.h>

namespace teamscan::dds {

void notify_ready() { (void)sd_notify(0, "READY=1"); }

void notify_status(const char* text) { (void)sd_notifyf(0, "STATUS=%s", text); }

void notify_watchdog() { (void)sd_notify(0, "WATCHDOG=1"); }

void notify_stopping() { (void)sd_notify(0, "STOPPING=1"); }

void notify_extend_timeout(Duration more) {
  const auto usec = std::chrono::duration_cast<std::chrono::microseconds>(more).count();
  (void)sd_notifyf(0, "EXTEND_TIMEOUT_USEC=%llu", static_cast<unsigned long long>(usec > 0 ? usec : 0));
}

Duration watchdog_interval() {
  std::uint64_t usec = 0;
  // > 0 only if WATCHDOG_USEC is set and WATCHDOG_PID is unset or this process.
  if (sd_watchdog_enabled(0, &usec) <= 0) return Duration{0};
  return std::chrono::microseconds(static_cast<std::int64_t>(usec));
}

}  // namespace teamscan::dds
