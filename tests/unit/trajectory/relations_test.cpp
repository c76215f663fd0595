// The relations metric on hand-computed relations, the parser's counters, and the real Intel log's
// relations against its odometry (every relation names a scan of the log).
#include <gtest/gtest.h>

#include <cmath>

#include "common/dataset/carmen.hpp"
#include "common/dataset/log_text.hpp"
#include "groundstation/trajectory/relations.hpp"
#include "tests/support/real_data.hpp"

namespace teamscan::trajectory {
namespace {

TEST(Relations, ParsesAndCountsMalformedLines) {
  const RelationsFile f = parse_relations(
      "# t1 t2 x y z roll pitch yaw\n"
      "976052905.167303 976052911.885496 -0.056990 -0.128430 0.000000 0.000000 0.000000 -1.682210\n"
      "\n"
      "1.5 2.5 1 2 3 4 5\n"           // seven fields
      "1.5 2.5 1 2 3 4 5 x\n"         // not a number
      "1.1234567 2 0 0 0 0 0 0\n");   // more than six decimals: not an exact stamp
  EXPECT_EQ(f.lines, 6u);
  EXPECT_EQ(f.comments, 2u);
  EXPECT_EQ(f.malformed, 3u);
  EXPECT_NE(f.first_error.find("line 4"), std::string::npos) << f.first_error;
  ASSERT_EQ(f.relations.size(), 1u);
  EXPECT_EQ(f.relations[0].t1_us, 976052905167303);
  EXPECT_EQ(f.relations[0].t2_us, 976052911885496);
  EXPECT_DOUBLE_EQ(f.relations[0].t1_from_t2.x_m, -0.056990);
  EXPECT_DOUBLE_EQ(f.relations[0].t1_from_t2.theta_rad, -1.682210);
}

// Poses 1 → 2: forward 1 m, turn left 90°; 2 → 3: 1 m to the robot's front (world +y).
// Relation A (1 → 2) is exact: error 0. Relation B (2 → 3) says (1, 0.1, 1°): its error is
// R(−1°)·((1, 0) − (1, 0.1)), 0.1 m, and −1°. Relation C names a stamp the trajectory lacks.
TEST(Relations, HandComputedErrors) {
  const std::vector<StampedPose> trajectory = {{1, {0, 0, 0}}, {2, {1, 0, kPi / 2}}, {3, {1, 1, kPi / 2}}};
  const std::vector<Relation> relations = {{1, 2, {1, 0, kPi / 2}}, {2, 3, {1, 0.1, kPi / 180}}, {2, 9, {0, 0, 0}}};
  const RelationErrors e = relation_errors(relations, trajectory);
  EXPECT_EQ(e.relations, 3u);
  EXPECT_EQ(e.used, 2u);
  EXPECT_NEAR(e.translation_mean_m, 0.05, 1e-12);
  EXPECT_NEAR(e.translation_std_m, 0.05, 1e-9);
  EXPECT_NEAR(e.translation_squared_mean_m2, 0.005, 1e-12);
  EXPECT_NEAR(e.translation_max_m, 0.1, 1e-12);
  EXPECT_NEAR(e.rotation_mean_deg, 0.5, 1e-9);
  EXPECT_NEAR(e.rotation_std_deg, 0.5, 1e-6);
  EXPECT_NEAR(e.rotation_squared_mean_deg2, 0.5, 1e-9);
  EXPECT_NEAR(e.rotation_max_deg, 1.0, 1e-9);
}

// MIT CSAIL's relations write five decimals, its log six: a stamp with fewer decimals than the
// log's names the scan it was rounded from (within half its last decimal's unit, either way);
// six decimals name a scan exactly.
TEST(Relations, AStampWithFewerDecimalsNamesTheScanItIsRoundedFrom) {
  const std::vector<StampedPose> trajectory = {{1'000'000, {0, 0, 0}}, {1'212'215, {1, 0, 0}}, {1'500'004, {2, 0, 0}}};
  const RelationsFile f = parse_relations(
      "1.00000 1.21221 1 0 0 0 0 0\n"    // 1.212215 rounded down (as printf rounds the double)
      "1.0 1.50000 2 0 0 0 0 0\n"        // 1.500004 rounded; t1 with one decimal
      "1.00000 1.21223 1 0 0 0 0 0\n"    // 1.212215 is 15 µs away: no scan
      "1.000000 1.212210 1 0 0 0 0 0\n"); // six decimals: exact only
  ASSERT_EQ(f.relations.size(), 4u);
  EXPECT_EQ(f.relations[0].t1_unit_us, 10);
  EXPECT_EQ(f.relations[1].t1_unit_us, 100'000);
  EXPECT_EQ(f.relations[3].t2_unit_us, 1);
  const RelationErrors e = relation_errors(f.relations, trajectory);
  EXPECT_EQ(e.used, 2u);
  EXPECT_EQ(e.rounded, 2u);
  EXPECT_NEAR(e.translation_max_m, 0.0, 1e-12);  // both named the right scans
  const RelationErrors exact = relation_errors({{1'000'000, 1'212'215, {1, 0, 0}}}, trajectory);
  EXPECT_EQ(exact.used, 1u);
  EXPECT_EQ(exact.rounded, 0u);
}

// The error does not depend on where the trajectory sits: a rigid motion of every pose leaves it.
TEST(Relations, InvariantToTheTrajectorysFrame) {
  std::vector<StampedPose> trajectory = {{1, {0, 0, 0}}, {2, {1, 0.2, 0.3}}, {3, {1.5, 1, 1.2}}};
  const std::vector<Relation> relations = {{1, 2, {0.9, 0.1, 0.25}}, {1, 3, {1.4, 1.2, 1.1}}};
  const RelationErrors a = relation_errors(relations, trajectory);
  const Pose2 move{5, -3, 2.0};
  for (StampedPose& p : trajectory) p.pose = move * p.pose;
  const RelationErrors b = relation_errors(relations, trajectory);
  EXPECT_NEAR(a.translation_mean_m, b.translation_mean_m, 1e-12);
  EXPECT_NEAR(a.rotation_mean_deg, b.rotation_mean_deg, 1e-9);
  EXPECT_GT(a.translation_mean_m, 0.0);
  EXPECT_EQ(relation_errors({}, trajectory).used, 0u);
}

TEST(RelationsReal, IntelOdometryNamesEveryRelation) {
  const Result<std::string> log_text = read_log_text(test::real_data_path("intel.clf.xz"));
  const Result<std::string> rel_text = read_log_text(test::real_data_path("intel.relations"));
  ASSERT_TRUE(log_text && rel_text);
  const RelationsFile f = parse_relations(rel_text.value());
  EXPECT_EQ(f.relations.size(), 2984u);
  EXPECT_EQ(f.malformed, 0u) << f.first_error;
  const CarmenLog log = parse_carmen(log_text.value());
  std::vector<StampedPose> odometry;
  for (const CarmenLaser& l : log.lasers) odometry.push_back({l.stamp_us, l.pose});
  const RelationErrors e = relation_errors(f.relations, odometry);
  EXPECT_EQ(e.used, 2984u);
  // Odometry alone: real drift, so errors well above the published SLAM figures (Hess et al. 2016
  // Table II: 0.023 m, 0.45°); relations across a loop see the whole drift, so the mean is large, yet
  // bounded by the building's size (about 40 m across).
  EXPECT_GT(e.translation_mean_m, 0.03);
  EXPECT_LT(e.translation_mean_m, 60.0);
  EXPECT_GT(e.rotation_mean_deg, 0.5);
  EXPECT_LE(e.rotation_max_deg, 180.0);
  std::printf("Intel odometry: %.4f ± %.4f m, %.3f ± %.3f deg over %zu relations\n", e.translation_mean_m, e.translation_std_m,
              e.rotation_mean_deg, e.rotation_std_deg, e.used);
}

}  // namespace
}  // namespace teamscan::trajectory
