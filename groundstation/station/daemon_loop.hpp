// teamscan-groundstation's run loop: one tick that takes the robots' samples, releases held scans,
// publishes the team, the map and the status, pings the watchdog and starts periodic model writes;
// then the orderly stop (figures to events.log, DDS left before the files close, the final model).
#pragma once

#include <optional>

#include "groundstation/station/config.hpp"
#include "groundstation/station/daemon_wiring.hpp"

namespace teamscan::station::daemon {

// SIGTERM and SIGINT end the loop (install before anything starts).
void install_stop_signals();

// Tells systemd the station is ready, starts the disk sync thread and runs the loop until a stop signal;
// then STOPPING=1 and the loop's figures. A value: the failure is logged, exit with it (1).
[[nodiscard]] std::optional<int> run_until_stopped(const GroundStationConfig& cfg, Daemon& d);

// The parts stopped in order, each one's figures to events.log; the session synced, then the final model.
void stop_daemon(Daemon& d);

}  // namespace teamscan::station::daemon
