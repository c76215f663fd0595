// Cost of the scan-to-map registration (docs/registration.md "Cost") on realistic input: the scans of
// a simulated lap2-drift survey (two robots, tilted LMS-200s, skid-steer drift), simulated once per
// process. BM_RegistrationAddScan: every scan through Registration::add_scan in stamp order, as the
// fusion core releases them: matches per second and the thread CPU of a call that ran a match against
// one that did not. BM_CoreBest: the fusion core (`teamscan eval`'s run_through_core, method best) with
// the registration off (0) and on (1): its share of the core's cost per scan. Figures only.
#include <benchmark/benchmark.h>

#include <time.h>

#include <algorithm>
#include <cstdlib>
#include <map>
#include <string>
#include <vector>

#include "common/point_flags.hpp"
#include "groundstation/fusion/evaluation.hpp"
#include "groundstation/registration/registration.hpp"
#include "sim/simulator.hpp"

namespace teamscan {
namespace {

// The first TEAMSCAN_BENCH_REG_SECONDS (default 60) of lap2-drift, direct path (no device streams).
const Dataset& survey() {
  static const Dataset d = [] {
    const char* src = std::getenv("TEAMSCAN_SOURCE_DIR");
    const std::string dir = src ? std::string{src} + "/sim/scenarios/" : std::string{TEAMSCAN_BENCH_SCENARIO_DIR} + "/";
    const sim::ScenarioLoad l = sim::load_scenario_file(dir + "lap2-drift.toml");
    if (!l.scenario) std::abort();
    sim::SimOptions o;
    o.device_streams = false;
    const char* s = std::getenv("TEAMSCAN_BENCH_REG_SECONDS");
    o.duration_s = s ? std::atof(s) : 60.0;
    return sim::simulate(*l.scenario, o).dataset;
  }();
  return d;
}

// One scan as the core hands it to the registration: odometry pose, points in the odometry-map frame.
struct Input {
  std::uint8_t robot = 0;
  std::int64_t stamp_ns = 0;
  Pose2 odom;
  std::vector<Vec3> points;
  std::vector<std::uint8_t> usable;
};

const std::vector<Input>& inputs() {
  static const std::vector<Input> in = [] {
    const Dataset& d = survey();
    std::vector<Input> out;
    std::map<std::pair<std::uint8_t, std::uint32_t>, std::size_t> at;
    for (const ScanRecord& s : d.scans) {
      at[{s.robot, s.scan}] = out.size();
      out.push_back({s.robot, s.stamp_ns, s.pose, {}, {}});
    }
    for (const LabelledPoint& p : d.points) {
      auto it = at.find({p.robot, p.scan});
      if (it == at.end()) continue;
      out[it->second].points.push_back({p.x, p.y, p.z});
      // The core keeps onboard-flagged points out of the match (and teammates' bodies, not modelled here).
      out[it->second].usable.push_back((p.flags & (point_flags::kInvalid | point_flags::kDirectionFiltered)) == 0 ? 1 : 0);
    }
    std::stable_sort(out.begin(), out.end(), [](const Input& a, const Input& b) {
      return a.stamp_ns != b.stamp_ns ? a.stamp_ns < b.stamp_ns : a.robot < b.robot;
    });
    return out;
  }();
  return in;
}

double cpu_s(clockid_t clock) {
  timespec ts{};
  ::clock_gettime(clock, &ts);
  return static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
}
double thread_cpu_s() { return cpu_s(CLOCK_THREAD_CPUTIME_ID); }

// One iteration: a fresh Registration fed the whole survey (the reference grows as in a run).
// Arg 0: match_delay_s = 0, everything on the caller's thread (the cost of a match itself: window grid,
// features, search, the reference's update when due). Arg 1: the default, matches and the reference on
// the match thread: the caller's CPU per scan, and the match thread's (the process's CPU less the
// caller's) per match.
void BM_RegistrationAddScan(benchmark::State& state) {
  const std::vector<Input>& in = inputs();
  double match_cpu_s = 0, other_cpu_s = 0, max_match_cpu_s = 0, worker_cpu_s = 0;
  std::uint64_t matches = 0, accepted = 0, others = 0, points = 0;
  registration::RegistrationOptions options;
  if (state.range(0) == 0) options.match_delay_s = 0.0;
  for (auto _ : state) {
    const double process0 = cpu_s(CLOCK_PROCESS_CPUTIME_ID), thread0 = thread_cpu_s();
    {
    registration::Registration reg(options);
    for (const Input& s : in) {
      const registration::RobotCorrection* before = reg.correction(s.robot);
      const std::uint64_t tried = before ? before->matches : 0;
      const double t0 = thread_cpu_s();
      const registration::RobotCorrection& c = reg.add_scan(s.robot, s.stamp_ns, s.odom, s.points, s.usable);
      const double dt = thread_cpu_s() - t0;
      points += s.points.size();
      if (c.matches != tried) {
        match_cpu_s += dt;
        max_match_cpu_s = std::max(max_match_cpu_s, dt);
        ++matches;
      } else {
        other_cpu_s += dt;
        ++others;
      }
    }
    for (std::uint8_t r = 1; r <= 2; ++r)
      if (const registration::RobotCorrection* c = reg.correction(r)) accepted += c->accepted;
    }  // the match thread joined
    worker_cpu_s += (cpu_s(CLOCK_PROCESS_CPUTIME_ID) - process0) - (thread_cpu_s() - thread0);
  }
  const auto n = static_cast<double>(state.iterations());
  state.counters["scans_per_s"] = benchmark::Counter(static_cast<double>(in.size()) * n, benchmark::Counter::kIsRate);
  state.counters["matches_per_s"] = benchmark::Counter(static_cast<double>(matches), benchmark::Counter::kIsRate);
  state.counters["matches"] = static_cast<double>(matches) / n;
  state.counters["accepted"] = static_cast<double>(accepted) / n;
  state.counters["points_per_scan"] = static_cast<double>(points) / (static_cast<double>(in.size()) * n);
  // Thread CPU per add_scan that ran a match (window features + ICP + reference rebuild when due), and
  // per add_scan without one (prediction, window, scans retired into the reference).
  state.counters["cpu_ms_per_match"] = matches ? 1e3 * match_cpu_s / static_cast<double>(matches) : 0.0;
  state.counters["cpu_ms_max_match"] = 1e3 * max_match_cpu_s;
  state.counters["cpu_us_per_other_scan"] = others ? 1e6 * other_cpu_s / static_cast<double>(others) : 0.0;
  state.counters["cpu_us_per_scan"] = 1e6 * (match_cpu_s + other_cpu_s) / (static_cast<double>(in.size()) * n);
  state.counters["match_thread_cpu_ms_per_match"] = matches ? 1e3 * worker_cpu_s / static_cast<double>(matches) : 0.0;
}
BENCHMARK(BM_RegistrationAddScan)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond)->Iterations(2);

// The fusion core on the survey, method best, registration off (0) / on (1): CPU per scan.
void BM_CoreBest(benchmark::State& state) {
  const Dataset& d = survey();
  fusion::CoreRunOptions run;
  run.registration = state.range(0) != 0;
  std::uint64_t accepted = 0;
  for (auto _ : state) {
    const fusion::CoreRun r = fusion::run_through_core(d, "best", {}, run).value();
    for (const registration::RobotCorrection& c : r.robots) accepted += c.accepted;
    benchmark::DoNotOptimize(r.removed.data());
  }
  const auto n = static_cast<double>(state.iterations());
  state.counters["scans_per_s"] = benchmark::Counter(static_cast<double>(d.scans.size()) * n, benchmark::Counter::kIsRate);
  // Seconds of CPU per scan (printed with an SI prefix: 150u = 150 µs).
  state.counters["cpu_per_scan"] =
      benchmark::Counter(static_cast<double>(d.scans.size()) * n, benchmark::Counter::kIsRate | benchmark::Counter::kInvert,
                         benchmark::Counter::OneK::kIs1000);
  state.counters["accepted"] = static_cast<double>(accepted) / n;
}
BENCHMARK(BM_CoreBest)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond)->Iterations(2);

}  // namespace
}  // namespace teamscan
