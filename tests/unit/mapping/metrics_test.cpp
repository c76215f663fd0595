// Metrics on a tiny labelled set computed by hand (PAPER_NOTES "The metrics", ANCHORS §1.1).
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "groundstation/mapping/metrics.hpp"

namespace teamscan::mapping {
namespace {

LabelledPoint labelled(PointClass c, float x = 0, float y = 0, float z = 0) {
  LabelledPoint p;
  p.label = c;
  p.x = x;
  p.y = y;
  p.z = z;
  if (c == PointClass::robot) p.hit_robot = 2;
  return p;
}

TEST(Metrics, HandComputedRemovalCounts) {
  using PC = PointClass;
  // 4 ghosts (3 removed), 3 floor (1 removed), 2 wall (0 removed), 1 furniture (1 removed).
  const std::vector<LabelledPoint> pts{labelled(PC::robot), labelled(PC::robot), labelled(PC::robot), labelled(PC::robot),
                                       labelled(PC::floor), labelled(PC::floor), labelled(PC::floor),
                                       labelled(PC::wall),  labelled(PC::wall),  labelled(PC::furniture)};
  const std::vector<std::uint8_t> removed{1, 1, 0, 1, 1, 0, 0, 0, 0, 1};
  const RemovalMetrics m = removal_metrics(pts, removed);
  EXPECT_EQ(m.ghosts, 4u);
  EXPECT_EQ(m.ghosts_removed, 3u);
  EXPECT_EQ(m.others, 6u);
  EXPECT_EQ(m.others_removed, 2u);
  EXPECT_NEAR(m.ghost_removed_pct, 75.0, 1e-9);
  EXPECT_NEAR(m.other_removed_pct, 100.0 / 3.0, 1e-9);
  EXPECT_NEAR(m.da, 75.0, 1e-9);
  EXPECT_NEAR(m.sa, 200.0 / 3.0, 1e-9);
  EXPECT_NEAR(m.aa, std::sqrt(75.0 * 200.0 / 3.0), 1e-9);            // √5000 ≈ 70.71
  EXPECT_NEAR(m.ha, 2.0 * 75.0 * (200.0 / 3.0) / (75.0 + 200.0 / 3.0), 1e-9);  // ≈ 70.59
  EXPECT_NEAR(m.by_class[static_cast<int>(PC::floor)].kept_pct(), 200.0 / 3.0, 1e-9);
  EXPECT_NEAR(m.by_class[static_cast<int>(PC::wall)].kept_pct(), 100.0, 1e-9);
  EXPECT_NEAR(m.by_class[static_cast<int>(PC::furniture)].kept_pct(), 0.0, 1e-9);
  EXPECT_TRUE(std::isnan(m.by_class[static_cast<int>(PC::ceiling)].kept_pct()));  // class absent
}

TEST(Metrics, NothingRemovedAndEverythingRemoved) {
  const std::vector<LabelledPoint> pts{labelled(PointClass::robot), labelled(PointClass::floor)};
  const RemovalMetrics none = removal_metrics(pts, std::vector<std::uint8_t>{0, 0});
  EXPECT_EQ(none.sa, 100.0);
  EXPECT_EQ(none.da, 0.0);
  EXPECT_EQ(none.aa, 0.0);
  EXPECT_EQ(none.ha, 0.0);
  const RemovalMetrics all = removal_metrics(pts, std::vector<std::uint8_t>{1, 1});
  EXPECT_EQ(all.sa, 0.0);
  EXPECT_EQ(all.da, 100.0);
  // No ghosts at all: DA undefined.
  const std::vector<LabelledPoint> clean{labelled(PointClass::floor)};
  EXPECT_TRUE(std::isnan(removal_metrics(clean, std::vector<std::uint8_t>{0}).da));
}

TEST(Metrics, PlaneImprovementsByTheirDefinitions) {
  // The paper's Lap numbers: −3.1 mm → 0.054 mm is a 98.3 % improvement; share 0.82 → 0.83 is +1.22 %.
  PlaneFit before, after;
  before.found = after.found = true;
  before.signed_mean_error_m = -3.1e-3;
  after.signed_mean_error_m = 0.054e-3;
  before.inlier_share = 0.82;
  after.inlier_share = 0.83;
  EXPECT_NEAR(plane_error_improvement_pct(before, after), 100.0 * (3.1 - 0.054) / 3.1, 1e-9);
  EXPECT_NEAR(plane_inlier_improvement_pct(before, after), 100.0 * (0.83 - 0.82) / 0.82, 1e-9);
  // Worse after: negative improvement.
  EXPECT_NEAR(plane_error_improvement_pct(after, before), 100.0 * (0.054 - 3.1) / 0.054, 1e-6);
  after.found = false;
  EXPECT_TRUE(std::isnan(plane_error_improvement_pct(before, after)));
}

TEST(Metrics, Table1OnAFloorWithGhostsJustAboveIt) {
  // 100 floor points at z 0 on a 10 × 10 grid, 20 ghost points at z 1 cm over the same area (inside
  // the 2 cm threshold), 30 wall points at x = −1. With ghosts: 120 inliers of 150 (80 %), ghosts 1/6
  // of the inliers. Ghosts removed: 100 of 130 (76.9 %): the share drops by 3.85 %.
  std::vector<LabelledPoint> pts;
  for (int i = 0; i < 10; ++i)
    for (int j = 0; j < 10; ++j) pts.push_back(labelled(PointClass::floor, 0.1f * static_cast<float>(i), 0.1f * static_cast<float>(j), 0.0f));
  for (int i = 0; i < 20; ++i)
    pts.push_back(labelled(PointClass::robot, 0.05f + 0.045f * static_cast<float>(i), 0.05f + 0.04f * static_cast<float>(i % 5), 0.01f));
  for (int i = 0; i < 30; ++i)
    pts.push_back(labelled(PointClass::wall, -1.0f, 0.1f * static_cast<float>(i % 10), 0.3f + 0.2f * static_cast<float>(i / 10)));
  std::vector<MapPoint> cloud;
  for (const auto& p : pts) cloud.push_back({p.x, p.y, p.z});
  RansacOptions o;
  o.threshold_m = 0.02;
  const Table1 t = table1(pts, cloud, o);
  ASSERT_TRUE(t.with_ghosts.found);
  ASSERT_TRUE(t.without_ghosts.found);
  EXPECT_EQ(t.with_ghosts.inliers, 120u);
  EXPECT_EQ(t.with_ghosts.points, 150u);
  EXPECT_EQ(t.without_ghosts.inliers, 100u);
  EXPECT_EQ(t.without_ghosts.points, 130u);
  EXPECT_NEAR(t.ghost_share_of_inliers_pct, 100.0 / 6.0, 1e-9);
  EXPECT_NEAR(t.inlier_improvement_pct, 100.0 * (100.0 / 130.0 - 0.8) / 0.8, 1e-9);
  // Without ghosts every inlier is exactly on z = 0: zero error whatever sample was drawn.
  EXPECT_NEAR(t.without_ghosts.mean_abs_error_m, 0.0, 1e-7);
}

TEST(Metrics, FloorBiasAgainstAFixedReferenceByHand) {
  // Reference z = 0; threshold 2 cm. Floor points at ±4 mm and 0 (mean 0), two ghosts at 1.5 cm,
  // one point at 5 cm (outside the band: ignored).
  const std::vector<MapPoint> pts{{0, 0, 0.004f}, {1, 0, -0.004f}, {2, 0, 0.0f}, {3, 0, 0.0f},
                                  {4, 0, 0.015f}, {5, 0, 0.015f}, {6, 0, 0.05f}};
  Plane ref;  // z = 0
  const double before = floor_bias_m(pts, ref, 0.02);
  EXPECT_NEAR(before, 0.030 / 6.0, 1e-7);
  const std::vector<std::uint8_t> ghosts_gone{0, 0, 0, 0, 1, 1, 0};
  EXPECT_NEAR(floor_bias_m(pts, ref, 0.02, ghosts_gone), 0.0, 1e-9);
  const std::vector<std::uint8_t> one_gone{0, 0, 0, 0, 1, 0, 0};
  const double after = floor_bias_m(pts, ref, 0.02, one_gone);
  EXPECT_NEAR(after, 0.015 / 5.0, 1e-7);
  EXPECT_NEAR(floor_bias_improvement_pct(before, after), 100.0 * (0.005 - 0.003) / 0.005, 1e-3);
  // Removing a low floor point instead makes the bias worse: the measure can go negative.
  const std::vector<std::uint8_t> low_gone{0, 1, 0, 0, 0, 0, 0};
  EXPECT_LT(floor_bias_improvement_pct(before, floor_bias_m(pts, ref, 0.02, low_gone)), 0.0);
  // A tilted reference: distances are along its normal.
  Plane tilted;
  tilted.normal = Eigen::Vector3d(0, 0.6, 0.8);
  tilted.d = 0.0;
  const std::vector<MapPoint> one{{0, 0.01f, 0.0f}};
  EXPECT_NEAR(floor_bias_m(one, tilted, 0.02), 0.006, 1e-7);
  const std::vector<MapPoint> far{{0, 0, 1.0f}};
  EXPECT_TRUE(std::isnan(floor_bias_m(far, ref, 0.02)));
  EXPECT_TRUE(std::isnan(floor_bias_improvement_pct(0.0, 0.001)));
}

}  // namespace
}  // namespace teamscan::mapping
