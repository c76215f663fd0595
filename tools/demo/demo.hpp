// `teamscan demo`: the whole system live on one machine. The scenario's robots as emulated devices on
// ptys fed by the simulator in real time (sim/live.hpp), one real teamscan-onboard per robot, one real
// teamscan-groundstation, Cyclone DDS on loopback; at the end the ground station's session is scored
// against the simulator's truth with the same code as `teamscan eval` and compared with an offline
// simulation of the same scenario and seed (docs/demo.md). tools/teamscan/cmd_demo.cpp parses the
// command line into DemoOptions; adding an option = a field here, a line there, its use in demo.cpp.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "sim/scenario.hpp"

namespace teamscan::demo {

struct DemoOptions {
  std::string scenario = "lap2";
  double speed = 1.0;
  bool force_speed = false;  // run above real time although the live figures are then not honest
  std::optional<int> robots;
  std::optional<double> duration_s;
  std::string out = "demo-out";
  std::optional<std::uint64_t> seed;
  double bringup_s = 6.0;
  std::optional<int> domain;
  std::string dds_config;
  std::string onboard_bin, station_bin;
  // Agreement with offline eval, percentage points (docs/demo.md "Tolerance").
  double tolerance_da_pct = 5.0;
  double tolerance_sa_pct = 1.0;
  double tolerance_map_sa_pct = 8.0;  // the map-based methods (frequency, visibility, combined)
  double tolerance_map_da_pct = 10.0;
  std::string methods = "all";
  bool quiet = false;
  // Live faults (docs/demo.md "Faults"), times in seconds of world time.
  std::optional<double> kill_station_at_s;
  double station_down_s = 2.0;
  std::optional<int> unplug_robot;
  double unplug_at_s = 0, unplug_for_s = 2.0;
  std::optional<int> kill_robot;
  double kill_robot_at_s = 0;
  // Onboard [odometry] max_hold_s (unset: the daemon's default, docs/demo.md "Latency").
  std::optional<double> max_hold_s;
  // Station [fusion] write_interval_s (0: the model is written once, at shutdown).
  double write_interval_s = 0.0;
  // The ground station's live fusion method (its [fusion] method); the demo scores its model.
  std::string station_method = "best";
  // The station's [fusion] compare_methods: "paper" (the paper's methods and best, but station_method),
  // "none", or a comma-separated list; each compared model gets the identity check of the primary's.
  std::string station_compare = "paper";
  // The station's [ros2] publishers (rt/teamscan/map_cloud, rt/tf, rt/robotN/odom; docs/ros2.md).
  bool station_ros2 = true;
  // The device feeder: one thread steps every pty this often (ms); 0: a thread per pty (sim/live.hpp).
  double feed_period_ms = 1.0;
  bool no_precast = false;  // cast every scan in real time instead of ahead (sim/live.hpp precast)
  bool secure = false;      // DDS Security with a throwaway site PKI in <out>/pki (docs/security.md)
  // The station's browser view on 127.0.0.1:PORT (its [view] listen; unset: off), docs/view.md.
  std::optional<int> view_port;
  // Scan-to-map registration in the station's fusion core (its [registration]) and in the demo's
  // `teamscan eval` runs (--registration); unset: on when the scenario's robots drift
  // (scenario_drifts), docs/demo.md "Registration".
  std::optional<bool> registration;
  // The pose graph as the station's back end (its [pose_graph]; docs/slam.md "The back end"): the report
  // scores the graph's poses against the truth and checks them against its replay of the session. Unset:
  // on (the station's default) but with --no-registration (odometry alone).
  std::optional<bool> pose_graph;
  // Each robot's odometry prior for the registration (`teamscan calibrate`'s output): appended to the
  // station's config and taken by the demo's evaluations; empty: none (docs/registration.md).
  std::string calibration_path;
  // Radio link faults (docs/radio.md "Link faults"): every process in a network namespace of its own
  // (needs root), packet loss on every link (--link-loss "20", "20%" or "200pm") and shadows (--shadow
  // ROBOT:AT:FOR, a robot's link down for a while); the namespaces' names start with netns_prefix
  // (empty: "tsdemo<pid>-").
  std::string link_loss;
  std::vector<std::string> shadows;
  std::string netns_prefix;
};

// Whether a scenario's odometry drifts: a robot with a skid-steer term in its [robot.odometry]
// (systematic slip, turn slip, heading drift per metre, heading random walk). The per-cycle jitter every
// scenario has (slip_sigma, heading_sigma) is not drift: it averages out.
[[nodiscard]] bool scenario_drifts(const sim::Scenario& scenario);

// --station-compare as the station's [fusion] compare_methods: "paper": the paper's methods and best
// without the station's own; "none": none; else the comma-separated list (the station validates it).
[[nodiscard]] std::vector<std::string> station_compare_methods(const DemoOptions& a);

// Runs the demo; the process exit code (0: nothing lost, live and offline agree, the station's models are
// identical to `teamscan eval` of its session, clean exits; 1: a check failed; 2: bad options).
[[nodiscard]] int run_demo(const DemoOptions& a);

}  // namespace teamscan::demo
