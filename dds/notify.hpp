// sd_notify wrappers for the daemons (DDS_SYSTEMD.md 5.1). Outside systemd (NOTIFY_SOCKET unset) every
// call is a no-op, so the same binary runs anywhere. Ping the watchdog from the main loop, never from a
// timer thread, so that a hung loop is detected.
#pragma once

#include "common/time.hpp"

namespace teamscan::dds {

void notify_ready();
void notify_status(const char* text);  // STATUS=<text>: shown by systemctl status
void notify_watchdog();
void notify_stopping();
// EXTEND_TIMEOUT_USEC: the service manager waits `more` longer than now before it gives up on the
// current start-up or stop (a long shutdown's work, asked for again as it progresses).
void notify_extend_timeout(Duration more);
// The watchdog timeout systemd (or a harness) asked for, or zero if the watchdog is off for this
// process (WATCHDOG_USEC unset, or WATCHDOG_PID names another process). Ping at half of it.
[[nodiscard]] Duration watchdog_interval();

}  // namespace teamscan::dds
