// Tests of common/scan_points: beam -> map-frame point on hand-computed cases (tilt, mount offset,
// registration, a robot moving during the sweep) and the per-point flags.
#include "common/scan_points.hpp"

#include <gtest/gtest.h>

#include <vector>

namespace teamscan {
namespace {

constexpr LaserVariant k180x1{180, 100};  // 181 beams, one revolution

struct Scan {
  std::vector<std::uint32_t> range;
  std::vector<std::uint8_t> flags;
  BeamSpans spans() const { return {range, flags}; }
};

Scan uniform(std::uint32_t range_mm, std::size_t n = 181) { return {std::vector<std::uint32_t>(n, range_mm), std::vector<std::uint8_t>(n, 0)}; }

OdometryHistory<> standing_at(Pose2 p) {
  OdometryHistory<> h;
  (void)h.push(Time::from_ns(0), p);
  (void)h.push(Time::from_ns(1'000'000'000), p);
  return h;
}

TEST(ScanPoints, IdentityMountBeamAngles) {
  ScanProjector proj{Pose3{}, Pose2{}};
  const auto odom = standing_at({});
  const Scan s = uniform(1000);
  ScanPoints out;
  ASSERT_TRUE(proj.project(s.spans(), Time::from_ns(500'000'000), k180x1, odom, out));
  ASSERT_EQ(out.count, 181);
  // Beam 0 on the right (−90°), beam 90 straight ahead, beam 180 on the left (DESIGN.md).
  EXPECT_EQ(out.points[0].x_mm, 0);
  EXPECT_EQ(out.points[0].y_mm, -1000);
  EXPECT_EQ(out.points[90].x_mm, 1000);
  EXPECT_EQ(out.points[90].y_mm, 0);
  EXPECT_EQ(out.points[180].y_mm, 1000);
  // Beam 30: −60°, (500, −866.03) -> rounded to the nearest mm.
  EXPECT_EQ(out.points[30].x_mm, 500);
  EXPECT_EQ(out.points[30].y_mm, -866);
  EXPECT_EQ(out.points[30].beam, 30);
  for (std::size_t i = 0; i < out.count; ++i) EXPECT_EQ(out.points[i].flags, 0) << i;
  EXPECT_TRUE(out.pose_ok);
}

TEST(ScanPoints, TiltedDownLaserHitsBelowItsCentre) {
  // Laser 0.5 m above the floor, pitched 30° down (positive pitch = nose down, common/pose.hpp).
  ScanProjector proj{Pose3::from_xyz_rpy(0, 0, 0.5, 0, deg_to_rad(30), 0), Pose2{}};
  const auto odom = standing_at({});
  const Scan s = uniform(2000);
  ScanPoints out;
  ASSERT_TRUE(proj.project(s.spans(), Time::from_ns(500'000'000), k180x1, odom, out));
  // Beam 90: 2 m along (cos30°, 0, −sin30°) from (0, 0, 0.5): (1732.05, 0, −500).
  EXPECT_EQ(out.points[90].x_mm, 1732);
  EXPECT_EQ(out.points[90].y_mm, 0);
  EXPECT_EQ(out.points[90].z_mm, -500);
  // Beam 0 (−90° in the scan plane) lies on the tilt axis: stays horizontal at 0.5 m.
  EXPECT_EQ(out.points[0].x_mm, 0);
  EXPECT_EQ(out.points[0].y_mm, -2000);
  EXPECT_EQ(out.points[0].z_mm, 500);
  // Beam 150 (+60°): laser (1000, 1732.05, 0) -> x = 1000·cos30 = 866.03, z = 500 − 1000·sin30 = 0.
  EXPECT_EQ(out.points[150].x_mm, 866);
  EXPECT_EQ(out.points[150].y_mm, 1732);
  EXPECT_EQ(out.points[150].z_mm, 0);
  EXPECT_EQ(out.origin_z_mm, 500);
}

TEST(ScanPoints, MountOffsetYawAndRegistration) {
  // Laser 0.2 m forward, 0.1 m left, 0.3 m up, turned 90° left; robot at (1, 2) facing +y (odometry);
  // odometry registered in the map at (10, 0), rotated 0.
  ScanProjector proj{Pose3::from_xyz_rpy(0.2, 0.1, 0.3, 0, 0, deg_to_rad(90)), Pose2{10.0, 0.0, 0.0}};
  const auto odom = standing_at({1.0, 2.0, deg_to_rad(90)});
  const Scan s = uniform(1000);
  ScanPoints out;
  ASSERT_TRUE(proj.project(s.spans(), Time::from_ns(500'000'000), k180x1, odom, out));
  // Beam 90 points along the laser x = robot +y = map −x. Robot frame: (0.2, 1.1, 0.3).
  // Robot facing +y: map = (1 − 1.1, 2 + 0.2) + (10, 0) = (9.9, 2.2).
  EXPECT_EQ(out.points[90].x_mm, 9900);
  EXPECT_EQ(out.points[90].y_mm, 2200);
  EXPECT_EQ(out.points[90].z_mm, 300);
  // The origin: robot frame (0.2, 0.1) -> map (1 − 0.1 + 10, 2 + 0.2).
  EXPECT_EQ(out.origin_x_mm, 10900);
  EXPECT_EQ(out.origin_y_mm, 2200);
  EXPECT_NEAR(out.map_from_robot.x_m, 11.0, 1e-12);
}

TEST(ScanPoints, RotatedRegistration) {
  // Registration: the odometry frame turned 90° in the map and shifted by (0, 5).
  ScanProjector proj{Pose3{}, Pose2{0.0, 5.0, deg_to_rad(90)}};
  const auto odom = standing_at({2.0, 0.0, 0.0});
  const Scan s = uniform(1000);
  ScanPoints out;
  ASSERT_TRUE(proj.project(s.spans(), Time::from_ns(500'000'000), k180x1, odom, out));
  // Odom point (3, 0) -> map (0 − 0, 5 + 3) = (0, 8).
  EXPECT_EQ(out.points[90].x_mm, 0);
  EXPECT_EQ(out.points[90].y_mm, 8000);
}

TEST(ScanPoints, RobotMovingDuringTheSweep) {
  // 2 m/s along +x: x(t) = 2·t. Stamp 0.5 s. One revolution of 1/75 s covers 360°; the 180° sweep
  // takes 6.667 ms, beam i measured (180 − i)·13.333333 ms / 360 before the stamp.
  OdometryHistory<> odom;
  ASSERT_TRUE(odom.push(Time::from_ns(0), {0.0, 0.0, 0.0}));
  ASSERT_TRUE(odom.push(Time::from_ns(1'000'000'000), {2.0, 0.0, 0.0}));
  ScanProjector proj{Pose3{}, Pose2{}};
  const Scan s = uniform(1000);
  ScanPoints out;
  ASSERT_TRUE(proj.project(s.spans(), Time::from_ns(500'000'000), k180x1, odom, out));
  // Beam 180: age 0 -> robot at x = 1.0 m, point (1.0, 1.0).
  EXPECT_EQ(out.points[180].x_mm, 1000);
  EXPECT_EQ(out.points[180].y_mm, 1000);
  // Beam 0: age 6.666666 ms -> x = 1.0 − 0.013333 = 0.986667 m -> 987 mm, y = −1000.
  EXPECT_EQ(out.points[0].x_mm, 987);
  EXPECT_EQ(out.points[0].y_mm, -1000);
  // Beam 90: age 3.333333 ms -> x = 1.0 − 0.0066667 + 1.0 = 1.993333 -> 1993 mm.
  EXPECT_EQ(out.points[90].x_mm, 1993);
}

TEST(ScanPoints, TurningDuringAnInterlacedSweep) {
  // 0.5° scan: two revolutions, revolution 0 measures even beams, then revolution 1 the odd ones.
  // The robot turns at 1 rad/s, so beam 180 (even, angle 0) is measured one full revolution plus
  // 90° of mirror (13.333 + 3.333 ms) before the stamp, beam 181 (odd) 90° − 0.5° of mirror before.
  OdometryHistory<> odom;
  ASSERT_TRUE(odom.push(Time::from_ns(0), {0.0, 0.0, 0.0}));
  ASSERT_TRUE(odom.push(Time::from_ns(100'000'000), {0.0, 0.0, 0.1}));
  ScanProjector proj{Pose3{}, Pose2{}};
  const Scan s = uniform(4000, 361);
  ScanPoints out;
  ASSERT_TRUE(proj.project(s.spans(), Time::from_ns(50'000'000), LaserVariant{180, 50}, odom, out));
  const double t180 = 0.05 - (1.0 / 75.0) * (1.0 + 90.0 / 360.0);
  EXPECT_EQ(out.points[180].x_mm, static_cast<std::int32_t>(std::lround(4000 * std::cos(t180))));
  EXPECT_EQ(out.points[180].y_mm, static_cast<std::int32_t>(std::lround(4000 * std::sin(t180))));
  const double t181 = 0.05 - (1.0 / 75.0) * (89.5 / 360.0);
  const double a181 = t181 + deg_to_rad(0.5);
  EXPECT_EQ(out.points[181].x_mm, static_cast<std::int32_t>(std::lround(4000 * std::cos(a181))));
  EXPECT_EQ(out.points[181].y_mm, static_cast<std::int32_t>(std::lround(4000 * std::sin(a181))));
}

TEST(ScanPoints, FlagsInvalidDazzledOutOfRange) {
  ScanProjector proj{Pose3::from_xyz_rpy(0.1, 0, 0.4, 0, 0, 0), Pose2{}, ScanPointsOptions{5000, 100ms}};
  const auto odom = standing_at({});
  Scan s = uniform(1000);
  s.flags[10] = kBeamInvalid;
  s.flags[11] = kBeamDazzled;
  s.range[12] = 0;
  s.range[13] = 5001;
  s.range[14] = 5000;
  ScanPoints out;
  ASSERT_TRUE(proj.project(s.spans(), Time::from_ns(500'000'000), k180x1, odom, out));
  EXPECT_EQ(out.points[10].flags, kPointInvalid);
  EXPECT_EQ(out.points[11].flags, kPointDazzled);
  EXPECT_EQ(out.points[12].flags, kPointInvalid);
  EXPECT_EQ(out.points[13].flags, kPointOutOfRange);
  EXPECT_EQ(out.points[14].flags, 0);
  // Unplaceable beams sit at the laser centre.
  EXPECT_EQ(out.points[10].x_mm, 100);
  EXPECT_EQ(out.points[10].z_mm, 400);
  EXPECT_EQ(out.points[11].x_mm, 100);
  // Out of range keeps its measured position: beam 13 at −77°.
  EXPECT_EQ(out.points[13].y_mm, static_cast<std::int32_t>(std::lround(5001 * std::sin(deg_to_rad(-77)))));
}

TEST(ScanPoints, NoOdometryFlagsEveryBeam) {
  ScanProjector proj{Pose3{}, Pose2{}};
  OdometryHistory<> empty;
  const Scan s = uniform(1000);
  ScanPoints out;
  ASSERT_TRUE(proj.project(s.spans(), Time::from_ns(500'000'000), k180x1, empty, out));
  EXPECT_FALSE(out.pose_ok);
  EXPECT_EQ(out.unplaced, 181);
  for (std::size_t i = 0; i < out.count; ++i) EXPECT_NE(out.points[i].flags & kPointNoPose, 0) << i;
}

TEST(ScanPoints, StaleOdometryOnlyCoversRecentBeams) {
  // The newest SIP is 100 ms + 3 ms before the stamp: beams older than 3 ms still get a pose.
  OdometryHistory<> odom;
  ASSERT_TRUE(odom.push(Time::from_ns(0), {}));
  ASSERT_TRUE(odom.push(Time::from_ns(10'000'000), {}));
  ScanProjector proj{Pose3{}, Pose2{}, ScanPointsOptions{8182, 100ms}};
  const Scan s = uniform(1000);
  ScanPoints out;
  ASSERT_TRUE(proj.project(s.spans(), Time::from_ns(113'000'000), k180x1, odom, out));
  EXPECT_FALSE(out.pose_ok);
  // Beam age (180 − i)·37037.04 ns; placed iff age ≥ 3 ms, i.e. 180 − i ≥ 81.000003: i ≤ 98.
  EXPECT_EQ(out.points[98].flags, 0);
  EXPECT_EQ(out.points[99].flags, kPointNoPose);
  EXPECT_EQ(out.unplaced, 82);
}

TEST(ScanPoints, VariantChangeRebuildsTable) {
  ScanProjector proj{Pose3{}, Pose2{}};
  const auto odom = standing_at({});
  ScanPoints out;
  const Scan a = uniform(1000, 101);
  ASSERT_TRUE(proj.project(a.spans(), Time::from_ns(500'000'000), LaserVariant{100, 100}, odom, out));
  EXPECT_EQ(out.count, 101);
  EXPECT_EQ(out.points[0].x_mm, static_cast<std::int32_t>(std::lround(1000 * std::cos(deg_to_rad(-50)))));
  const Scan b = uniform(1000, 181);
  ASSERT_TRUE(proj.project(b.spans(), Time::from_ns(500'000'000), k180x1, odom, out));
  EXPECT_EQ(out.points[0].x_mm, 0);
  EXPECT_EQ(out.points[0].y_mm, -1000);
}

TEST(ScanPoints, RefusesBeamsThatAreNotOneFullSweepOfTheVariant) {
  ScanProjector proj{Pose3{}, Pose2{}};
  const auto odom = standing_at({});
  ScanPoints out;
  out.count = 7;  // unchanged by a refusal
  const Scan short_scan = uniform(1000, 180);
  EXPECT_FALSE(proj.project(short_scan.spans(), Time::from_ns(500'000'000), k180x1, odom, out));
  EXPECT_FALSE(proj.project(BeamSpans{}, Time::from_ns(500'000'000), k180x1, odom, out));  // a partial telegram's sweep()
  Scan mismatched = uniform(1000);
  mismatched.flags.pop_back();
  EXPECT_FALSE(proj.project(mismatched.spans(), Time::from_ns(500'000'000), k180x1, odom, out));
  EXPECT_EQ(out.count, 7);
  const Scan full = uniform(1000);
  EXPECT_TRUE(proj.project(full.spans(), Time::from_ns(500'000'000), k180x1, odom, out));
  EXPECT_EQ(out.count, 181);
}

}  // namespace
}  // namespace teamscan
