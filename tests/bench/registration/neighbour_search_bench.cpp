// The matcher's correspondence search (docs/registration.md "Library choice"): the nearest line
// feature within a gate whose normal agrees, answered by nanoflann's k-d tree (LineMap, the
// production index) and by an Eigen-only hash grid (cells of the gate's size, FlatKeyMap → CSR
// arrays), on the same synthetic walls at realistic reference sizes. Prints queries/s, index build
// time and the search time of one match (12 ICP iterations + the final assessment over a source of
// 300 features, the gate shrinking to 0.10 m as in match()); counts disagreements between the two.
// Figures, never a pass/fail test.
#include <benchmark/benchmark.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <random>
#include <vector>

#include <Eigen/Core>

#include "groundstation/mapping/flat_key_map.hpp"
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

// The alternative: an Eigen-only hash grid. Cells of `cell_m`; a query visits the cells its gate
// disc touches, keeps the 4 nearest within the gate (as LineMap's 4-nearest), then the first whose
// normal agrees: the same answer as LineMap::nearest.
class HashGrid {
 public:
  explicit HashGrid(double cell_m) : cell_m_{cell_m} {}

  void build(const std::vector<LineFeature>& features) {
    features_ = &features;
    cells_.clear();
    order_.resize(features.size());
    std::vector<std::pair<std::uint64_t, std::uint32_t>> keyed(features.size());
    for (std::size_t i = 0; i < features.size(); ++i)
      keyed[i] = {key(cell(features[i].x_m), cell(features[i].y_m)), static_cast<std::uint32_t>(i)};
    std::sort(keyed.begin(), keyed.end());
    cells_.reserve(keyed.size());
    for (std::size_t i = 0; i < keyed.size();) {
      std::size_t j = i;
      while (j < keyed.size() && keyed[j].first == keyed[i].first) {
        order_[j] = keyed[j].second;
        ++j;
      }
      cells_.get_or_insert(keyed[i].first, Range{static_cast<std::uint32_t>(i), static_cast<std::uint32_t>(j)});
      i = j;
    }
  }

  [[nodiscard]] std::ptrdiff_t nearest(double x, double y, double nx, double ny, double gate_m, double min_dot) const {
    constexpr int kK = 4;
    std::uint32_t idx[kK];
    double d2[kK];
    int found = 0;
    const double gate2 = gate_m * gate_m;
    const Eigen::Vector2d q{x, y};
    const std::int64_t x0 = cell(x - gate_m), x1 = cell(x + gate_m), y0 = cell(y - gate_m), y1 = cell(y + gate_m);
    for (std::int64_t cx = x0; cx <= x1; ++cx)
      for (std::int64_t cy = y0; cy <= y1; ++cy) {
        const Range* r = cells_.find(key(cx, cy));
        if (!r) continue;
        for (std::uint32_t k = r->begin; k < r->end; ++k) {
          const LineFeature& f = (*features_)[order_[k]];
          const double e2 = (Eigen::Vector2d{f.x_m, f.y_m} - q).squaredNorm();
          if (e2 > gate2 || (found == kK && e2 >= d2[kK - 1])) continue;
          int at = std::min(found, kK - 1);  // insertion into the sorted 4 nearest
          while (at > 0 && d2[at - 1] > e2) {
            if (at < kK) {
              d2[at] = d2[at - 1];
              idx[at] = idx[at - 1];
            }
            --at;
          }
          d2[at] = e2;
          idx[at] = order_[k];
          found = std::min(found + 1, kK);
        }
      }
    for (int k = 0; k < found; ++k) {
      const LineFeature& f = (*features_)[idx[k]];
      if (std::abs(f.nx * nx + f.ny * ny) >= min_dot) return static_cast<std::ptrdiff_t>(idx[k]);
    }
    return -1;
  }

 private:
  struct Range {
    std::uint32_t begin = 0, end = 0;
  };
  [[nodiscard]] std::int64_t cell(double v) const { return static_cast<std::int64_t>(std::floor(v / cell_m_)); }
  static std::uint64_t key(std::int64_t cx, std::int64_t cy) {
    constexpr std::int64_t kBias = 1 << 30;
    return (static_cast<std::uint64_t>(cx + kBias) << 31) | static_cast<std::uint64_t>(cy + kBias);
  }
  double cell_m_;
  const std::vector<LineFeature>* features_ = nullptr;
  mapping::FlatKeyMap<Range> cells_;
  std::vector<std::uint32_t> order_;
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
  LineMap index;
  index.build(map);
  std::size_t hits = 0;
  for (auto _ : state) hits = one_match(index, source, gate_start_m);
  state.SetItemsProcessed(state.iterations() * static_cast<std::int64_t>(source.size()) * (kIterations + 1));
  state.counters["hits_per_match"] = static_cast<double>(hits);
}

void BM_HashGrid_Search(benchmark::State& state) {
  const auto map = make_walls(static_cast<std::size_t>(state.range(0)), 1);
  const auto source = make_source(map, 2);
  HashGrid index{static_cast<double>(state.range(1)) / 100.0};
  const double gate_start_m = static_cast<double>(state.range(2)) / 100.0;
  index.build(map);
  std::size_t hits = 0;
  for (auto _ : state) hits = one_match(index, source, gate_start_m);
  // Same answers as the k-d tree? (ties at equal distance aside, they must be.)
  LineMap tree;
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
  LineMap index;
  for (auto _ : state) {
    index.build(map);
    benchmark::DoNotOptimize(index.size());
  }
  state.SetItemsProcessed(state.iterations() * state.range(0));
}

void BM_HashGrid_Build(benchmark::State& state) {
  const auto map = make_walls(static_cast<std::size_t>(state.range(0)), 1);
  HashGrid index{static_cast<double>(state.range(1)) / 100.0};
  for (auto _ : state) {
    index.build(map);
    benchmark::ClobberMemory();
  }
  state.SetItemsProcessed(state.iterations() * state.range(0));
}

// The whole match (the production matcher on the k-d tree): what share of it the search is.
void BM_Match_KdTree(benchmark::State& state) {
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
// reaches ~6 k), a large site (32 k). Grid cells 10 cm (the voxel) and 30 cm (the default widest
// gate). Gates opening at 30 cm (the default) and 100 cm (after a long unmatched stretch). The time
// per iteration is the search of one match (300 × 13 queries).
BENCHMARK(BM_KdTree_Search)->ArgsProduct({{2000, 8000, 32000}, {30, 100}})->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_HashGrid_Search)->ArgsProduct({{2000, 8000, 32000}, {10, 30}, {30, 100}})->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_KdTree_Build)->Arg(2000)->Arg(8000)->Arg(32000)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_HashGrid_Build)->Args({2000, 30})->Args({8000, 30})->Args({32000, 30})->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_Match_KdTree)->Arg(2000)->Arg(8000)->Arg(32000)->Unit(benchmark::kMicrosecond);

}  // namespace
}  // namespace teamscan::registration
