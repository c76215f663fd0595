// The odometry correction's loop from the station to a robot and back, in process and without DDS
// traffic (the samples are the IDL's C structs the DDS layer carries): the station's team source gets a
// registration correction, teamscan/team carries it (team_member_from), the robot's pipeline takes it
// (decode_team, on_team), publishes its scans corrected and says so (encode_scan), and the station's
// edge (SampleValidator, stored_from) stores them back in the odometry-map frame: the points the fusion
// core and the session record see are those of a robot that applied nothing, to the millimetre.
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <cstdlib>
#include <string>

#include "groundstation/station/pose_history_team_source.hpp"
#include "groundstation/station/sample_validation.hpp"
#include "groundstation/station/station.hpp"
#include "onboard/bridge/bridge.hpp"
#include "onboard/core/pipeline.hpp"
#include "teamscan.h"
#include "tests/support/onboard_config_fixture.hpp"
#include "tests/support/pipeline_scan.hpp"

namespace teamscan {
namespace {

using namespace std::chrono_literals;

const Time kT0 = Time::from_ns(1'800'000'000'000'000'000);

onboard::OnboardPipeline make_robot() {
  std::string msg;
  auto config = onboard::parse_onboard_config(test::pipeline_test_config_toml(1, false), msg);
  EXPECT_TRUE(config.ok()) << msg;
  auto p = onboard::OnboardPipeline::create(config.value());
  EXPECT_TRUE(p.ok());
  return std::move(p.value());
}

// The station's reading of a teamscan/pose sample (station.cpp on_pose), for the team source.
station::PoseObservation observed(const onboard::OnboardPose& p) {
  station::PoseObservation o;
  o.robot_id = p.robot_id;
  o.seq = p.seq;
  o.stamp = Time::from_ns(p.stamp_ns);
  o.received = o.stamp;
  o.x_m = p.x_mm * 1e-3;
  o.y_m = p.y_mm * 1e-3;
  o.yaw_rad = p.yaw_urad * 1e-6;
  o.vx_mps = p.vx_mmps * 1e-3;
  o.vy_mps = p.vy_mmps * 1e-3;
  o.yaw_rate_radps = p.yaw_rate_mradps * 1e-3;
  return o;
}

struct Beams {
  std::array<std::uint32_t, 361> range{};
  std::array<std::uint8_t, 361> flags{};
  BeamSpans spans() const { return {range, flags}; }
};

TEST(RobotCorrectionLoop, TheRobotAppliesTheStationsCorrectionAndTheStationStoresTheOdometryFrame) {
  onboard::OnboardPipeline corrected = make_robot();
  onboard::OnboardPipeline plain = make_robot();  // the same robot that never applies a correction
  station::PoseHistoryTeamSource team{fusion::PoseHistoryOptions{}};  // the one tracker, its own history (no fusion stage here)

  // Robot 1 drives a 5 m arc at 0.5 m/s (0.1 rad/s), odometry at 10 Hz for 4 s; robot 2 stands still.
  onboard::OnboardPose pose;
  const auto odometry = [&](int k) {
    const Time t = kT0 + Duration{std::int64_t{k} * 100'000'000};
    const double a = 0.01 * k;
    const Pose2 odom_from_robot{5.0 * std::sin(a), 5.0 * (1.0 - std::cos(a)), a};
    ASSERT_TRUE(corrected.on_odometry(t, odom_from_robot, 500.0, 0.1, pose));
    ASSERT_TRUE(plain.on_odometry(t, odom_from_robot, 500.0, 0.1, pose));
    team.add_pose(observed(pose));
    station::PoseObservation still;
    still.robot_id = 2;
    still.stamp = t;
    still.x_m = 6.0;
    still.y_m = 1.0;
    team.add_pose(still);
  };
  for (int k = 0; k <= 20; ++k) odometry(k);
  // The registration moves robot 1's odometry frame by (0.25 m, −0.4 m, 0.08 rad).
  team.set_correction(1, 0.25, -0.4, 0.08, 0.03, 0.002, true);
  for (int k = 21; k <= 40; ++k) odometry(k);

  // teamscan/team as the station publishes it.
  const Time now = kT0 + 4s;
  std::array<station::TeamMemberEstimate, kMaxRobots> estimates{};
  static teamscan_msg_TeamState wire;
  wire.seq = 1;
  wire.stamp_ns = now.ns();
  wire.count = static_cast<std::uint8_t>(team.estimate(now, estimates));
  ASSERT_EQ(wire.count, 2);
  for (std::size_t i = 0; i < wire.count; ++i) station::team_member_from(estimates[i], false, wire.members[i]);
  EXPECT_EQ(wire.members[0].robot_id, 1u);
  EXPECT_EQ(wire.members[0].corr_x_mm, 250);
  EXPECT_EQ(wire.members[0].corr_y_mm, -400);
  EXPECT_EQ(wire.members[0].corr_yaw_urad, 80'000);
  EXPECT_EQ(wire.members[0].corr_sigma_mm, 30u);
  EXPECT_EQ(wire.members[0].corr_sigma_yaw_urad, 2'000u);
  EXPECT_EQ(wire.members[0].corr_seq, 1u);
  EXPECT_EQ(wire.members[1].corr_seq, 0u);  // robot 2: none

  // The robot takes it; the plain one gets the same state without its correction.
  onboard::TeamSnapshot snapshot;
  ASSERT_TRUE(onboard::decode_team(wire, snapshot));
  ASSERT_TRUE(corrected.on_team(snapshot, now).ok());
  snapshot.members[0].correction = OdomCorrection{};
  ASSERT_TRUE(plain.on_team(snapshot, now).ok());
  EXPECT_EQ(corrected.counters().corrections_applied, 1u);
  EXPECT_EQ(corrected.applied_correction().x_mm, 250);
  EXPECT_TRUE(plain.applied_correction().none());

  Beams beams;
  for (std::size_t b = 0; b < beams.range.size(); ++b) beams.range[b] = 1500 + static_cast<std::uint32_t>(b * 13 % 2500);
  beams.flags[7] = kBeamInvalid;  // no echo: the point sits at the laser's centre, and moves with it
  beams.flags[8] = kBeamDazzled;
  const Time scan_at = kT0 + 3900ms;
  static teamscan_msg_ScanPoints sample_corrected, sample_plain;
  onboard::encode_scan(test::scan_of(corrected, beams.spans(), scan_at), sample_corrected);
  // The robot's corrected position is where the station's tracker puts it (the team's frame).
  const Pose2 robot_at = corrected.last_scan().map_from_robot;
  EXPECT_NEAR(robot_at.x_m, estimates[0].x_m - estimates[0].vx_mps * 0.1, 0.05);
  EXPECT_NEAR(robot_at.y_m, estimates[0].y_m - estimates[0].vy_mps * 0.1, 0.05);
  onboard::encode_scan(test::scan_of(plain, beams.spans(), scan_at), sample_plain);
  EXPECT_EQ(sample_corrected.corr_seq, 1u);
  EXPECT_EQ(sample_corrected.corr_x_mm, 250);
  EXPECT_EQ(sample_plain.corr_seq, 0u);
  // The published points really moved: each is the correction applied to the plain robot's point.
  for (const std::uint16_t i : {0, 90, 180, 270, 360}) {
    const Vec2 expected = Pose2{0.25, -0.4, 0.08}.apply(
        Vec2{sample_plain.points[i].x_mm * 1e-3, sample_plain.points[i].y_mm * 1e-3});
    EXPECT_NEAR(sample_corrected.points[i].x_mm, expected.x * 1e3, 1.0) << i;
    EXPECT_NEAR(sample_corrected.points[i].y_mm, expected.y * 1e3, 1.0) << i;
    EXPECT_GT(std::abs(sample_corrected.points[i].x_mm - sample_plain.points[i].x_mm) +
                  std::abs(sample_corrected.points[i].y_mm - sample_plain.points[i].y_mm),
              100)
        << i;
  }

  // The station's edge: accepted, then stored in the odometry-map frame.
  station::SampleValidator validator;
  ASSERT_TRUE(validator.check_scan(sample_corrected, scan_at + 5ms).ok());
  const station::ReceiveTime at{scan_at + 5ms, scan_at + 5ms};
  static ScanPoints stored, reference;
  (void)station::stored_from(sample_corrected, at, station::Reject::kNone, stored);
  (void)station::stored_from(sample_plain, at, station::Reject::kNone, reference);
  EXPECT_EQ(stored.applied.seq, 1u);  // the record says which correction the robot applied
  EXPECT_EQ(stored.applied.yaw_urad, 80'000);
  EXPECT_LE(std::abs(stored.origin_x_mm - reference.origin_x_mm), 1);
  EXPECT_LE(std::abs(stored.origin_y_mm - reference.origin_y_mm), 1);
  EXPECT_EQ(stored.origin_z_mm, reference.origin_z_mm);
  ASSERT_EQ(stored.count, reference.count);
  int off_by_one = 0;
  for (std::uint16_t i = 0; i < stored.count; ++i) {
    const ScanPoint& a = stored.points[i];
    const ScanPoint& b = reference.points[i];
    ASSERT_EQ(a.beam, b.beam);
    ASSERT_EQ(a.z_mm, b.z_mm) << i;
    ASSERT_LE(std::abs(a.x_mm - b.x_mm), 1) << i;  // one rounding on the robot, one at the station
    ASSERT_LE(std::abs(a.y_mm - b.y_mm), 1) << i;
    off_by_one += (a.x_mm != b.x_mm) + (a.y_mm != b.y_mm);
  }
  EXPECT_LT(off_by_one, static_cast<int>(stored.count));  // mostly exact
  // A refused scan is stored as received: the robot's frame, its correction recorded.
  static ScanPoints refused;
  (void)station::stored_from(sample_corrected, at, station::Reject::kSeqJump, refused);
  EXPECT_EQ(refused.points[180].x_mm, sample_corrected.points[180].x_mm);
  EXPECT_EQ(refused.applied.seq, 1u);
}

}  // namespace
}  // namespace teamscan
