// SurfaceGrid: walls become line features with the right normals; floor, ceiling and table tops never.
#include <gtest/gtest.h>

#include <cmath>

#include "groundstation/registration/surface_grid.hpp"
#include "tests/unit/registration/synthetic_scene.hpp"

namespace teamscan::registration {
namespace {

using testing::Scene;

TEST(SurfaceGrid, WallsGiveFeaturesWithTheirNormalsHorizontalSurfacesNone) {
  Scene s = Scene::room(8, 6, 2.5);
  std::mt19937_64 rng{1};
  SurfaceGrid grid;
  for (const Vec3& p : s.sample({0, 0}, 20, 200000, rng)) (void)grid.add(p);
  std::vector<LineFeature> f;
  grid.features(f);
  ASSERT_GT(f.size(), 200u);
  for (const LineFeature& l : f) {
    // Every feature lies on a wall with the wall's normal.
    // (A corner voxel holds both walls: its mean sits a few centimetres inside the corner.)
    const bool on_x_wall = std::abs(std::abs(l.x_m) - 4.0) < 0.05, on_y_wall = std::abs(std::abs(l.y_m) - 3.0) < 0.05;
    ASSERT_TRUE(on_x_wall || on_y_wall) << l.x_m << ", " << l.y_m;
    SCOPED_TRACE(::testing::Message() << l.x_m << ", " << l.y_m << " n " << l.nx << ", " << l.ny << " w " << l.weight);
    if (std::abs(l.x_m) > 3.8 && std::abs(l.y_m) > 2.8) continue;  // a corner voxel: two planes, either normal
    if (on_x_wall && !on_y_wall) {
      EXPECT_GT(std::abs(l.nx), 0.99);
    }
    if (on_y_wall && !on_x_wall) {
      EXPECT_GT(std::abs(l.ny), 0.99);
    }
  }
}

TEST(SurfaceGrid, FloorBandIsDroppedAndVoxelsAreCapped) {
  SurfaceOptions o;
  o.voxel_cap = 10;
  SurfaceGrid grid{o};
  EXPECT_FALSE(grid.add({1, 1, 0.01}));  // floor
  int taken = 0;
  for (int i = 0; i < 50; ++i) taken += grid.add({1.01 + 0.001 * i, 1.02, 1.0}) ? 1 : 0;
  EXPECT_EQ(taken, 10);
  EXPECT_EQ(grid.voxels(), 1u);
  EXPECT_FALSE(grid.add({std::nan(""), 0, 1}));
}

TEST(SurfaceGrid, OnlyATableTopAndFloorGiveNoFeature) {
  Scene s;
  s.slabs = {{-1, 1, -0.5, 0.5, 0.75}, {-3, 3, -3, 3, 0.0}};
  std::mt19937_64 rng{2};
  SurfaceGrid grid;
  for (const Vec3& p : s.sample({0, 0}, 10, 50000, rng)) (void)grid.add(p);
  std::vector<LineFeature> f;
  grid.features(f);
  EXPECT_EQ(f.size(), 0u);
  EXPECT_GT(grid.voxels(), 100u);
}

}  // namespace
}  // namespace teamscan::registration

namespace teamscan::registration {
namespace {

TEST(SurfaceGrid, AHorizontalLaserSeesWallsEdgeOn) {
  // Every point at one height (a horizontal 2-D laser, SurfaceOptions::planar_scans): each wall voxel
  // holds a horizontal line whose normal in the floor plane is the wall's.
  std::mt19937_64 rng{3};
  std::uniform_real_distribution<double> u(-3.9, 3.9);
  std::normal_distribution<double> g(0.0, 0.005);
  SurfaceOptions o;
  o.planar_scans = true;
  SurfaceGrid grid{o};
  for (int i = 0; i < 20000; ++i) {
    (void)grid.add({u(rng), 3.0 + g(rng), 0.3});
    (void)grid.add({4.0 + g(rng), 0.75 * u(rng), 0.3});
  }
  std::vector<LineFeature> f;
  grid.features(f);
  ASSERT_GT(f.size(), 100u);
  for (const LineFeature& l : f) {
    if (std::abs(l.x_m) > 3.8 && std::abs(l.y_m) > 2.8) continue;  // the corner
    if (std::abs(l.y_m - 3.0) < 0.05) {
      EXPECT_GT(std::abs(l.ny), 0.99) << l.x_m;
    } else {
      EXPECT_NEAR(l.x_m, 4.0, 0.05);
      EXPECT_GT(std::abs(l.nx), 0.99) << l.y_m;
    }
  }
}

}  // namespace
}  // namespace teamscan::registration

namespace teamscan::registration {
namespace {

// A wall y = 3.05 seen by a laser pitched down as it drives along x: every sweep draws one stripe on the
// wall, a horizontal line at a height that changes from sweep to sweep, so a voxel holds a few thin
// line (too thin for a normal on its own). The ceiling's stripes lie at one height, z = 2.5 on a voxel
// boundary, so each is split between two voxels of its column: pooled, still one line.
void stripes(SurfaceGrid& grid, double wall_y, double ceiling_z, std::mt19937_64& rng) {
  std::normal_distribution<double> g(0.0, 0.003);
  for (int sweep = 0; sweep < 6; ++sweep) {
    const double z = 0.15 + 0.1 * sweep;  // one stripe per 10 cm voxel layer
    for (double x = -2.0; x < 2.0; x += 0.005) {
      (void)grid.add({x + g(rng), wall_y + g(rng), z + g(rng)});
      (void)grid.add({x + g(rng), 0.4 * sweep - 1.0 + g(rng), ceiling_z + g(rng)});
    }
  }
}

TEST(SurfaceGrid, ATiltedLasersStripesOnAWallArePooledPerColumn) {
  std::mt19937_64 rng{4};
  SurfaceOptions o;
  o.voxel_cap = 1000;
  SurfaceGrid grid{o};
  stripes(grid, 3.05, 2.5, rng);
  std::vector<LineFeature> f;
  grid.features(f);
  // One feature per wall column (40 columns along 4 m), none from the ceiling's stripes.
  ASSERT_GE(f.size(), 38u);
  for (const LineFeature& l : f) {
    EXPECT_NEAR(l.y_m, 3.05, 0.02) << l.x_m;
    EXPECT_GT(std::abs(l.ny), 0.99) << l.x_m;
  }
  // Without pooling, the same stripes give no feature: each voxel holds lines only.
  o.pool_stripes = false;
  SurfaceGrid single{o};
  stripes(single, 3.05, 2.5, rng);
  single.features(f);
  EXPECT_EQ(f.size(), 0u);
}

}  // namespace
}  // namespace teamscan::registration
