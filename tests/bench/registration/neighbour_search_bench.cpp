// The matcher's correspondence search (docs/registration.md "Library choice" and "Cost"): the nearest
// line feature within a gate whose normal agrees, answered by LineMap (the production index: a hash
// grid updated in place, searched ring by ring) and by nanoflann's k-d tree (the index before, rebuilt
// from every feature), on the same synthetic walls at realistic reference sizes. Prints queries/s,
// build and in-place update times and the search time of one match (12 ICP iterations + the final
// assessment over a source of 300 features, the gate shrinking to 0.10 m as in match()); counts
// disagreements between the two.
// Figures, never a pass/fail test.
#include <benchmark/benchmark.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <memory>
#include <random>
#include <span>
#include <vector>

#include <Eigen/Core>
#include <nanoflann.hpp>

#include "groundstation/registration/matcher.hpp"

namespace teamscan::registration {
namespace {

constexpr double kMinDot = 0.8;      // MatchOptions::min_normal_dot
constexpr std::size_t kSource = 300;  // source features of one match (a 2-D scan's points, a 3-D window's features)
constexpr int kIterations = 12;       // MatchOptions::iterations (+ 1 final assessment)

// Walls every 10 cm (the SurfaceGrid's voxel): rooms of 4 × 4 m in a square block, plus slanted
// furniture segments, until `n` features exist.
std::vector<LineFeature> make_walls(std::size_t n, std::uint32_t seed) {
  std::mt19937 rng{seed};
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::vector<LineFeature> out;
  out.reserve(n);
  const int rooms = static_cast<int>(std::ceil(std::sqrt(static_cast<double>(n) / 160.0)));  // ~160 features per room
  auto segment = [&](double x0, double y0, double x1, double y1) {
    const double len = std::hypot(x1 - x0, y1 - y0);
    const double nx = -(y1 - y0) / len, ny = (x1 - x0) / len;
    for (double s = 0.05; s < len && out.size() < n; s += 0.10)
      out.push_back({x0 + (x1 - x0) * s / len, y0 + (y1 - y0) * s / len, nx, ny, 20.0f});
  };
  for (int i = 0; i < rooms && out.size() < n; ++i)
    for (int j = 0; j < rooms && out.size() < n; ++j) {
      const double x = 4.0 * i, y = 4.0 * j;
      segment(x, y, x + 4, y);
      segment(x, y, x, y + 4);
      const double cx = x + 0.5 + 3 * u(rng), cy = y + 0.5 + 3 * u(rng), a = 3.14159 * u(rng);
      segment(cx, cy, cx + 1.2 * std::cos(a), cy + 1.2 * std::sin(a));
    }
  return out;
}

// A match's source: features of the map seen again with 2 cm of noise, shifted by a 6 cm / 1°
// odometry error, and 15 % clutter that has no counterpart.
std::vector<LineFeature> make_source(const std::vector<LineFeature>& map, std::uint32_t seed) {
  std::mt19937 rng{seed};
  std::normal_distribution<double> noise(0.0, 0.02);
  std::uniform_int_distribution<std::size_t> pick(0, map.size() - 1);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  const std::size_t centre = pick(rng);
  const double cx = map[centre].x_m, cy = map[centre].y_m, c = std::cos(0.017), s = std::sin(0.017);
  std::vector<LineFeature> out;
  out.reserve(kSource);
  while (out.size() < kSource) {
    const LineFeature& f = map[pick(rng)];
    if (std::hypot(f.x_m - cx, f.y_m - cy) > 8.0) continue;  // what one robot sees around it
    LineFeature g = f;
    if (u(rng) < 0.15) {
      g.x_m += 0.5 * (u(rng) - 0.5);
      g.y_m += 0.5 * (u(rng) - 0.5);
    }
    const double x = g.x_m - cx + noise(rng), y = g.y_m - cy + noise(rng);
    g.x_m = cx + c * x - s * y + 0.06;
    g.y_m = cy + s * x + c * y - 0.03;
    out.push_back(g);
  }
  return out;
}

// The index LineMap had before (until it was updated in place): nanoflann's k-d tree over the
// features, rebuilt from all of them; the same answer (the 4 nearest, then the first whose normal
// agrees).
class KdTree {
 public:
  void build(const std::vector<LineFeature>& features) {
    cloud_.f = &features;
    tree_ = std::make_unique<Tree>(2, cloud_, nanoflann::KDTreeSingleIndexAdaptorParams{10});
  }

  [[nodiscard]] std::ptrdiff_t nearest(double x, double y, double nx, double ny, double gate_m, double min_dot) const {
    constexpr std::size_t kK = 4;
    std::uint32_t idx[kK];
    double d2[kK];
    const double q[2] = {x, y};
    const std::size_t found = tree_->knnSearch(q, kK, idx, d2);
    for (std::size_t k = 0; k < found; ++k) {
      if (d2[k] > gate_m * gate_m) break;
      const LineFeature& f = (*cloud_.f)[idx[k]];
      if ((nx == 0 && ny == 0) || std::abs(f.nx * nx + f.ny * ny) >= min_dot) return static_cast<std::ptrdiff_t>(idx[k]);
    }
    return -1;
  }

 private:
  struct Cloud {
    const std::vector<LineFeature>* f = nullptr;
    [[nodiscard]] std::size_t kdtree_get_point_count() const { return f->size(); }
    [[nodiscard]] double kdtree_get_pt(std::size_t i, std::size_t dim) const { return dim == 0 ? (*f)[i].x_m : (*f)[i].y_m; }
    template <class Box>
    bool kdtree_get_bbox(Box&) const {
      return false;
    }
  };
  using Tree = nanoflann::KDTreeSingleIndexAdaptor<nanoflann::L2_Simple_Adaptor<double, Cloud>, Cloud, 2, std::uint32_t>;
  Cloud cloud_;
  std::unique_ptr<Tree> tree_;
};

// The gate of iteration `it`: from `start_m` (0.30 m; wider after a long unmatched stretch, when the
// bounded step opens with the prediction's 3σ) down to 0.10 m.
double gate_of(int it, double start_m) {
  return start_m + (0.10 - start_m) * std::min(1.0, static_cast<double>(it) / (kIterations - 1));
}

// One match's queries (12 iterations + the final one), returns how many found a correspondence.
template <class Index>
std::size_t one_match(const Index& index, const std::vector<LineFeature>& source, double gate_start_m) {
  std::size_t hits = 0;
  for (int it = 0; it <= kIterations; ++it)
    for (const LineFeature& f : source) hits += index.nearest(f.x_m, f.y_m, f.nx, f.ny, gate_of(it, gate_start_m), kMinDot) >= 0;
  return hits;
}

void BM_KdTree_Search(benchmark::State& state) {
  const auto map = make_walls(static_cast<std::size_t>(state.range(0)), 1);
  const auto source = make_source(map, 2);
  const double gate_start_m = static_cast<double>(state.range(1)) / 100.0;
  KdTree index;
  index.build(map);
  std::size_t hits = 0;
  for (auto _ : state) hits = one_match(index, source, gate_start_m);
  state.SetItemsProcessed(state.iterations() * static_cast<std::int64_t>(source.size()) * (kIterations + 1));
  state.counters["hits_per_match"] = static_cast<double>(hits);
}

// LineMap (the production index: a hash grid searched ring by ring) with cells of range(1) cm.
void BM_LineMap_Search(benchmark::State& state) {
  const auto map = make_walls(static_cast<std::size_t>(state.range(0)), 1);
  const auto source = make_source(map, 2);
  LineMap index{static_cast<double>(state.range(1)) / 100.0};
  const double gate_start_m = static_cast<double>(state.range(2)) / 100.0;
  index.build(map);
  std::size_t hits = 0;
  for (auto _ : state) hits = one_match(index, source, gate_start_m);
  // Same answers as the k-d tree? (ties at equal distance aside, they must be.)
  KdTree tree;
  tree.build(map);
  std::size_t disagree = 0;
  for (int it = 0; it <= kIterations; ++it)
    for (const LineFeature& f : source)
      disagree += tree.nearest(f.x_m, f.y_m, f.nx, f.ny, gate_of(it, gate_start_m), kMinDot) !=
                  index.nearest(f.x_m, f.y_m, f.nx, f.ny, gate_of(it, gate_start_m), kMinDot);
  state.SetItemsProcessed(state.iterations() * static_cast<std::int64_t>(source.size()) * (kIterations + 1));
  state.counters["hits_per_match"] = static_cast<double>(hits);
  state.counters["disagreements"] = static_cast<double>(disagree);
}

void BM_KdTree_Build(benchmark::State& state) {
  const auto map = make_walls(static_cast<std::size_t>(state.range(0)), 1);
  KdTree index;
  for (auto _ : state) {
    index.build(map);
    benchmark::ClobberMemory();
  }
  state.SetItemsProcessed(state.iterations() * state.range(0));
}

void BM_LineMap_Build(benchmark::State& state) {
  const auto map = make_walls(static_cast<std::size_t>(state.range(0)), 1);
  LineMap index{static_cast<double>(state.range(1)) / 100.0};
  for (auto _ : state) {
    index.build(map);
    benchmark::DoNotOptimize(index.size());
  }
  state.SetItemsProcessed(state.iterations() * state.range(0));
}

// An update in place: 1 000 of the map's features (groups) replaced by themselves moved 1 cm, what an
// update of the reference does per changed column; items = features replaced.
void BM_LineMap_Replace(benchmark::State& state) {
  const auto map = make_walls(static_cast<std::size_t>(state.range(0)), 1);
  LineMap index;
  index.build(map);
  std::mt19937 rng{3};
  std::uniform_int_distribution<std::size_t> pick(0, map.size() - 1);
  double shift = 0.01;
  for (auto _ : state) {
    for (int k = 0; k < 1000; ++k) {
      const std::size_t i = pick(rng);
      LineFeature f = map[i];
      f.x_m += shift;
      index.replace(i, std::span<const LineFeature>{&f, 1});
    }
    shift = -shift;
  }
  state.SetItemsProcessed(state.iterations() * 1000);
}

// The whole match (the production matcher on LineMap): what share of it the search is.
void BM_Match(benchmark::State& state) {
  const auto map = make_walls(static_cast<std::size_t>(state.range(0)), 1);
  const auto source = make_source(map, 2);
  LineMap index;
  index.build(map);
  MatchOptions o;
  std::size_t accepted = 0;
  for (auto _ : state) {
    const MatchResult m = match(index, source, Pose2{}, o);
    accepted += m.status == MatchStatus::accepted;
    benchmark::DoNotOptimize(m.rms_m);
  }
  state.counters["accepted_share"] = static_cast<double>(accepted) / static_cast<double>(state.iterations());
  state.SetItemsProcessed(state.iterations());  // matches/s
}

// Reference sizes: a room (2 k features), a floor of a building (8 k, the Intel lab's reference
// reaches ~6 k; 32 robots' after 10 s of their first lap ~8 k), a large site (32 k). Grid cells 10,
// 25 and 50 cm. Gates opening at 30 cm (the default) and 100 cm (after a long unmatched stretch). The
// time per iteration is the search of one match (300 × 13 queries).
BENCHMARK(BM_KdTree_Search)->ArgsProduct({{2000, 8000, 32000}, {30, 100}})->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_LineMap_Search)->ArgsProduct({{2000, 8000, 32000}, {10, 25, 50}, {30, 100}})->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_KdTree_Build)->Arg(2000)->Arg(8000)->Arg(32000)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_LineMap_Build)->Args({2000, 25})->Args({8000, 25})->Args({32000, 25})->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_LineMap_Replace)->Arg(8000)->Arg(32000)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_Match)->Arg(2000)->Arg(8000)->Arg(32000)->Unit(benchmark::kMicrosecond);

}  // namespace
}  // namespace teamscan::registration
