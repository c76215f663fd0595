// KalmanTeamSource (built when groundstation/mapping is in the tree): the adapter hands the tracker the
// forward speed from the map-frame velocity, orders robots by id and merges liveliness into `lost`.
#include <gtest/gtest.h>

#include <array>
#include <cmath>

#include "groundstation/station/kalman_team_source.hpp"

namespace teamscan::station {
namespace {

PoseObservation pose(std::uint32_t id, double t_s, double x, double y, double yaw, double vx, double vy) {
  PoseObservation p;
  p.robot_id = id;
  p.stamp = Time::from_seconds(t_s);
  p.x_m = x;
  p.y_m = y;
  p.yaw_rad = yaw;
  p.vx_mps = vx;
  p.vy_mps = vy;
  return p;
}

TEST(KalmanTeamSource, TracksAConstantVelocityRobotAtAnAngle) {
  KalmanTeamSource k(mapping::TrackerOptions{});
  // 1 m/s along 30 degrees for 3 s at 10 Hz.
  const double yaw = 30.0 * 3.14159265358979 / 180.0;
  for (int i = 0; i <= 30; ++i) {
    const double t = 0.1 * i;
    k.add_pose(pose(5, 100.0 + t, t * std::cos(yaw), t * std::sin(yaw), yaw, std::cos(yaw), std::sin(yaw)));
  }
  std::array<TeamMemberEstimate, kMaxRobots> out{};
  ASSERT_EQ(k.estimate(Time::from_seconds(103.2), out), 1u);
  EXPECT_EQ(out[0].robot_id, 5u);
  EXPECT_NEAR(out[0].x_m, 3.2 * std::cos(yaw), 0.02);  // 0.2 s ahead of the last pose
  EXPECT_NEAR(out[0].y_m, 3.2 * std::sin(yaw), 0.02);
  EXPECT_NEAR(out[0].vx_mps, std::cos(yaw), 0.05);
  EXPECT_NEAR(out[0].vy_mps, std::sin(yaw), 0.05);
  EXPECT_GT(out[0].cov_xx_m2, 0.0);
  EXPECT_FALSE(out[0].lost);
}

TEST(KalmanTeamSource, ARobotWithoutACorrectionCarriesNone) {
  KalmanTeamSource k(mapping::TrackerOptions{});
  for (int i = 0; i <= 5; ++i) k.add_pose(pose(2, 10.0 + 0.1 * i, 0.0, 0.1 * i, 0.0, 0.0, 1.0));
  std::array<TeamMemberEstimate, kMaxRobots> out{};
  ASSERT_EQ(k.estimate(Time::from_seconds(10.5), out), 1u);
  EXPECT_TRUE(out[0].correction.none());
  EXPECT_EQ(out[0].correction.x_mm, 0);
  EXPECT_EQ(out[0].correction.yaw_urad, 0);
}

TEST(KalmanTeamSource, OrderedByIdAndLostFromLivelinessOrAge) {
  mapping::TrackerOptions o;
  o.lost_after_s = 1.0;
  KalmanTeamSource k(o);
  k.add_pose(pose(9, 10.0, 9.0, 0.0, 0.0, 0.0, 0.0));
  k.add_pose(pose(2, 10.0, 2.0, 0.0, 0.0, 0.0, 0.0));
  k.set_lost(9, true);
  std::array<TeamMemberEstimate, kMaxRobots> out{};
  ASSERT_EQ(k.estimate(Time::from_seconds(10.1), out), 2u);
  EXPECT_EQ(out[0].robot_id, 2u);
  EXPECT_FALSE(out[0].lost);
  EXPECT_EQ(out[1].robot_id, 9u);
  EXPECT_TRUE(out[1].lost);
  ASSERT_EQ(k.estimate(Time::from_seconds(12.0), out), 2u);  // 2 s without a pose
  EXPECT_TRUE(out[0].lost);
}

// The registration's correction goes into teamscan/team: the poses after it are corrected before the
// tracker, and the track's drift restarts from the correction's σ.
TEST(KalmanTeamSource, PosesAfterACorrectionArePublishedCorrected) {
  mapping::TrackerOptions o;
  o.drift_m_per_m = 0.02;
  KalmanTeamSource k(o);
  for (int i = 0; i <= 20; ++i) k.add_pose(pose(3, 10.0 + 0.1 * i, 0.1 * i, 0.0, 0.0, 1.0, 0.0));
  std::array<TeamMemberEstimate, kMaxRobots> out{};
  ASSERT_EQ(k.estimate(Time::from_seconds(12.0), out), 1u);
  const double cov_before = out[0].cov_xx_m2;
  // Odometry says (2, 0); the map says the odometry frame sits 0.3 m further in y and turned 0.05 rad.
  k.set_correction(3, 0.0, 0.3, 0.05, 0.01, 0.001, true);
  ASSERT_EQ(k.estimate(Time::from_seconds(12.0), out), 1u);
  EXPECT_LT(out[0].cov_xx_m2, cov_before);  // the drift restarts from the correction's σ
  for (int i = 21; i <= 60; ++i) k.add_pose(pose(3, 10.0 + 0.1 * i, 0.1 * i, 0.0, 0.0, 1.0, 0.0));
  ASSERT_EQ(k.estimate(Time::from_seconds(16.0), out), 1u);
  const Pose2 expected = Pose2{0.0, 0.3, 0.05} * Pose2{6.0, 0.0, 0.0};
  EXPECT_NEAR(out[0].x_m, expected.x_m, 0.02);
  EXPECT_NEAR(out[0].y_m, expected.y_m, 0.02);
  // The estimate carries the correction itself for the robot (teamscan/team TeamMember.corr_*),
  // numbered from 1, in whole mm and µrad, with its σ.
  EXPECT_EQ(out[0].correction.seq, 1u);
  EXPECT_EQ(out[0].correction.x_mm, 0);
  EXPECT_EQ(out[0].correction.y_mm, 300);
  EXPECT_EQ(out[0].correction.yaw_urad, 50'000);
  EXPECT_DOUBLE_EQ(out[0].correction_sigma_m, 0.01);
  EXPECT_DOUBLE_EQ(out[0].correction_sigma_yaw_rad, 0.001);
  k.set_correction(3, -0.0625, 0.31, -3.5, 0.02, 0.002, true);  // yaw wrapped into (−π, π]
  ASSERT_EQ(k.estimate(Time::from_seconds(16.0), out), 1u);
  EXPECT_EQ(out[0].correction.seq, 2u);
  EXPECT_EQ(out[0].correction.x_mm, -63);  // −62.5 mm: ties away from zero
  EXPECT_EQ(out[0].correction.yaw_urad, 2'783'185);
  k.set_correction(0, 1, 1, 1, 1, 1, true);  // bad ids are ignored
  k.set_correction(kMaxRobots + 1, 1, 1, 1, 1, 1, true);
}

}  // namespace
}  // namespace teamscan::station
