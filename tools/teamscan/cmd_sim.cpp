// `teamscan sim SCENARIO --out DIR`: simulates a team survey and writes the labelled data set
// (dataset.toml, points.pcd, scans.csv, truth.csv, odom.csv) and each robot's serial captures
// (captures/robotN-arcos.cap, captures/robotN-lms200.cap), with progress on stderr and the point,
// ghost and timing counts at the end.
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <ctime>
#include <cstdio>
#include <filesystem>
#include <optional>
#include <string>

#include "sim/simulator.hpp"
#include "tools/teamscan/subcommand.hpp"

namespace teamscan::tool {
namespace {

struct SimArgs {
  std::string scenario;
  std::string out;
  std::optional<std::uint64_t> seed;
  std::optional<double> duration_s;
  bool benchmark = false;
  bool quiet = false;
  bool direct = false;
};

// captures/robotN-arcos.cap and captures/robotN-lms200.cap (common/capture.hpp format).
bool write_captures(const std::string& out_dir, const std::vector<sim::RobotCaptures>& captures) {
  namespace fs = std::filesystem;
  std::error_code ec;
  const fs::path dir = fs::path(out_dir) / "captures";
  fs::create_directories(dir, ec);
  if (ec) {
    std::fprintf(stderr, "teamscan sim: cannot create %s: %s\n", dir.c_str(), ec.message().c_str());
    return false;
  }
  for (const sim::RobotCaptures& c : captures) {
    for (const auto& [suffix, capture] : {std::pair<const char*, const Capture*>{"arcos", &c.arcos}, {"lms200", &c.lms200}}) {
      const fs::path path = dir / ("robot" + std::to_string(c.id) + "-" + suffix + ".cap");
      std::FILE* f = std::fopen(path.c_str(), "wb");
      const std::string text = format_capture(*capture);
      const bool ok = f != nullptr && std::fwrite(text.data(), 1, text.size(), f) == text.size();
      if (f != nullptr && std::fclose(f) != 0) return false;
      if (!ok) {
        std::fprintf(stderr, "teamscan sim: cannot write %s\n", path.c_str());
        return false;
      }
    }
  }
  return true;
}

int run_sim(const SimArgs& args) {
  const sim::ScenarioLoad load = sim::resolve_scenario(args.scenario);
  if (!load.scenario) {
    std::fprintf(stderr, "teamscan sim: %s\n", load.error.c_str());
    return 2;
  }
  if (args.out.empty() && !args.benchmark) {
    std::fprintf(stderr, "teamscan sim: --out DIR is required (or --benchmark to only time the simulation)\n");
    return 2;
  }
  const sim::Scenario& scenario = *load.scenario;
  sim::SimOptions options;
  options.seed = args.seed;
  options.duration_s = args.duration_s;
  options.device_streams = !args.direct;
  const bool show_progress = !args.quiet && isatty(STDERR_FILENO);
  const auto wall_start = std::chrono::steady_clock::now();
  const std::clock_t cpu_start = std::clock();
  if (!args.quiet) {
    options.progress = [&, last_shown = -1](double fraction) mutable {
      const int percent = static_cast<int>(fraction * 100.0);
      if (percent == last_shown) return;
      // On a terminal a line that rewrites itself; in a log every 10 %.
      if (show_progress) {
        std::fprintf(stderr, "\rteamscan sim: %s %3d %%", scenario.name.c_str(), percent);
        if (percent >= 100) std::fputc('\n', stderr);
      } else if (percent % 10 == 0 && percent / 10 != last_shown / 10) {
        std::fprintf(stderr, "teamscan sim: %s %d %%\n", scenario.name.c_str(), percent);
      }
      last_shown = percent;
    };
  }
  const sim::SimOutput out = sim::simulate(scenario, options);
  const double sim_wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_start).count();
  // CPU time too: on a shared machine the wall clock also counts other processes' turns.
  const double sim_cpu_s = static_cast<double>(std::clock() - cpu_start) / CLOCKS_PER_SEC;

  if (!args.out.empty()) {
    const Status written = write_dataset(args.out, out.dataset);
    if (!written) {
      std::fprintf(stderr, "teamscan sim: cannot write the data set to %s: %s (%ld)\n", args.out.c_str(),
                   written.error().what, written.error().detail);
      return 1;
    }
    if (!write_captures(args.out, out.captures)) return 1;
  }
  const double total_wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_start).count();

  std::uint64_t points = 0, ghosts = 0;
  std::printf("scenario %s, seed %llu, %.1f s simulated, %zu robots\n", scenario.name.c_str(),
              static_cast<unsigned long long>(out.dataset.seed), out.dataset.duration_s, out.stats.size());
  for (const sim::RobotStats& s : out.stats) {
    std::printf("  robot %u: %llu scans, %llu beams, %llu points, %llu no-return/out-of-range, %llu ghosts", s.id,
                static_cast<unsigned long long>(s.scans), static_cast<unsigned long long>(s.beams),
                static_cast<unsigned long long>(s.points), static_cast<unsigned long long>(s.invalid),
                static_cast<unsigned long long>(s.ghosts));
    for (std::size_t k = 1; k <= kMaxRobots; ++k) {
      if (s.ghosts_by_robot[k] > 0)
        std::printf(" (%llu on robot %zu)", static_cast<unsigned long long>(s.ghosts_by_robot[k]), k);
    }
    std::printf("\n");
    points += s.points;
    ghosts += s.ghosts;
  }
  for (const sim::RobotCaptures& c : out.captures) {
    if (!c.arcos_connected || !c.lms_streaming)
      std::fprintf(stderr, "teamscan sim: warning: robot %u's devices were not up when it started to drive (ARCOS %s, LMS %s)\n",
                   c.id, c.arcos_connected ? "connected" : "not connected", c.lms_streaming ? "streaming" : "not streaming");
  }
  std::printf("  total: %llu points, %llu ghosts (%.2f %%)\n", static_cast<unsigned long long>(points),
              static_cast<unsigned long long>(ghosts), points ? 100.0 * static_cast<double>(ghosts) / static_cast<double>(points) : 0.0);
  std::printf("  time: simulation %.2f s wall (%.1f x real time), %.2f s CPU (%.1f x real time); with writing %.2f s wall\n",
              sim_wall_s, out.dataset.duration_s / sim_wall_s, sim_cpu_s, out.dataset.duration_s / std::max(sim_cpu_s, 1e-9),
              total_wall_s);
  if (!args.out.empty())
    std::printf("  data set: %s%s\n", args.out.c_str(), out.captures.empty() ? "" : " (with captures/)");
  return 0;
}

const SubcommandRegistration kSim{
    {"sim", "Simulate a robot team survey and write the labelled data set", [](CLI::App& app) {
       auto args = std::make_shared<SimArgs>();
       std::string names;
       for (const auto& n : sim::builtin_scenario_names()) names += (names.empty() ? "" : ", ") + n;
       app.add_option("scenario", args->scenario, "Built-in scenario (" + names + ") or path to a scenario .toml")
           ->required();
       app.add_option("--out,-o", args->out, "Output folder for the data set (created if missing)");
       app.add_option("--seed", args->seed, "Random seed (overrides the scenario's `seed`)");
       app.add_option("--duration", args->duration_s, "Simulated seconds (default: the scenario's, or until every robot is done)")
           ->check(CLI::PositiveNumber);
       app.add_flag("--benchmark", args->benchmark, "Report the simulation speed (x real time); --out is optional");
       app.add_flag("--quiet,-q", args->quiet, "No progress on stderr");
       app.add_flag("--direct", args->direct,
                    "Skip the serial device streams (no captures): device fields decoded in process, faster");
       app.footer("Scenario keys: sim/scenarios/README.md. The data set format: docs/formats.md.");
       return [args] { return run_sim(*args); };
     }}};

}  // namespace
}  // namespace teamscan::tool
