// The stages of `teamscan demo` (demo.hpp) and what passes between them: configure (DemoSetup), start
// the processes and run the world with its faults (RunRecord), then collect, score and report
// (demo_report.hpp). Private to tools/demo.
#pragma once

#include <chrono>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "groundstation/registration/registration.hpp"
#include "sim/live.hpp"
#include "sim/scenario.hpp"
#include "tools/demo/demo.hpp"
#include "tools/demo/link_faults.hpp"
#include "tools/demo/progress.hpp"
#include "tools/demo/supervisor.hpp"

namespace teamscan::demo {

// What the options resolve to before anything starts.
struct DemoSetup {
  std::chrono::steady_clock::time_point wall_start;
  sim::Scenario scenario;
  double duration_s = 0;
  bool registration = false;
  std::string registration_why;  // "on: the scenario's robots drift", ...
  bool pose_graph = true;        // the station's [pose_graph] enabled (DemoOptions::pose_graph resolved)
  registration::RegistrationOptions priors;
  std::string calibration_toml;  // appended to the station's config
  std::string dds;               // the Cyclone DDS config file
  int domain = 0;
  std::string onboard_bin, station_bin;
  std::string out, session, pki_dir;  // absolute
  std::string station_config;         // out/config/groundstation.toml
  // Link faults (link_faults.hpp): the namespaces while they exist (null: none, loopback) and the shadows.
  std::shared_ptr<LinkNetwork> links;
  std::vector<LinkShadow> shadows;
  int loss_permille = 0;
  bool namespaces = false;  // the processes run in network namespaces (also after `links` is released)
};

// What the run left behind for scoring: the processes (stopped, with exit codes and CPU), the truth
// of every scan the ray caster sent, the faults that happened, CPU figures of the run window.
struct RunRecord {
  std::vector<Child> children;     // [0] the ground station, [1..] one onboard daemon per robot, then killed stations
  std::size_t robot_children = 0;  // the onboard daemons among children
  std::size_t killed_child = 0;    // index in children of the daemon killed by --kill-robot (0: none)
  std::vector<std::vector<sim::LiveScanTruth>> truths;
  std::vector<std::string> faults;  // one line per fault event, in order
  bool interrupted = false, child_died = false;
  double precast_cpu_s = 0, feeder_cpu_s = 0, cast_cpu_s = 0, run_wall_s = 0;
  std::uint64_t precast_scans = 0;
};

// Configure: the options checked and resolved; 0 with `setup` filled, else the exit code (2: bad options).
[[nodiscard]] int configure_demo(const DemoOptions& a, DemoSetup& setup);

// Link faults (--link-loss, --shadow; link_faults.cpp): checked, `setup.dds` the config they derive from
// (2: bad syntax); then, once the output folder exists, the namespaces made (1: no root or no network
// namespaces). Both 0 without link faults.
[[nodiscard]] int check_link_faults(const DemoOptions& a, DemoSetup& setup);
[[nodiscard]] int make_link_network(const DemoOptions& a, DemoSetup& setup);

// Start the station and the robots, run the world to the duration with the faults, stop in order.
// 0 with `record` filled (also when a process died or the run was interrupted), else the exit code.
[[nodiscard]] int run_live(const DemoOptions& a, const DemoSetup& setup, sim::LiveTeam& live, Progress& progress,
                           RunRecord& record);

// Collect, score and report (demo_report.cpp): the exit code of the demo.
[[nodiscard]] int score_and_report(const DemoOptions& a, const DemoSetup& setup, sim::LiveTeam& live,
                                   Progress& progress, RunRecord& record);

}  // namespace teamscan::demo
