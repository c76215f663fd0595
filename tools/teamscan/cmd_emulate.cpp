// `teamscan emulate`: a scenario's robots as emulated Pioneers and LMS-200s on pseudo-terminals, fed
// by the simulator in real time × --speed (sim/live.hpp), for a real teamscan-onboard to open.
#include <atomic>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <thread>

#include "sim/live.hpp"
#include "sim/scenario.hpp"
#include "tools/teamscan/subcommand.hpp"

namespace teamscan::tool {
namespace {

std::atomic<bool> g_emulate_stop{false};
extern "C" void emulate_on_signal(int) { g_emulate_stop.store(true); }

struct EmulateArgs {
  std::string scenario = "lap2";
  std::vector<int> robots;
  std::string run_dir = "run";
  double speed = 1.0;
  std::optional<double> duration_s;
  std::optional<std::uint64_t> seed;
  double bringup_s = 5.0;
  bool loop = false;
};

int run_emulate(const EmulateArgs& a) {
  const sim::ScenarioLoad load = sim::resolve_scenario(a.scenario);
  if (!load.scenario) {
    std::fprintf(stderr, "teamscan emulate: %s\n", load.error.c_str());
    return 2;
  }
  sim::LiveOptions o;
  o.run_dir = a.run_dir;
  o.speed = a.speed;
  o.seed = a.seed;
  o.bringup_s = a.bringup_s;
  o.loop = a.loop;
  for (int id : a.robots) o.robot_ids.push_back(static_cast<std::uint8_t>(id));
  auto live = sim::LiveTeam::create(*load.scenario, o);
  if (!live) {
    std::fprintf(stderr, "teamscan emulate: %s\n", live.error().what);
    return 1;
  }
  std::signal(SIGINT, emulate_on_signal);
  std::signal(SIGTERM, emulate_on_signal);
  if (Status s = live.value()->start(); !s) {
    std::fprintf(stderr, "teamscan emulate: %s\n", s.error().what);
    return 1;
  }
  sim::LiveTeam& team = *live.value();
  for (std::size_t i = 0; i < team.robot_count(); ++i)
    std::printf("robot%u: arcos %s (%u Bd)  lms200 %s (9600 Bd at power-up)\n", static_cast<unsigned>(team.spec(i).id),
                team.arcos_path(i).c_str(), static_cast<unsigned>(team.spec(i).arcos_baud), team.lms_path(i).c_str());
  std::printf("robots drive from world time 0, %.1f s from now, at %.2fx real time; Ctrl-C stops\n", a.bringup_s, a.speed);
  std::fflush(stdout);
  while (!g_emulate_stop.load()) {
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
    // Truth is only needed by `teamscan demo`; drop it here so memory stays bounded.
    for (std::size_t i = 0; i < team.robot_count(); ++i) (void)team.take_truth(i);
    if (a.duration_s && team.world_time_s() >= *a.duration_s) break;
  }
  team.stop();
  for (std::size_t i = 0; i < team.robot_count(); ++i)
    std::printf("robot%u: %llu scans measured, %llu beams hit a teammate\n", static_cast<unsigned>(team.spec(i).id),
                static_cast<unsigned long long>(team.scans_measured(i)), static_cast<unsigned long long>(team.ghost_beams(i)));
  return 0;
}

const SubcommandRegistration kEmulate{
    {"emulate", "Run a scenario's Pioneers and LMS-200s on pseudo-terminals, fed by the simulator in real time",
     [](CLI::App& app) {
       auto a = std::make_shared<EmulateArgs>();
       app.add_option("--scenario", a->scenario, "Built-in scenario (lap2, fig8, ...) or a TOML file")->capture_default_str();
       app.add_option("--robot", a->robots, "Robot id(s) to emulate (default: all of the scenario)");
       app.add_option("--run-dir", a->run_dir, "Folder for the pty symlinks robotN-arcos, robotN-lms200")->capture_default_str();
       app.add_option("--speed", a->speed, "World seconds per wall-clock second")->capture_default_str()->check(CLI::PositiveNumber);
       app.add_option("--duration", a->duration_s, "Stop at this world time in seconds (default: until Ctrl-C)");
       app.add_option("--seed", a->seed, "Override the scenario's seed");
       app.add_option("--bringup", a->bringup_s, "Seconds the robots stand still after start (device bring-up)")
           ->capture_default_str();
       app.add_flag("--loop", a->loop,
                    "Repeat the scenario's motion forever (world time runs on; the tracks restart at their end), "
                    "for soak runs such as tests/bench/onboard/rss_soak.sh");
       return [a] { return run_emulate(*a); };
     }}};

}  // namespace
}  // namespace teamscan::tool
