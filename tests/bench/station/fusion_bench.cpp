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
#include <filesystem>
#include <memory>
#include <map>

#include "groundstation/station/fusion.hpp"
#include "tests/bench/mapping/synthetic_survey.hpp"

namespace {

using namespace teamscan;
using namespace teamscan::station;

std::int32_t mm(double m) { return static_cast<std::int32_t>(std::lround(m * 1000.0)); }

struct Feed {
  std::vector<PoseObservation> poses;  // in order, interleaved with scans by stamp
  std::vector<StoredScan> scans;
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
      StoredScan& s = out.scans[i];
      s.robot_id = r.robot;
      s.seq = r.scan;
      s.stamp_ns = r.stamp_ns;
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
  for (const StoredScan& s : f.scans) {
    while (next_pose < f.poses.size() && f.poses[next_pose].stamp.ns() <= s.stamp_ns) stage.add_pose(f.poses[next_pose++]);
    stage.add_scan(s);
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
