// The team's reference updated in proportion to what changed: SurfaceGrid::take_changes (the changed
// columns' features) applied to a LineMap column by column must give exactly the features of a grid
// built from scratch on the same points; LineMap::nearest, updated in place, must answer as a brute-force
// search over its current features.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <random>
#include <utility>
#include <vector>

#include "groundstation/registration/matcher.hpp"
#include "groundstation/registration/registration.hpp"
#include "groundstation/registration/surface_grid.hpp"
#include "tests/unit/registration/synthetic_scene.hpp"

namespace teamscan::registration {
namespace {

using testing::Scene;

// Applies every change since the last call to `map` (what Registration does at an update).
std::size_t apply_changes(SurfaceGrid& grid, LineMap& map) {
  std::vector<ColumnChange> columns;
  std::vector<LineFeature> features;
  grid.take_changes(columns, features);
  const std::span<const LineFeature> all{features};
  for (const ColumnChange& c : columns) map.replace(c.column, all.subspan(c.begin, c.end - c.begin));
  return columns.size();
}

// The features of a grid fed `points` from scratch.
std::vector<LineFeature> features_from_scratch(const std::vector<Vec3>& points, const SurfaceOptions& o) {
  SurfaceGrid scratch{o};
  for (const Vec3& p : points) (void)scratch.add(p);
  std::vector<LineFeature> out;
  scratch.features(out);
  return out;
}

// Every feature of `map`, by column and place in it.
std::vector<std::pair<std::uint64_t, LineFeature>> collected(const LineMap& map) {
  std::vector<std::pair<std::uint64_t, LineFeature>> out;
  map.collect(out);
  return out;
}

// `map`'s features (by column, place in it) against a grid fed the same points from scratch.
void expect_same_as_from_scratch(const LineMap& map, const std::vector<Vec3>& points, const SurfaceOptions& o) {
  const std::vector<LineFeature> expected = features_from_scratch(points, o);
  const std::vector<std::pair<std::uint64_t, LineFeature>> got = collected(map);
  ASSERT_EQ(got.size(), expected.size());
  ASSERT_GT(got.size(), 0u);
  for (std::size_t i = 0; i < got.size(); ++i) {
    const LineFeature& a = got[i].second;
    const LineFeature& b = expected[i];
    ASSERT_NEAR(a.x_m, b.x_m, 1e-9) << i;
    ASSERT_NEAR(a.y_m, b.y_m, 1e-9) << i;
    ASSERT_NEAR(a.nx, b.nx, 1e-9) << i;
    ASSERT_NEAR(a.ny, b.ny, 1e-9) << i;
    ASSERT_EQ(a.weight, b.weight) << i;
  }
}

// A furnished room seen from several places, plus a tilted laser's stripes on a wall (pooled per
// column), in batches like scans retired into the reference.
std::vector<std::vector<Vec3>> batches(std::mt19937_64& rng) {
  Scene s = Scene::room(8, 6, 2.5);
  s.box(-1.0, -1.0, 1.2, 0.6, 0.9);
  s.box(2.5, 2.0, 0.6, 0.8, 1.8);
  std::vector<std::vector<Vec3>> out;
  for (int i = 0; i < 40; ++i) {
    const Vec2 at{-3.5 + 0.18 * i, -2.5 + 0.12 * i};  // across the room: each batch sees a part of it
    out.push_back(s.sample(at, 1.5, 1500 + 100 * (i % 7), rng));
  }
  std::normal_distribution<double> g(0.0, 0.003);
  for (int sweep = 0; sweep < 8; ++sweep) {
    std::vector<Vec3> b;
    const double z = 0.15 + 0.1 * sweep;
    for (double x = -2.0; x < 2.0; x += 0.01) b.push_back({x + g(rng), 2.95 + g(rng), z + g(rng)});
    out.insert(out.begin() + 5 * sweep + 3, b);  // between the room's batches
  }
  return out;
}

TEST(IncrementalReference, ChangedColumnsGiveTheFeaturesOfABuildFromScratch) {
  std::mt19937_64 rng{11};
  const auto in = batches(rng);
  SurfaceOptions o;
  o.voxel_cap = 48;  // the reference's: full voxels stop changing, others keep changing
  SurfaceGrid grid{o, /*track_columns=*/true};
  LineMap map;
  std::vector<Vec3> all;
  std::size_t recomputed = 0;
  for (std::size_t b = 0; b < in.size(); ++b) {
    for (const Vec3& p : in[b]) (void)grid.add(p);
    all.insert(all.end(), in[b].begin(), in[b].end());
    if (b % 3 != 2 && b + 1 != in.size()) continue;  // an update every few batches, as at the update cadence
    recomputed += apply_changes(grid, map);
    SCOPED_TRACE(::testing::Message() << "after batch " << b);
    expect_same_as_from_scratch(map, all, o);
  }
  // Proportional: far fewer column recomputations than a rebuild of every column at every update.
  EXPECT_LT(recomputed, grid.columns() * (in.size() / 3) / 2) << recomputed << " of " << grid.columns();
  // Nothing changed since: nothing to recompute.
  EXPECT_EQ(grid.changed_columns(), 0u);
  EXPECT_EQ(apply_changes(grid, map), 0u);
}

TEST(IncrementalReference, TheSameForHorizontalLasers) {
  // planar_scans: no verdict cache, a 2-D normal per voxel; columns of one voxel each.
  std::mt19937_64 rng{12};
  SurfaceOptions o;
  o.planar_scans = true;
  o.voxel_m = 0.15;
  o.min_points = 3;
  SurfaceGrid grid{o, true};
  LineMap map;
  std::vector<Vec3> all;
  std::normal_distribution<double> g(0.0, 0.01);
  for (int scan = 0; scan < 30; ++scan) {
    std::vector<Vec3> pts;
    for (int k = 0; k < 180; ++k) {
      const double a = 2 * 3.14159265358979 * k / 180.0 + 0.01 * scan;
      // A 6 × 4 m room seen from (0.1·scan, 0): where the beam meets the walls.
      const double ox = 0.1 * scan, c = std::cos(a), s = std::sin(a);
      const double tx = c > 0 ? (3.0 - ox) / c : c < 0 ? (-3.0 - ox) / c : 1e9;
      const double ty = s > 0 ? 2.0 / s : s < 0 ? -2.0 / s : 1e9;
      const double t = std::min(tx, ty);
      pts.push_back({ox + t * c + g(rng), t * s + g(rng), 0.3});
    }
    for (const Vec3& p : pts) (void)grid.add(p);
    all.insert(all.end(), pts.begin(), pts.end());
    (void)apply_changes(grid, map);
  }
  expect_same_as_from_scratch(map, all, o);
}

TEST(IncrementalReference, AMissedColumnIsSeen) {
  // The comparison itself catches a stale column: the map updated before the last batch differs.
  std::mt19937_64 rng{13};
  const auto in = batches(rng);
  SurfaceOptions o;
  SurfaceGrid grid{o, true};
  LineMap map;
  std::vector<Vec3> all;
  for (std::size_t b = 0; b + 1 < in.size(); ++b) {
    for (const Vec3& p : in[b]) (void)grid.add(p);
    all.insert(all.end(), in[b].begin(), in[b].end());
  }
  (void)apply_changes(grid, map);
  for (const Vec3& p : in.back()) (void)grid.add(p);
  all.insert(all.end(), in.back().begin(), in.back().end());
  ASSERT_GT(grid.changed_columns(), 0u);
  const std::vector<LineFeature> expected = features_from_scratch(all, o);
  const std::vector<std::pair<std::uint64_t, LineFeature>> got = collected(map);
  bool differs = got.size() != expected.size();
  for (std::size_t i = 0; !differs && i < got.size(); ++i)
    differs = got[i].second.x_m != expected[i].x_m || got[i].second.weight != expected[i].weight;
  EXPECT_TRUE(differs);
  (void)apply_changes(grid, map);
  expect_same_as_from_scratch(map, all, o);
}

// The brute-force answer of LineMap::nearest over `features` (group, place → feature): the 4 nearest
// within the gate by (distance², group, place), the first whose normal agrees.
const LineFeature* brute_nearest(const std::map<std::uint64_t, std::vector<LineFeature>>& features, double x, double y,
                                 double nx, double ny, double gate, double min_dot) {
  struct Hit {
    double d2;
    std::uint64_t group;
    std::size_t place;
    const LineFeature* f;
  };
  std::vector<Hit> hits;
  for (const auto& [group, list] : features)
    for (std::size_t i = 0; i < list.size(); ++i) {
      const double d2 = (list[i].x_m - x) * (list[i].x_m - x) + (list[i].y_m - y) * (list[i].y_m - y);
      if (d2 <= gate * gate) hits.push_back({d2, group, i, &list[i]});
    }
  std::sort(hits.begin(), hits.end(), [](const Hit& a, const Hit& b) {
    return a.d2 != b.d2 ? a.d2 < b.d2 : a.group != b.group ? a.group < b.group : a.place < b.place;
  });
  for (std::size_t k = 0; k < hits.size() && k < 4; ++k)
    if ((nx == 0 && ny == 0) || std::abs(hits[k].f->nx * nx + hits[k].f->ny * ny) >= min_dot) return hits[k].f;
  return nullptr;
}

TEST(LineMapIncremental, NearestAgreesWithABruteForceSearchThroughReplacements) {
  std::mt19937_64 rng{21};
  std::uniform_real_distribution<double> u(0.0, 1.0);
  auto random_feature = [&](double x0, double y0) {
    const double a = 2 * 3.14159265358979 * u(rng);
    // On a 5 cm lattice now and then: equal distances happen, and are broken by (group, place).
    double x = x0 + 3.0 * u(rng), y = y0 + 3.0 * u(rng);
    if (u(rng) < 0.3) {
      x = 0.05 * std::round(x / 0.05);
      y = 0.05 * std::round(y / 0.05);
    }
    return LineFeature{x, y, std::cos(a), std::sin(a), 1.0f};
  };
  std::map<std::uint64_t, std::vector<LineFeature>> model;
  for (const double cell_m : {0.1, 0.25, 1.0}) {
    LineMap map{cell_m};
    model.clear();
    std::size_t checked = 0, found = 0;
    for (int round = 0; round < 40; ++round) {
      // Replace, add or remove groups (columns) at random, in a 10 × 10 m area with denser spots.
      for (int k = 0; k < 60; ++k) {
        const std::uint64_t group = static_cast<std::uint64_t>(u(rng) * 400);
        const int n = static_cast<int>(u(rng) * 4);  // 0: removed
        std::vector<LineFeature> list;
        const double x0 = 10 * u(rng) - 5, y0 = 10 * u(rng) - 5;
        for (int i = 0; i < n; ++i) list.push_back(random_feature(x0 * (u(rng) < 0.5 ? 0.2 : 1.0), y0));
        map.replace(group, list);
        if (list.empty()) model.erase(group);
        else model[group] = list;
      }
      std::size_t live = 0;
      for (const auto& [g, l] : model) live += l.size();
      ASSERT_EQ(map.size(), live);
      for (int q = 0; q < 200; ++q) {
        const double x = 14 * u(rng) - 7, y = 14 * u(rng) - 7;
        const double gate = u(rng) < 0.2 ? 3.0 * u(rng) : 0.05 + 0.4 * u(rng);
        const bool bare = u(rng) < 0.2;
        const double a = 2 * 3.14159265358979 * u(rng);
        const double nx = bare ? 0.0 : std::cos(a), ny = bare ? 0.0 : std::sin(a);
        const LineFeature* want = brute_nearest(model, x, y, nx, ny, gate, 0.8);
        const std::ptrdiff_t got = map.nearest(x, y, nx, ny, gate, 0.8);
        ++checked;
        if (want == nullptr) {
          ASSERT_EQ(got, -1) << "query " << x << ", " << y << " gate " << gate;
          continue;
        }
        ++found;
        ASSERT_GE(got, 0) << "query " << x << ", " << y << " gate " << gate;
        const LineFeature& f = map.feature(static_cast<std::size_t>(got));
        ASSERT_EQ(f.x_m, want->x_m);
        ASSERT_EQ(f.y_m, want->y_m);
        ASSERT_EQ(f.nx, want->nx);
        ASSERT_EQ(f.ny, want->ny);
      }
    }
    EXPECT_GT(found, checked / 4) << "cell " << cell_m;  // the queries do find features
  }
}

TEST(LineMapIncremental, AQueryFarFromEveryFeatureWithAHugeGateStillFindsTheNearest) {
  LineMap map;
  const std::vector<LineFeature> f{{50.0, 50.0, 1.0, 0.0, 1.0f}, {50.3, 50.0, 1.0, 0.0, 1.0f}};
  map.build(f);
  const std::ptrdiff_t k = map.nearest(40.0, 45.0, 1.0, 0.0, 20.0, 0.8);
  ASSERT_GE(k, 0);
  EXPECT_EQ(map.feature(static_cast<std::size_t>(k)).x_m, 50.0);
  EXPECT_EQ(map.nearest(40.0, 45.0, 1.0, 0.0, 5.0, 0.8), -1);
  map.replace(0, {});
  map.replace(1, {});
  EXPECT_EQ(map.size(), 0u);
  EXPECT_EQ(map.nearest(50.0, 50.0, 1.0, 0.0, 1.0, 0.8), -1);
}

}  // namespace
}  // namespace teamscan::registration
