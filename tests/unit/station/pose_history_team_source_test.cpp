// PoseHistoryTeamSource: teamscan/team from the station's one tracker (the fusion core's pose history):
// the same state the former separate Kalman tracker published for the same poses, bit for bit; the
// forward speed from the map-frame velocity, robots by id, liveliness merged into `lost`; corrections
// applied by the history (by stamp) and carried in wire form.
#include <gtest/gtest.h>

#include <array>
#include <cmath>

#include "groundstation/mapping/tracker.hpp"
#include "groundstation/station/fusion.hpp"
#include "groundstation/station/pose_history_team_source.hpp"

namespace teamscan::station {
namespace {

PoseObservation pose(std::uint32_t id, double t_s, double x, double y, double yaw, double vx, double vy) {
  PoseObservation p;
  p.robot_id = id;
  p.stamp = Time::from_seconds(t_s);
  p.received = p.stamp;
  p.x_m = x;
  p.y_m = y;
  p.yaw_rad = yaw;
  p.vx_mps = vx;
  p.vy_mps = vy;
  return p;
}

fusion::PoseHistoryOptions history_options(const mapping::TrackerOptions& tracker = {}) {
  fusion::PoseHistoryOptions o;
  o.tracker = tracker;
  return o;
}

TEST(PoseHistoryTeamSource, TracksAConstantVelocityRobotAtAnAngle) {
  PoseHistoryTeamSource k(history_options());
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

// What teamscan/team carried from the separate tracker (mapping::TeamTracker fed every pose, predicted
// to the publication time) is what it carries now, to the bit: two robots, one turning, one that goes
// silent (coasting, then held and lost), published between, after and long after the poses.
TEST(PoseHistoryTeamSource, PublishesWhatTheSeparateTrackerPublishedForTheSamePoses) {
  mapping::TrackerOptions t;
  t.drift_m_per_m = 0.01;
  t.drift_heading_rad_per_m = 0.001;
  PoseHistoryTeamSource source(history_options(t));
  mapping::TeamTracker reference(t);
  const auto both = [&](const PoseObservation& p) {
    source.add_pose(p);
    reference.add_pose(static_cast<std::uint8_t>(p.robot_id), p.stamp.ns(), Pose2{p.x_m, p.y_m, p.yaw_rad},
                       forward_speed_mps(p.vx_mps, p.vy_mps, p.yaw_rad));
  };
  std::array<TeamMemberEstimate, kMaxRobots> out{};
  std::size_t compared = 0;
  const auto compare = [&](double at_s) {
    const mapping::TeamState expected = reference.predict(Time::from_seconds(at_s).ns());
    const std::size_t n = source.estimate(Time::from_seconds(at_s), out);
    ASSERT_EQ(n, expected.robots.size());
    for (std::size_t i = 0; i < n; ++i) {
      const mapping::RobotEstimate* r = expected.find(static_cast<std::uint8_t>(out[i].robot_id));
      ASSERT_NE(r, nullptr);
      EXPECT_EQ(out[i].x_m, r->position_m.x);
      EXPECT_EQ(out[i].y_m, r->position_m.y);
      EXPECT_EQ(out[i].vx_mps, r->velocity_mps.x);
      EXPECT_EQ(out[i].vy_mps, r->velocity_mps.y);
      EXPECT_EQ(out[i].cov_xx_m2, r->position_cov_m2(0, 0));
      EXPECT_EQ(out[i].cov_xy_m2, r->position_cov_m2(0, 1));
      EXPECT_EQ(out[i].cov_yy_m2, r->position_cov_m2(1, 1));
      EXPECT_EQ(out[i].lost, r->lost);
      EXPECT_EQ(out[i].valid.ns(), r->stamp_ns);
      ++compared;
    }
  };
  for (int i = 0; i <= 60; ++i) {
    const double s = 0.1 * i, a = 0.2 * s;
    both(pose(7, 50.0 + s, 2.0 * std::sin(a), 2.0 * (1.0 - std::cos(a)), a, 0.4 * std::cos(a), 0.4 * std::sin(a)));
    if (i <= 25) both(pose(3, 50.0 + s + 0.05, 1.0 + 0.3 * s, -1.0, 0.0, 0.3, 0.0));  // silent after 2.55 s
    if (i % 7 == 0) compare(50.0 + s + 0.03);
  }
  for (const double at : {56.05, 56.5, 58.0, 60.0, 80.0}) compare(at);
  EXPECT_EQ(compared, 2u * (9 + 5));
}

TEST(PoseHistoryTeamSource, ARobotWithoutACorrectionCarriesNone) {
  PoseHistoryTeamSource k(history_options());
  for (int i = 0; i <= 5; ++i) k.add_pose(pose(2, 10.0 + 0.1 * i, 0.0, 0.1 * i, 0.0, 0.0, 1.0));
  std::array<TeamMemberEstimate, kMaxRobots> out{};
  ASSERT_EQ(k.estimate(Time::from_seconds(10.5), out), 1u);
  EXPECT_TRUE(out[0].correction.none());
  EXPECT_EQ(out[0].correction.x_mm, 0);
  EXPECT_EQ(out[0].correction.yaw_urad, 0);
}

TEST(PoseHistoryTeamSource, OrderedByIdAndLostFromLivelinessOrAge) {
  mapping::TrackerOptions o;
  o.lost_after_s = 1.0;
  PoseHistoryTeamSource k(history_options(o));
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
  k.set_lost(9, false);
  ASSERT_EQ(k.estimate(Time::from_seconds(10.1), out), 2u);
  EXPECT_FALSE(out[1].lost);
}

// A correction given to a source with its own history: the poses after it are corrected before the
// tracker, and the track's drift restarts from the correction's σ at the next pose.
TEST(PoseHistoryTeamSource, PosesAfterACorrectionArePublishedCorrected) {
  mapping::TrackerOptions o;
  o.drift_m_per_m = 0.02;
  PoseHistoryTeamSource k(history_options(o));
  for (int i = 0; i <= 20; ++i) k.add_pose(pose(3, 10.0 + 0.1 * i, 0.1 * i, 0.0, 0.0, 1.0, 0.0));
  std::array<TeamMemberEstimate, kMaxRobots> out{};
  ASSERT_EQ(k.estimate(Time::from_seconds(12.1), out), 1u);
  const double cov_before = out[0].cov_xx_m2;
  // Odometry says (2, 0); the map says the odometry frame sits 0.3 m further in y and turned 0.05 rad.
  k.set_correction(3, 0.0, 0.3, 0.05, 0.01, 0.001, /*measurement=*/true);
  k.add_pose(pose(3, 12.1, 2.1, 0.0, 0.0, 1.0, 0.0));
  ASSERT_EQ(k.estimate(Time::from_seconds(12.1), out), 1u);
  EXPECT_LT(out[0].cov_xx_m2, cov_before);  // the drift restarted from the correction's σ
  for (int i = 22; i <= 60; ++i) k.add_pose(pose(3, 10.0 + 0.1 * i, 0.1 * i, 0.0, 0.0, 1.0, 0.0));
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
  ASSERT_EQ(k.estimate(Time::from_seconds(16.0), out), 1u);
  EXPECT_EQ(out[0].correction.seq, 2u);
}

// The station's wiring with the fusion stage on: the source views the core's history (the one tracker).
// add_pose on the source feeds nothing (the stage's hook feeds the core); what the core's history holds,
// including a correction set by stamp (as the registration does), is what teamscan/team carries.
TEST(PoseHistoryTeamSource, ViewsTheFusionCoresHistory) {
  FusionOptions fo;
  fo.latency_csv.clear();
  const std::string dir = ::testing::TempDir();
  auto stage = FusionStage::create(fo, dir);
  ASSERT_TRUE(stage.ok());
  FusionStage& fusion = **stage;
  PoseHistoryTeamSource source(fusion.core().poses());
  EXPECT_EQ(&source.history(), &fusion.core().poses());
  for (int i = 0; i <= 20; ++i) {
    const PoseObservation p = pose(4, 20.0 + 0.1 * i, 0.5 * 0.1 * i, 2.0, 0.0, 0.5, 0.0);
    source.add_pose(p);  // what Station::on_pose does before its hooks
    fusion.add_pose(p);  // the fusion stage's pose hook
  }
  EXPECT_EQ(fusion.core().poses().poses_held(), 21u);  // once, from the hook
  EXPECT_EQ(fusion.core().poses().duplicates(), 0u);
  std::array<TeamMemberEstimate, kMaxRobots> out{};
  ASSERT_EQ(source.estimate(Time::from_seconds(22.0), out), 1u);
  const mapping::RobotEstimate* track = fusion.core().poses().newest_tracks_at(Time::from_seconds(22.0).ns()).find(4);
  ASSERT_NE(track, nullptr);
  EXPECT_EQ(out[0].x_m, track->position_m.x);
  EXPECT_NEAR(out[0].x_m, 1.0, 0.01);
  EXPECT_NEAR(out[0].y_m, 2.0, 0.01);
  // The registration corrects robot 4 from 21.0 s on (a scan's stamp, before the newest poses): the
  // poses stamped after it are folded again, and the published state moves with them.
  fusion.core().poses().set_map_from_odom(4, Time::from_seconds(21.0).ns(), Pose2{0.0, -0.5, 0.0}, 0.02, 0.001, true);
  source.set_correction(4, 0.0, -0.5, 0.0, 0.02, 0.001, true);  // CorrectionShare: the wire form only
  ASSERT_EQ(source.estimate(Time::from_seconds(22.0), out), 1u);
  EXPECT_NEAR(out[0].x_m, 1.0, 0.01);
  EXPECT_NEAR(out[0].y_m, 1.5, 0.05);
  EXPECT_EQ(out[0].correction.seq, 1u);
  EXPECT_EQ(out[0].correction.y_mm, -500);
  EXPECT_EQ(fusion.core().poses().map_from_odom(4, Time::from_seconds(21.0).ns()).y_m, -0.5);  // set once, by the core
}

}  // namespace
}  // namespace teamscan::station
