// Live fusion throughput on one core: scans per second through FusionStage::add_scan (tracker
// prediction, filter observe + classify, voxel map) for each method, alone and with the paper's methods
// compared side by side (compare_methods), and the cost of a fused-model write at the end of a
// lap2-like survey: the whole write on the caller's thread (write_model: the shutdown write, and what
// every periodic write cost the receive loop before), and the loop's share of a write off the loop
// (request_write: the snapshot; the files on the writer thread).
// Run: build/dev/tests/bench/station/station_fusion_bench   (figures in docs/groundstation.md)
#include <benchmark/benchmark.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <memory>
#include <map>

#include <time.h>

#include "groundstation/station/fusion.hpp"
#include "tests/bench/mapping/synthetic_survey.hpp"

namespace {

using namespace teamscan;
using namespace teamscan::station;

std::int32_t mm(double m) { return static_cast<std::int32_t>(std::lround(m * 1000.0)); }

struct Feed {
  std::vector<PoseObservation> poses;  // in order, interleaved with scans by stamp
  std::vector<ScanPoints> scans;
};

// The default survey: 10 m room, 2 robots, 30 s at 10 Hz, 181 beams (lap2-like), as the station stores it.
const Feed& feed() {
  static const Feed f = [] {
    const Dataset d = bench::synthetic_survey(bench::SurveyOptions{});
    Feed out;
    std::map<std::pair<int, std::uint32_t>, std::vector<const LabelledPoint*>> points;
    for (const LabelledPoint& p : d.points) points[{p.robot, p.scan}].push_back(&p);
    for (const TrajectorySample& s : d.odom) {
      PoseObservation p;
      p.robot_id = s.robot;
      p.stamp = Time::from_ns(s.stamp_ns);
      p.x_m = s.pose.x_m;
      p.y_m = s.pose.y_m;
      p.yaw_rad = s.pose.theta_rad;
      p.vx_mps = s.v_mps * std::cos(s.pose.theta_rad);
      p.vy_mps = s.v_mps * std::sin(s.pose.theta_rad);
      out.poses.push_back(p);
    }
    out.scans.resize(d.scans.size());
    for (std::size_t i = 0; i < d.scans.size(); ++i) {
      const ScanRecord& r = d.scans[i];
      ScanPoints& s = out.scans[i];
      s.robot_id = r.robot;
      s.seq = r.scan;
      s.stamp = Time::from_ns(r.stamp_ns);
      s.origin_x_mm = mm(r.origin.x);
      s.origin_y_mm = mm(r.origin.y);
      s.origin_z_mm = mm(r.origin.z);
      for (const LabelledPoint* p : points[{r.robot, r.scan}])
        s.points[s.count++] = ScanPoint{mm(p->x), mm(p->y), mm(p->z), p->beam, 0};
    }
    return out;
  }();
  return f;
}

void run_feed(FusionStage& stage, const Feed& f) {
  std::size_t next_pose = 0;
  for (const ScanPoints& s : f.scans) {
    while (next_pose < f.poses.size() && f.poses[next_pose].stamp.ns() <= s.stamp.ns()) stage.add_pose(f.poses[next_pose++]);
    stage.add_scan(s, Receipt{});
  }
}

// best_ray_stride: best's free-space part casts every Nth ray (MethodOptions::best_freespace; 0: the default).
void BM_LiveScans(benchmark::State& state, const char* method, double resolution_m, std::uint32_t best_ray_stride = 0) {
  const Feed& f = feed();
  std::uint64_t points = 0;
  for (auto _ : state) {
    FusionOptions o;
    o.core.method = method;
    o.core.methods.frequency.resolution_m = o.core.methods.visibility.resolution_m = o.core.methods.combined_resolution_m = resolution_m;
    if (best_ray_stride > 0) o.core.methods.best_freespace.ray_stride = best_ray_stride;
    auto stage = FusionStage::create(o, "/tmp");
    run_feed(**stage, f);
    (*stage)->flush();
    points += (*stage)->counters().points;
    benchmark::DoNotOptimize((*stage)->counters().live_removed);
  }
  state.counters["scans_per_s"] =
      benchmark::Counter(static_cast<double>(f.scans.size() * state.iterations()), benchmark::Counter::kIsRate);
  state.counters["points_per_s"] = benchmark::Counter(static_cast<double>(points), benchmark::Counter::kIsRate);
}
BENCHMARK_CAPTURE(BM_LiveScans, best, "best", 0.1)->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_LiveScans, best_every_ray, "best", 0.1, 1u)->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_LiveScans, combined_0_1m, "combined", 0.1)->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_LiveScans, visibility_0_05m, "visibility", 0.05)->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_LiveScans, frequency_0_05m, "frequency", 0.05)->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_LiveScans, direction, "direction", 0.1)->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_LiveScans, position, "position", 0.1)->Unit(benchmark::kMillisecond);

// The capacity benchmark's load in one process, without DDS (tests/bench/station/run_capacity.sh feeds the
// same survey over DDS): N robots × 75 Hz for `seconds` of robot time, each copy of the lap2-like
// template driving its own 12 m cell (station_feeder's layout), scans interleaved robot by robot, poses at
// 10 Hz, arrival = stamp, the capacity run's decision lag (0.15 s). Every scan grows the maps, as in the
// first lap of a 32-robot survey: the CPU per scan here is the station loop's share of
// run_capacity.sh's cpu_ms_per_scan, repeatable on a loaded machine (counter cpu_us_per_scan); the third
// argument turns the scan-to-map registration on (counter corrections: the corrections it set). Stalls
// as thread CPU per call (one turn of the loop), without wall-clock noise: scan_call_max / p999 / p99,
// and with the registration the calls that updated its reference or ran a match.
struct TeamFeed {
  std::vector<PoseObservation> poses;
  std::vector<ScanPoints> scans;  // in arrival order, poses interleaved by stamp (pose_before[i])
  std::vector<Receipt> receipts;  // receipts[i]: scans[i]'s
  std::vector<std::size_t> poses_before;  // poses to add before scans[i]
};

const TeamFeed& team_feed(int robots, double seconds) {
  static std::map<std::pair<int, int>, TeamFeed> cache;
  auto key = std::make_pair(robots, static_cast<int>(seconds * 1000));
  if (auto it = cache.find(key); it != cache.end()) return it->second;
  bench::SurveyOptions so;
  so.scan_hz = 75.0;
  const double a = 0.3 * so.room_m, b = 0.2 * so.room_m;
  so.duration_s = 3.14159265358979 * (3 * (a + b) - std::sqrt((3 * a + b) * (a + 3 * b))) / so.speed_mps;
  const Dataset d = bench::synthetic_survey(so);
  struct Template {
    std::vector<const ScanRecord*> scans;
    std::vector<std::vector<const LabelledPoint*>> points;
    std::vector<const TrajectorySample*> odom;
  };
  std::map<int, Template> templates;
  std::map<std::pair<int, std::uint32_t>, std::size_t> at;
  for (const ScanRecord& r : d.scans) {
    Template& t = templates[r.robot];
    at[{r.robot, r.scan}] = t.scans.size();
    t.scans.push_back(&r);
    t.points.emplace_back();
  }
  for (const LabelledPoint& p : d.points) templates[p.robot].points[at[{p.robot, p.scan}]].push_back(&p);
  for (const TrajectorySample& s : d.odom) templates[s.robot].odom.push_back(&s);
  std::vector<const Template*> list;
  for (const auto& [id, t] : templates) list.push_back(&t);
  TeamFeed out;
  const std::int64_t t0_ns = 1'700'000'000'000'000'000;
  const auto scans_per_robot = static_cast<std::size_t>(seconds * 75.0);
  std::size_t pose_k = 0;
  for (std::size_t k = 0; k < scans_per_robot; ++k) {
    const std::int64_t stamp_ns = t0_ns + static_cast<std::int64_t>(static_cast<double>(k) * 1e9 / 75.0);
    // Poses at 10 Hz, from each robot's template odometry at the same index fraction.
    while (t0_ns + static_cast<std::int64_t>(pose_k) * 100'000'000 <= stamp_ns) {
      for (int i = 0; i < robots; ++i) {
        const Template& t = *list[static_cast<std::size_t>(i) % list.size()];
        const int cell = i / static_cast<int>(list.size());
        const double ox = (cell % 8) * 12.0, oy = (cell / 8) * 12.0;
        const std::size_t phase = static_cast<std::size_t>(cell) * 37;
        const std::size_t scan_index = (pose_k * 75 / 10 + phase) % t.scans.size();
        const std::size_t odom_index = std::min(t.odom.size() - 1, scan_index * t.odom.size() / t.scans.size());
        const TrajectorySample& s = *t.odom[odom_index];
        PoseObservation p;
        p.robot_id = static_cast<std::uint32_t>(i + 1);
        p.stamp = Time::from_ns(t0_ns + static_cast<std::int64_t>(pose_k) * 100'000'000);
        p.received = p.stamp;
        p.x_m = s.pose.x_m + ox;
        p.y_m = s.pose.y_m + oy;
        p.yaw_rad = s.pose.theta_rad;
        p.vx_mps = s.v_mps * std::cos(s.pose.theta_rad);
        p.vy_mps = s.v_mps * std::sin(s.pose.theta_rad);
        out.poses.push_back(p);
      }
      ++pose_k;
    }
    for (int i = 0; i < robots; ++i) {
      const Template& t = *list[static_cast<std::size_t>(i) % list.size()];
      const int cell = i / static_cast<int>(list.size());
      const double ox = (cell % 8) * 12.0, oy = (cell / 8) * 12.0;
      const std::size_t j = (k + static_cast<std::size_t>(cell) * 37) % t.scans.size();
      out.scans.emplace_back();
      ScanPoints& s = out.scans.back();
      s.robot_id = static_cast<std::uint32_t>(i + 1);
      s.seq = static_cast<std::uint32_t>(k + 1);
      s.stamp = Time::from_ns(stamp_ns + i * 13'333'333 / robots);
      const std::int64_t received_ns = s.stamp.ns() + 2'000'000;
      out.receipts.push_back(Receipt{received_ns, received_ns, 0});
      s.origin_x_mm = mm(t.scans[j]->origin.x + ox);
      s.origin_y_mm = mm(t.scans[j]->origin.y + oy);
      s.origin_z_mm = mm(t.scans[j]->origin.z);
      for (const LabelledPoint* p : t.points[j])
        if (s.count < kMaxBeams) s.points[s.count++] = ScanPoint{mm(p->x + ox), mm(p->y + oy), mm(p->z), p->beam, 0};
      out.poses_before.push_back(out.poses.size());
    }
  }
  return cache.emplace(key, std::move(out)).first->second;
}

double thread_cpu_s() {
  timespec t{};
  ::clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
  return static_cast<double>(t.tv_sec) + 1e-9 * static_cast<double>(t.tv_nsec);
}

// The p-quantile (0..1) of `v` (sorted in place).
double quantile(std::vector<double>& v, double p) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  return v[std::min(v.size() - 1, static_cast<std::size_t>(p * static_cast<double>(v.size())))];
}

void BM_LiveScansTeam(benchmark::State& state) {
  const TeamFeed& f = team_feed(static_cast<int>(state.range(0)), static_cast<double>(state.range(1)));
  double cpu_s = 0, corrections = 0;
  // Stalls without wall-clock noise: the thread CPU of each call (one turn of the station's loop: a
  // scan, or a pose, and whatever it releases through the core), the registration's reference updates
  // among them (a call during which Registration::reference_updates() moved).
  // The first 2 s of robot time are left out of the figures (start-up: the core's hold releases its
  // first second of scans in one call, startup_call_max_ms).
  std::vector<double> scan_call_s, update_call_s, match_call_s, busy_ms;
  double pose_call_max_s = 0, startup_call_max_s = 0;
  const std::int64_t steady_from_ns = f.scans.empty() ? 0 : f.scans.front().stamp.ns() + 2'000'000'000;
  std::uint64_t updates = 0, columns = 0, dropped = 0, reference_features = 0, matches = 0;
  for (auto _ : state) {
    FusionOptions o;
    o.core.tracker.team_lag_s = 0.15;
    o.core.registration = state.range(2) != 0;
    if (state.range(3) > 0) o.core.methods.best_freespace.ray_stride = static_cast<std::uint32_t>(state.range(3));
    auto stage = FusionStage::create(o, "/tmp");
    const registration::Registration* reg = (*stage)->core().registration();
    scan_call_s.clear();
    scan_call_s.reserve(f.scans.size());
    // The scan calls' CPU per millisecond of robot time (their stamps): the busiest 50 ms window is what
    // the loop must do in 50 ms when the scans arrive on time (more than 50 ms of CPU: they queue).
    busy_ms.assign(static_cast<std::size_t>((f.scans.back().stamp.ns() - f.scans.front().stamp.ns()) / 1'000'000) + 1, 0.0);
    update_call_s.clear();
    match_call_s.clear();
    // Matches tried so far by every robot (a call that ran one or more).
    auto tried = [&] {
      std::uint64_t n = 0;
      if (reg)
        for (std::uint8_t r = 1; r <= state.range(0); ++r)
          if (const registration::RobotCorrection* c = reg->correction(r)) n += c->matches;
      return n;
    };
    // TEAMSCAN_BENCH_LONGEST_CALLS=1 prints the 20 longest scan calls (over 10 ms) with the reference's
    // voxels before and after (a doubling of a hash map shows as a long call at its load limit).
    struct Long {
      double s;
      std::size_t scan, voxels_before, voxels_after;
      bool operator<(const Long& o) const { return s < o.s; }
    };
    std::vector<Long> longest;
    const double c0 = thread_cpu_s();
    std::size_t next_pose = 0;
    for (std::size_t i = 0; i < f.scans.size(); ++i) {
      while (next_pose < f.poses_before[i]) {
        const std::uint64_t u0 = reg ? reg->reference_updates() : 0;
        const double t0 = thread_cpu_s();
        (*stage)->add_pose(f.poses[next_pose++]);
        const double dt = thread_cpu_s() - t0;
        if (f.scans[i].stamp.ns() < steady_from_ns) {
          startup_call_max_s = std::max(startup_call_max_s, dt);
          continue;
        }
        pose_call_max_s = std::max(pose_call_max_s, dt);
        if (reg && reg->reference_updates() != u0) update_call_s.push_back(dt);
      }
      const std::uint64_t u0 = reg ? reg->reference_updates() : 0, m0 = tried();
      const std::size_t v0 = reg ? reg->reference_voxels() : 0;
      const double t0 = thread_cpu_s();
      (*stage)->add_scan(f.scans[i], f.receipts[i]);
      const double dt = thread_cpu_s() - t0;
      if (f.scans[i].stamp.ns() < steady_from_ns) {
        startup_call_max_s = std::max(startup_call_max_s, dt);
        continue;
      }
      scan_call_s.push_back(dt);
      busy_ms[static_cast<std::size_t>((f.scans[i].stamp.ns() - f.scans.front().stamp.ns()) / 1'000'000)] += dt;
      if (reg && reg->reference_updates() != u0) update_call_s.push_back(dt);
      if (reg && tried() != m0) match_call_s.push_back(dt);
      if (dt > 0.010) longest.push_back({dt, i, v0, reg ? reg->reference_voxels() : 0});
    }
    (*stage)->flush();
    cpu_s += thread_cpu_s() - c0;
    if (std::getenv("TEAMSCAN_BENCH_LONGEST_CALLS") != nullptr) {
      std::sort(longest.rbegin(), longest.rend());
      for (std::size_t k = 0; k < longest.size() && k < 20; ++k) {
        const ScanPoints& sc = f.scans[longest[k].scan];
        std::fprintf(stderr, "call %.1f ms: scan %zu (robot %u, %.3f s), registration reference %zu -> %zu voxels\n",
                     1e3 * longest[k].s, longest[k].scan, sc.robot_id,
                     1e-9 * static_cast<double>(sc.stamp.ns() - f.scans.front().stamp.ns()), longest[k].voxels_before,
                     longest[k].voxels_after);
      }
    }
    corrections = static_cast<double>((*stage)->core().counters().registration_corrections);
    if (reg) {
      updates = reg->reference_updates();
      columns = reg->reference_columns_updated();
      reference_features = reg->reference_features();
      dropped = reg->reference_map().dropped();
      matches = 0;
      for (std::uint8_t r = 1; r <= state.range(0); ++r)
        if (const registration::RobotCorrection* c = reg->correction(r)) matches += c->matches;
    }
    benchmark::DoNotOptimize((*stage)->counters().live_removed);
  }
  const double scans = static_cast<double>(f.scans.size() * state.iterations());
  state.counters["scans"] = static_cast<double>(f.scans.size());
  state.counters["cpu_us_per_scan"] = 1e6 * cpu_s / scans;
  state.counters["corrections"] = static_cast<double>(corrections);
  // The last iteration's calls from 2 s on: the longest, p99.9 and p99 of a scan's call (ms of thread CPU).
  state.counters["scan_call_max_ms"] = 1e3 * quantile(scan_call_s, 1.0);
  state.counters["scan_call_p999_ms"] = 1e3 * quantile(scan_call_s, 0.999);
  state.counters["scan_call_p99_ms"] = 1e3 * quantile(scan_call_s, 0.99);
  std::vector<double> windows;  // every 50 ms window of robot time from 2 s on, by the millisecond
  double window_s = 0;
  for (std::size_t k = 0; k < busy_ms.size(); ++k) {
    window_s += busy_ms[k];
    if (k >= 50) window_s -= busy_ms[k - 50];
    if (k >= 2050) windows.push_back(window_s);
  }
  state.counters["cpu_ms_per_50ms_max"] = 1e3 * quantile(windows, 1.0);
  state.counters["cpu_ms_per_50ms_p99"] = 1e3 * quantile(windows, 0.99);
  state.counters["cpu_ms_per_50ms_p50"] = 1e3 * quantile(windows, 0.5);
  state.counters["pose_call_max_ms"] = 1e3 * pose_call_max_s;
  state.counters["startup_call_max_ms"] = 1e3 * startup_call_max_s;
  if (state.range(2) != 0) {
    // The calls that updated the registration's reference: how many, their longest and median.
    state.counters["ref_updates"] = static_cast<double>(updates);
    state.counters["ref_columns_per_update"] = updates ? static_cast<double>(columns) / static_cast<double>(updates) : 0.0;
    state.counters["ref_features"] = static_cast<double>(reference_features);
    state.counters["ref_dropped"] = static_cast<double>(dropped);  // features beyond LineMap::kMaxPerGroup (0)
    state.counters["update_call_max_ms"] = 1e3 * quantile(update_call_s, 1.0);
    state.counters["update_call_p50_ms"] = 1e3 * quantile(update_call_s, 0.5);
    state.counters["matches"] = static_cast<double>(matches);
    // The calls that ran a match (window features + ICP; in the loop like the rest).
    state.counters["match_call_max_ms"] = 1e3 * quantile(match_call_s, 1.0);
    state.counters["match_call_p50_ms"] = 1e3 * quantile(match_call_s, 0.5);
  }
}
// Args: robots, seconds of robot time, registration (0 off, 1 on: docs/registration.md "Cost"), best's
// ray stride (0: the default, 1: every ray cast; docs/beyond.md "A cheaper free-space walk").
BENCHMARK(BM_LiveScansTeam)->Args({32, 10, 0, 0})->Args({32, 10, 1, 0})->Args({32, 10, 0, 1})->Iterations(1)->Unit(benchmark::kMillisecond);

// best with the paper's five methods decided side by side: six cores on the same input.
void BM_LiveScansCompared(benchmark::State& state) {
  const Feed& f = feed();
  for (auto _ : state) {
    FusionOptions o;
    o.compare_methods = {"frequency", "visibility", "position", "direction", "combined"};
    auto stage = FusionStage::create(o, "/tmp");
    run_feed(**stage, f);
    (*stage)->flush();
    benchmark::DoNotOptimize((*stage)->counters().live_removed);
  }
  state.counters["scans_per_s"] =
      benchmark::Counter(static_cast<double>(f.scans.size() * state.iterations()), benchmark::Counter::kIsRate);
}
BENCHMARK(BM_LiveScansCompared)->Unit(benchmark::kMillisecond);

// One fused-model write after the whole survey, from the core's memory: every stored point decided
// against the map + two PCDs (kept, all with keep).
// A stage in `dir` (created) that has fused the whole survey, writing fused.pcd and fused_all.pcd.
std::unique_ptr<FusionStage> fed_stage(const std::string& dir) {
  std::filesystem::create_directories(dir);
  FusionOptions o;
  o.all_points_pcd = "fused_all.pcd";
  auto stage = FusionStage::create(o, dir);
  run_feed(**stage, feed());
  (*stage)->flush();
  return std::move(stage.value());
}

void BM_WriteModel(benchmark::State& state) {
  const std::string dir = std::filesystem::temp_directory_path() / "teamscan-station-fusion-bench";
  const std::unique_ptr<FusionStage> stage = fed_stage(dir);
  for (auto _ : state) {
    if (!stage->write_model().ok()) state.SkipWithError("write failed");
  }
  state.counters["points"] = static_cast<double>(stage->counters().points);
  state.counters["scans"] = static_cast<double>(stage->counters().scans);
  std::filesystem::remove_all(dir);
}
BENCHMARK(BM_WriteModel)->Unit(benchmark::kMillisecond);

// A periodic write as the station's loop runs it: request_write(), then poll_write() every turn until
// the write is done (the loop's turns are back to back here). Timed: the whole write; counters: the
// loop's time on it (loop_ms: the snapshot's slices), its longest stall (longest_slice_ms, at most about
// fusion.write_slice_ms), the writer thread's time (writer_thread_ms).
void BM_RequestWrite(benchmark::State& state) {
  const std::string dir = std::filesystem::temp_directory_path() / "teamscan-station-fusion-bench-async";
  const std::unique_ptr<FusionStage> stage = fed_stage(dir);
  double loop_s = 0, slice_max_s = 0, thread_s = 0, slices = 0;
  for (auto _ : state) {
    stage->request_write();
    while (stage->write_in_flight()) (void)stage->poll_write();
    (void)stage->poll_write();
    const ModelWriteReport& w = stage->last_write();
    if (!w.ok) state.SkipWithError("write failed");
    loop_s += w.snapshot_s;
    slice_max_s = std::max(slice_max_s, w.snapshot_slice_max_s);
    thread_s += w.write_s;
    slices += w.snapshot_slices;
  }
  const double n = state.iterations() ? static_cast<double>(state.iterations()) : 1.0;
  state.counters["points"] = static_cast<double>(stage->counters().points);
  state.counters["loop_ms"] = 1e3 * loop_s / n;
  state.counters["longest_slice_ms"] = 1e3 * slice_max_s;
  state.counters["slices"] = slices / n;
  state.counters["writer_thread_ms"] = 1e3 * thread_s / n;
  std::filesystem::remove_all(dir);
}
BENCHMARK(BM_RequestWrite)->Unit(benchmark::kMillisecond);

}  // namespace
