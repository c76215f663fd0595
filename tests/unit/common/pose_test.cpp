// Poses: composition, inverse and the pitch convention (positive pitch points +x down).
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "common/pose.hpp"

namespace teamscan {
namespace {

TEST(Pose2, ComposeAndInverse) {
  const Pose2 map_from_robot{1.0, 2.0, kPi / 2};
  const Vec2 p = map_from_robot.apply({1.0, 0.0});
  EXPECT_NEAR(p.x, 1.0, 1e-12);
  EXPECT_NEAR(p.y, 3.0, 1e-12);
  const Pose2 identity = map_from_robot * map_from_robot.inverse();
  EXPECT_NEAR(identity.x_m, 0.0, 1e-12);
  EXPECT_NEAR(identity.y_m, 0.0, 1e-12);
  EXPECT_NEAR(identity.theta_rad, 0.0, 1e-12);
}

TEST(Rot3, PositivePitchPointsForwardAxisDown) {
  const Rot3 r = Rot3::from_rpy(0, deg_to_rad(30), 0);
  const Vec3 x = r.apply({1, 0, 0});
  EXPECT_NEAR(x.x, std::cos(deg_to_rad(30)), 1e-12);
  EXPECT_NEAR(x.z, -0.5, 1e-12);
}

TEST(Pose3, InverseUndoesTransform) {
  const Pose3 a = Pose3::from_xyz_rpy(0.1, -0.2, 0.3, 0.4, -0.5, 0.6);
  const Vec3 p{1.5, -2.5, 0.75};
  const Vec3 q = a.inverse().apply(a.apply(p));
  EXPECT_NEAR(q.x, p.x, 1e-12);
  EXPECT_NEAR(q.y, p.y, 1e-12);
  EXPECT_NEAR(q.z, p.z, 1e-12);
}

}  // namespace
}  // namespace teamscan

// A corrupt file's heading (1e300, inf) must not hang the wrap (found by fuzz_carmen).
TEST(NormalizeAngle, FarOutsideAndNotFinite) {
  EXPECT_NEAR(teamscan::normalize_angle(3.0 * teamscan::kPi), teamscan::kPi, 1e-12);
  EXPECT_NEAR(teamscan::normalize_angle(-0.5), -0.5, 0.0);
  const double far = teamscan::normalize_angle(1e300);
  EXPECT_GT(far, -teamscan::kPi);
  EXPECT_LE(far, teamscan::kPi);
  EXPECT_NEAR(teamscan::normalize_angle(2001.0 * teamscan::kPi), teamscan::kPi, 1e-9);
  EXPECT_TRUE(std::isinf(teamscan::normalize_angle(std::numeric_limits<double>::infinity())));
  EXPECT_TRUE(std::isnan(teamscan::normalize_angle(std::numeric_limits<double>::quiet_NaN())));
}
