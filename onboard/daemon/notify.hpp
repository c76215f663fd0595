// sd_notify for the daemon: onboard/dds/notify.hpp when the DDS bridge is built, else the same calls
// straight to libsystemd. Outside systemd (NOTIFY_SOCKET unset) every call is a no-op.
#pragma once

#include "common/time.hpp"

#if TEAMSCAN_HAVE_DDS
#include "onboard/dds/notify.hpp"
#else
#include <systemd/sd-daemon.h>

#include <cstdint>

namespace teamscan::onboard {
inline void notify_ready() { (void)sd_notify(0, "READY=1"); }
inline void notify_status(const char* text) { (void)sd_notifyf(0, "STATUS=%s", text); }
inline void notify_watchdog() { (void)sd_notify(0, "WATCHDOG=1"); }
inline void notify_stopping() { (void)sd_notify(0, "STOPPING=1"); }
inline Duration watchdog_interval() {
  std::uint64_t usec = 0;
  if (sd_watchdog_enabled(0, &usec) <= 0) return Duration{0};
  return Duration{static_cast<std::int64_t>(usec) * 1000};
}
}  // namespace teamscan::onboard
#endif
