// Mapping benchmarks. Figures, not pass/fail:
//  - points per second of each filter (offline and live) at 0.05 and 0.1 m on a lap2-like survey;
//  - bytes per occupied voxel, and map memory against room size (a hollow room's occupancy grows
//    with its surface, not its volume: the paper's reason for a sparse map);
//  - RANSAC floor fit on 1 M points;
//  - OctoMap's ray-cast insertion of the same scans at the same resolution, with the ratio.
#include <benchmark/benchmark.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <random>

#include "groundstation/fusion/evaluation.hpp"
#include "groundstation/mapping/ransac.hpp"
#include "tests/bench/mapping/synthetic_survey.hpp"

#include <octomap/octomap.h>

namespace teamscan::mapping {
namespace {
using fusion::PreparedDataset;
using fusion::PreparedScan;
using fusion::prepare_dataset;
using fusion::run_live;
using fusion::run_offline;

// TEAMSCAN_BENCH_DATASET=DIR runs the filter benchmarks on a data set from `teamscan sim` (e.g. lap2);
// otherwise two robots in a 10 m room, 60 s of scans at 10 Hz (the paper's lap is about a minute).
const Dataset& lap_like() {
  static const Dataset d = bench::bench_dataset_or_survey("mapping_bench", 60.0);
  return d;
}

const PreparedDataset& lap_prepared() {
  static const PreparedDataset p = prepare_dataset(lap_like(), {});
  return p;
}

MethodOptions at(double resolution_m) {
  MethodOptions o;
  o.frequency.resolution_m = o.visibility.resolution_m = o.combined_resolution_m = resolution_m;
  return o;
}

void filter_bench(benchmark::State& state, const char* method, bool live) {
  const double resolution_m = static_cast<double>(state.range(0)) / 100.0;
  const PreparedDataset& p = lap_prepared();
  auto filter = make_filter(method, at(resolution_m));
  std::size_t removed = 0;
  for (auto _ : state) {
    const auto r = live ? run_live(p, *filter) : run_offline(p, *filter);
    removed = static_cast<std::size_t>(std::count(r.begin(), r.end(), std::uint8_t{1}));
    benchmark::DoNotOptimize(removed);
  }
  state.SetItemsProcessed(static_cast<std::int64_t>(state.iterations() * p.points.size()));
  state.counters["points"] = static_cast<double>(p.points.size());
  state.counters["removed_share"] = static_cast<double>(removed) / static_cast<double>(p.points.size());
}

void BM_FilterOffline_Frequency(benchmark::State& s) { filter_bench(s, "frequency", false); }
void BM_FilterOffline_Visibility(benchmark::State& s) { filter_bench(s, "visibility", false); }
void BM_FilterOffline_Position(benchmark::State& s) { filter_bench(s, "position", false); }
void BM_FilterOffline_Direction(benchmark::State& s) { filter_bench(s, "direction", false); }
void BM_FilterOffline_Combined(benchmark::State& s) { filter_bench(s, "combined", false); }
void BM_FilterLive_Frequency(benchmark::State& s) { filter_bench(s, "frequency", true); }
void BM_FilterLive_Visibility(benchmark::State& s) { filter_bench(s, "visibility", true); }
void BM_FilterLive_Combined(benchmark::State& s) { filter_bench(s, "combined", true); }
// Argument: resolution in centimetres (5 → 0.05 m, 10 → 0.1 m). Robot-based filters ignore it.
BENCHMARK(BM_FilterOffline_Frequency)->Arg(5)->Arg(10)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_FilterOffline_Visibility)->Arg(5)->Arg(10)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_FilterOffline_Position)->Arg(5)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_FilterOffline_Direction)->Arg(5)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_FilterOffline_Combined)->Arg(10)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_FilterLive_Frequency)->Arg(5)->Arg(10)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_FilterLive_Visibility)->Arg(5)->Arg(10)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_FilterLive_Combined)->Arg(10)->Unit(benchmark::kMillisecond);

// Hollow room of side L (height 2.5 m): every surface sampled twice per voxel edge, jittered.
void BM_VoxelMapMemoryByRoomSize(benchmark::State& state) {
  const double room_m = static_cast<double>(state.range(0));
  const double resolution_m = static_cast<double>(state.range(1)) / 100.0;
  const double height_m = 2.5, step = resolution_m / 2;
  std::mt19937_64 rng(1);
  std::uniform_real_distribution<double> jitter(0.0, step);
  std::vector<MapPoint> cloud;
  for (double u = 0; u < room_m; u += step)
    for (double v = 0; v < room_m; v += step) {
      cloud.push_back({static_cast<float>(u + jitter(rng)), static_cast<float>(v + jitter(rng)), 0.0f});
      cloud.push_back({static_cast<float>(u + jitter(rng)), static_cast<float>(v + jitter(rng)), static_cast<float>(height_m - 0.01)});
    }
  for (double u = 0; u < room_m; u += step)
    for (double h = 0; h < height_m; h += step) {
      const auto hz = static_cast<float>(h + jitter(rng));
      cloud.push_back({static_cast<float>(u + jitter(rng)), 0.0f, hz});
      cloud.push_back({static_cast<float>(u + jitter(rng)), static_cast<float>(room_m - 0.01), hz});
      cloud.push_back({0.0f, static_cast<float>(u + jitter(rng)), hz});
      cloud.push_back({static_cast<float>(room_m - 0.01), static_cast<float>(u + jitter(rng)), hz});
    }
  std::size_t voxels = 0, bytes = 0;
  for (auto _ : state) {
    VoxelMap map(resolution_m);
    map.insert(cloud);  // batch path
    voxels = map.occupied_voxels();
    bytes = map.memory_bytes();
    benchmark::DoNotOptimize(voxels);
  }
  const double dense_voxels = (room_m / resolution_m) * (room_m / resolution_m) * (height_m / resolution_m);
  state.SetItemsProcessed(static_cast<std::int64_t>(state.iterations() * cloud.size()));
  state.counters["voxels"] = static_cast<double>(voxels);
  state.counters["MiB"] = static_cast<double>(bytes) / (1024.0 * 1024.0);
  state.counters["bytes_per_voxel"] = static_cast<double>(bytes) / static_cast<double>(voxels);
  state.counters["occupied_pct_of_volume"] = 100.0 * static_cast<double>(voxels) / dense_voxels;
  state.counters["dense_grid_MiB"] = dense_voxels * 4.0 / (1024.0 * 1024.0);  // a uint32 count per voxel
}
BENCHMARK(BM_VoxelMapMemoryByRoomSize)
    ->ArgsProduct({{5, 10, 20, 40}, {5, 10}})
    ->ArgNames({"room_m", "res_cm"})
    ->Unit(benchmark::kMillisecond)
    ->Iterations(3);

// 1 M points: 40 % floor (σ 4 mm), walls, ceiling and clutter (like ANCHORS §3.5's PCL smoke test).
void BM_Ransac1M(benchmark::State& state) {
  static const std::vector<MapPoint> cloud = [] {
    std::mt19937_64 rng(3);
    std::uniform_real_distribution<double> u(0.0, 10.0), h(0.0, 2.5);
    std::normal_distribution<double> n(0.0, 0.004);
    std::vector<MapPoint> c;
    c.reserve(1'000'000);
    for (int i = 0; i < 400'000; ++i) c.push_back({static_cast<float>(u(rng)), static_cast<float>(u(rng)), static_cast<float>(n(rng))});
    for (int i = 0; i < 300'000; ++i) c.push_back({static_cast<float>(u(rng)), 0.0f, static_cast<float>(h(rng))});
    for (int i = 0; i < 200'000; ++i) c.push_back({static_cast<float>(u(rng)), static_cast<float>(u(rng)), 2.5f});
    for (int i = 0; i < 100'000; ++i) c.push_back({static_cast<float>(u(rng)), static_cast<float>(u(rng)), static_cast<float>(h(rng))});
    return c;
  }();
  RansacOptions o;
  o.threshold_m = 0.04;
  o.iterations = static_cast<int>(state.range(0));
  if (state.range(1) == 0) {  // unconstrained plane (PCL SACMODEL_PLANE); 1: floor constraints on
    o.max_tilt_deg = 0;
    o.max_height_m = INFINITY;
  }
  std::size_t inliers = 0;
  for (auto _ : state) {
    const PlaneFit f = fit_plane_ransac(cloud, o);
    inliers = f.inliers;
    benchmark::DoNotOptimize(inliers);
  }
  state.counters["inliers"] = static_cast<double>(inliers);
  state.SetItemsProcessed(static_cast<std::int64_t>(state.iterations() * cloud.size()));
}
BENCHMARK(BM_Ransac1M)->ArgsProduct({{100, 500}, {0, 1}})->ArgNames({"iterations", "floor_constrained"})->Unit(benchmark::kMillisecond)->Iterations(2);

// The same scans into OctoMap (ray-cast insertion, the DynamicMap benchmark's baseline) and into our
// sparse map + visibility filter, side by side: the ratio is ours / OctoMap in points per second.
void BM_OctomapVsVoxelMap(benchmark::State& state) {
  const double resolution_m = static_cast<double>(state.range(0)) / 100.0;
  static const Dataset d = [] {
    bench::SurveyOptions o;
    o.duration_s = 10.0;  // OctoMap at 0.05 m is slow: keep one iteration under a few seconds
    return bench::synthetic_survey(o);
  }();
  static const PreparedDataset p = prepare_dataset(d, {});
  double octomap_s = 0, ours_s = 0;
  for (auto _ : state) {
    using clock = std::chrono::steady_clock;
    const auto t0 = clock::now();
    octomap::OcTree tree(resolution_m);
    for (std::size_t s = 0; s < p.scans.size(); ++s) {
      const PreparedScan& ps = p.scans[s];
      octomap::Pointcloud cloud;
      for (std::size_t i = ps.first; i < ps.first + ps.count; ++i) cloud.push_back(p.points[i].x, p.points[i].y, p.points[i].z);
      const Vec3& o = ps.record.origin;
      tree.insertPointCloud(cloud, octomap::point3d(static_cast<float>(o.x), static_cast<float>(o.y), static_cast<float>(o.z)));
    }
    const auto t1 = clock::now();
    auto filter = make_filter("visibility", at(resolution_m));
    const auto removed = run_live(p, *filter);
    const auto t2 = clock::now();
    benchmark::DoNotOptimize(removed.data());
    octomap_s += std::chrono::duration<double>(t1 - t0).count();
    ours_s += std::chrono::duration<double>(t2 - t1).count();
  }
  const double n = static_cast<double>(p.points.size()) * static_cast<double>(state.iterations());
  state.counters["points"] = static_cast<double>(p.points.size());
  state.counters["octomap_pts_per_s"] = n / octomap_s;
  state.counters["ours_pts_per_s"] = n / ours_s;
  state.counters["ratio_ours_over_octomap"] = octomap_s / ours_s;
}
BENCHMARK(BM_OctomapVsVoxelMap)->Arg(5)->Arg(10)->Unit(benchmark::kMillisecond)->Iterations(1);

}  // namespace
}  // namespace teamscan::mapping
