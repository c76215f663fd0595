// Tests of the onboard pipeline: odometry -> pose message, scan -> points -> filter -> scan message,
// publish modes.
#include "onboard/core/pipeline.hpp"
#include "tests/support/pipeline_scan.hpp"

#include <gtest/gtest.h>

#include <array>
#include <string>

namespace teamscan::onboard {
namespace {

OnboardConfig config(PublishMode publish = PublishMode::all) {
  std::string msg;
  auto c = parse_onboard_config(R"(
[robot]
id = 1
[arcos]
device = "/dev/a"
[lms]
device = "/dev/b"
fov_deg = 180
resolution_deg = 1
[mount]
x_m = 0
y_m = 0
z_m = 0.3
pitch_deg = 0
[registration]
x_m = 1.0
y_m = 0.0
theta_deg = 90
[filter]
half_angle_deg = 7
max_team_age_s = 0.5
)", msg);
  EXPECT_TRUE(c.ok()) << msg;
  c->publish = publish;
  return c.value();
}

const Time kT0 = Time::from_ns(1'700'000'000'000'000'000);

TEST(OnboardPipeline, PoseInTheMapFrame) {
  auto p = OnboardPipeline::create(config());
  ASSERT_TRUE(p.ok());
  OnboardPose pose;
  // Odometry (2, 0) heading 0, 500 mm/s forward; registration rotates by 90° and shifts by (1, 0).
  ASSERT_TRUE(p->on_odometry(kT0, {2.0, 0.0, 0.0}, 500.0, 0.1, pose));
  EXPECT_EQ(pose.robot_id, 1u);
  EXPECT_EQ(pose.seq, 1u);
  EXPECT_EQ(pose.stamp_ns, kT0.ns());
  EXPECT_EQ(pose.x_mm, 1000);
  EXPECT_EQ(pose.y_mm, 2000);
  EXPECT_EQ(pose.yaw_urad, 1570796);
  EXPECT_EQ(pose.vx_mmps, 0);
  EXPECT_EQ(pose.vy_mmps, 500);
  EXPECT_EQ(pose.yaw_rate_mradps, 100);
  EXPECT_FALSE(p->on_odometry(kT0, {}, 0, 0, pose));  // same stamp: refused, counted
  EXPECT_EQ(p->counters().odometry_rejected, 1u);
}

struct Beams {
  std::array<std::uint32_t, 181> range{};
  std::array<std::uint8_t, 181> flags{};
  BeamSpans spans() const { return {range, flags}; }
};

TEST(OnboardPipeline, ScanFilteredAgainstTheTeamAndPublishedWithFlags) {
  auto p = OnboardPipeline::create(config());
  ASSERT_TRUE(p.ok());
  OnboardPose pose;
  // Robot at map (1, 0) facing map +y (odometry origin, heading 0, registration 90°).
  ASSERT_TRUE(p->on_odometry(kT0, {0, 0, 0}, 0, 0, pose));
  ASSERT_TRUE(p->on_odometry(kT0 + 100ms, {0, 0, 0}, 0, 0, pose));
  TeamSnapshot team;
  team.count = 1;
  team.members[0].robot_id = 2;
  team.members[0].x_mm = 1000;
  team.members[0].y_mm = 3000;  // 3 m straight ahead
  team.members[0].valid_ns = (kT0 + 50ms).ns();
  p->on_team(team, kT0 + 50ms);
  Beams b;
  b.range.fill(3000);
  b.flags[0] = kBeamInvalid;
  const ScanPoints& s = test::scan_of(*p, b.spans(), kT0 + 60ms);
  EXPECT_EQ(s.robot_id, 1u);
  EXPECT_EQ(s.seq, 1u);
  EXPECT_EQ(s.count, 181);
  EXPECT_EQ(s.origin_x_mm, 1000);
  EXPECT_EQ(s.origin_y_mm, 0);
  EXPECT_EQ(s.origin_z_mm, 300);
  // Beam 90 hits (1000, 3000): inside the cone. Beams 84..96 are within ±6°, inside a 7° cone at 3 m;
  // beam 80 (10°) is not.
  EXPECT_EQ(s.points[90].x_mm, 1000);
  EXPECT_EQ(s.points[90].y_mm, 3000);
  EXPECT_EQ(s.points[90].flags, kPointDirectionFiltered);
  EXPECT_EQ(s.points[84].flags, kPointDirectionFiltered);
  EXPECT_EQ(s.points[96].flags, kPointDirectionFiltered);
  EXPECT_EQ(s.points[80].flags, 0);
  EXPECT_EQ(s.points[0].flags, kPointInvalid);
  EXPECT_EQ(p->last_filter_stats().filtered, 13u);
  EXPECT_EQ(p->counters().points_direction_filtered, 13u);
  EXPECT_TRUE(p->team_fresh(kT0 + 60ms));
  EXPECT_FALSE(p->team_fresh(kT0 + 551ms));
}

// A team state whose member for robot 1 (this robot) carries `correction`, and, if mate_y_mm is not 0,
// teammate 2 at (mate_x_mm, mate_y_mm), all valid at `at`.
TeamSnapshot team_with_correction(const OdomCorrection& correction, Time at, std::int32_t mate_x_mm = 0,
                                  std::int32_t mate_y_mm = 0) {
  TeamSnapshot team;
  team.count = 1;
  team.members[0].robot_id = 1;
  team.members[0].x_mm = 1000;
  team.members[0].valid_ns = at.ns();
  team.members[0].correction = correction;
  if (mate_y_mm != 0) {
    team.count = 2;
    team.members[1].robot_id = 2;
    team.members[1].x_mm = mate_x_mm;
    team.members[1].y_mm = mate_y_mm;
    team.members[1].valid_ns = at.ns();
  }
  return team;
}

TEST(OnboardPipeline, OwnCorrectionMovesThePublishedScanAndTheScanSaysWhichOne) {
  auto p = OnboardPipeline::create(config());
  ASSERT_TRUE(p.ok());
  OnboardPose pose;
  // Robot at map (1, 0) facing map +y in its odometry-map frame.
  ASSERT_TRUE(p->on_odometry(kT0, {0, 0, 0}, 0, 0, pose));
  ASSERT_TRUE(p->on_odometry(kT0 + 100ms, {0, 0, 0}, 0, 0, pose));
  // map_from_odom = (0.1 m, 0.2 m, +0.2 rad).
  const OdomCorrection c{100, 200, 200'000, 7};
  const TeamCheck check = p->on_team(team_with_correction(c, kT0 + 50ms), kT0 + 50ms);
  EXPECT_TRUE(check.ok()) << team_reject_name(check.reason);
  EXPECT_EQ(p->counters().corrections_applied, 1u);
  EXPECT_EQ(p->applied_correction().seq, 7u);
  Beams b;
  b.range.fill(3000);
  const ScanPoints& s = test::scan_of(*p, b.spans(), kT0 + 60ms);
  EXPECT_EQ(s.applied.x_mm, 100);
  EXPECT_EQ(s.applied.y_mm, 200);
  EXPECT_EQ(s.applied.yaw_urad, 200'000);
  EXPECT_EQ(s.applied.seq, 7u);
  // Origin (1000, 0, 300) turned by 0.2 rad and shifted: (1080.07, 398.67, 300).
  EXPECT_EQ(s.origin_x_mm, 1080);
  EXPECT_EQ(s.origin_y_mm, 399);
  EXPECT_EQ(s.origin_z_mm, 300);
  // Beam 90 hits odometry-map (1000, 3000): corrected (1000 cos 0.2 − 3000 sin 0.2 + 100,
  // 1000 sin 0.2 + 3000 cos 0.2 + 200) = (484.06, 3338.87).
  EXPECT_EQ(s.points[90].x_mm, 484);
  EXPECT_EQ(s.points[90].y_mm, 3339);
  EXPECT_EQ(s.points[90].z_mm, 300);
  // teamscan/pose stays in the odometry-map frame (the station's tracker and registration take it).
  ASSERT_TRUE(p->on_odometry(kT0 + 200ms, {0, 0, 0}, 0, 0, pose));
  EXPECT_EQ(pose.x_mm, 1000);
  EXPECT_EQ(pose.y_mm, 0);
  // The same correction again (every team state repeats it) is not a new one.
  p->on_team(team_with_correction(c, kT0 + 150ms), kT0 + 150ms);
  EXPECT_EQ(p->counters().corrections_applied, 1u);
}

TEST(OnboardPipeline, DirectionFilterUsesTheCorrectedOwnPositionAgainstCorrectedTeammates) {
  // The robot stands at odometry-map (1, 0) facing +y; the station's correction shifts its odometry by
  // 1.5 m along −x: corrected, it stands at (−0.5, 0). cone::Teammate 2 (corrected, as every position in
  // teamscan/team) stands 6 m straight ahead of the corrected robot at (−0.5, 6).
  const OdomCorrection shift{-1500, 0, 0, 1};
  for (const bool corrected : {true, false}) {
    auto p = OnboardPipeline::create(config());
    ASSERT_TRUE(p.ok());
    OnboardPose pose;
    ASSERT_TRUE(p->on_odometry(kT0, {0, 0, 0}, 0, 0, pose));
    ASSERT_TRUE(p->on_odometry(kT0 + 100ms, {0, 0, 0}, 0, 0, pose));
    p->on_team(team_with_correction(corrected ? shift : OdomCorrection{}, kT0 + 50ms, -500, 6000), kT0 + 50ms);
    Beams b;
    b.range.fill(3000);
    const ScanPoints& s = test::scan_of(*p, b.spans(), kT0 + 60ms);
    if (corrected) {
      // The sweep's centre beam hits (−0.5, 3), on the line to the teammate: beams within ±6° are in
      // the 7° cone from the corrected apex (−0.5, 0). (Corrected points from the uncorrected apex
      // (1, 0) would leave beam 90 12.6° off the line to the teammate: not filtered.)
      EXPECT_EQ(s.points[90].x_mm, -500);
      EXPECT_EQ(s.points[90].y_mm, 3000);
      EXPECT_EQ(s.points[90].flags, kPointDirectionFiltered);
      EXPECT_EQ(s.points[84].flags, kPointDirectionFiltered);
      EXPECT_EQ(s.points[96].flags, kPointDirectionFiltered);
      EXPECT_EQ(s.points[80].flags, 0);
      EXPECT_EQ(p->last_filter_stats().filtered, 13u);
    } else {
      // Without the correction (the robot's own frame against the teammate's corrected position) the
      // line to the teammate points 14° to the left of the sweep's centre: the teammate's ghosts in
      // front of it stay, and the cone removes other points (beams 98..111).
      EXPECT_EQ(s.points[90].x_mm, 1000);
      EXPECT_EQ(s.points[90].flags, 0);
      EXPECT_EQ(s.points[84].flags, 0);
      EXPECT_EQ(s.points[96].flags, 0);
      EXPECT_EQ(s.points[104].flags, kPointDirectionFiltered);
      EXPECT_EQ(p->last_filter_stats().filtered, 14u);
    }
  }
}

TEST(OnboardPipeline, AnAbsurdCorrectionStepIsRefusedCountedAndTheAppliedOneStays) {
  auto p = OnboardPipeline::create(config());
  ASSERT_TRUE(p.ok());
  OnboardPose pose;
  ASSERT_TRUE(p->on_odometry(kT0, {0, 0, 0}, 0, 0, pose));
  ASSERT_TRUE(p->on_odometry(kT0 + 1s, {0, 0, 0}, 0, 0, pose));
  Time t = kT0 + 10ms;
  const auto team = [&](OdomCorrection c) {
    t += 10ms;
    return p->on_team(team_with_correction(c, t), t);
  };
  EXPECT_TRUE(team({500, 0, 0, 1}).ok());
  EXPECT_EQ(p->applied_correction().seq, 1u);
  EXPECT_TRUE(team({5500, 0, 0, 2}).ok());  // 5 m in one step: the team state is good, the step is not
  EXPECT_TRUE(team({500, 0, 700'000, 3}).ok());  // 40° in one step
  EXPECT_EQ(p->counters().corrections_rejected, 2u);
  EXPECT_EQ(p->applied_correction().seq, 1u);
  Beams b;
  b.range.fill(3000);
  EXPECT_EQ(test::scan_of(*p, b.spans(), t).applied.seq, 1u);
  EXPECT_EQ(p->last_scan().origin_x_mm, 1500);
  // A plausible step after the refused ones is taken (measured from the applied one).
  EXPECT_TRUE(team({700, -300, 400'000, 4}).ok());  // 0.36 m, 22.9°
  EXPECT_EQ(p->applied_correction().seq, 4u);
  EXPECT_EQ(p->counters().corrections_applied, 2u);
  // None (a restarted station): back to the identity, whatever the step.
  EXPECT_TRUE(team({}).ok());
  EXPECT_TRUE(p->applied_correction().none());
  EXPECT_EQ(test::scan_of(*p, b.spans(), t).applied.seq, 0u);
  EXPECT_EQ(p->last_scan().origin_x_mm, 1000);
  EXPECT_EQ(p->counters().corrections_applied, 3u);
  EXPECT_EQ(p->counters().corrections_rejected, 2u);
}

TEST(OnboardPipeline, KeptModePublishesOnlyValidUnfilteredPoints) {
  auto p = OnboardPipeline::create(config(PublishMode::kept));
  ASSERT_TRUE(p.ok());
  OnboardPose pose;
  ASSERT_TRUE(p->on_odometry(kT0, {0, 0, 0}, 0, 0, pose));
  ASSERT_TRUE(p->on_odometry(kT0 + 100ms, {0, 0, 0}, 0, 0, pose));
  TeamSnapshot team;
  team.count = 1;
  team.members[0].robot_id = 2;
  team.members[0].x_mm = 1000;
  team.members[0].y_mm = 3000;
  team.members[0].valid_ns = (kT0 + 50ms).ns();
  p->on_team(team, kT0 + 50ms);
  Beams b;
  b.range.fill(3000);
  b.flags[0] = kBeamInvalid;
  b.flags[1] = kBeamDazzled;
  b.range[2] = 9000;  // beyond max_range_m = 8
  const ScanPoints& s = test::scan_of(*p, b.spans(), kT0 + 60ms);
  EXPECT_EQ(s.count, 181 - 13 - 3);
  for (std::uint16_t i = 0; i < s.count; ++i) EXPECT_EQ(s.points[i].flags, 0) << i;
  EXPECT_EQ(s.points[0].beam, 3);
}

TEST(OnboardPipeline, NoTeamYetMarksPointsStale) {
  auto p = OnboardPipeline::create(config());
  ASSERT_TRUE(p.ok());
  OnboardPose pose;
  ASSERT_TRUE(p->on_odometry(kT0, {0, 0, 0}, 0, 0, pose));
  Beams b;
  b.range.fill(2000);
  const ScanPoints& s = test::scan_of(*p, b.spans(), kT0 + 10ms);
  for (std::uint16_t i = 0; i < s.count; ++i) EXPECT_EQ(s.points[i].flags, kPointTeamStale) << i;
  EXPECT_FALSE(p->team_fresh(kT0));
}

TEST(OnboardPipeline, NoOdometryMeansNoPoseAndNoFilter) {
  auto p = OnboardPipeline::create(config());
  ASSERT_TRUE(p.ok());
  Beams b;
  b.range.fill(2000);
  const ScanPoints& s = test::scan_of(*p, b.spans(), kT0);
  EXPECT_EQ(s.count, 181);
  EXPECT_EQ(p->counters().scans_without_pose, 1u);
  EXPECT_EQ(p->counters().points_no_pose, 181u);
  for (std::uint16_t i = 0; i < s.count; ++i) EXPECT_EQ(s.points[i].flags, kPointNoPose) << i;
}

// Only a full sweep of the configured variant (180°/1° here: 181 beams) is placed; anything else is
// refused and counted, and takes no sequence number.
TEST(OnboardPipeline, ASweepThatIsNotOneOfTheConfiguredVariantIsRefused) {
  auto p = OnboardPipeline::create(config());
  ASSERT_TRUE(p.ok());
  const std::array<std::uint32_t, 361> range{};
  const std::array<std::uint8_t, 361> flags{};
  EXPECT_EQ(p->on_scan(BeamSpans{range, flags}, kT0), nullptr);  // a 0.5° sweep
  EXPECT_EQ(p->on_scan(BeamSpans{}, kT0), nullptr);              // a partial telegram's sweep()
  EXPECT_EQ(p->counters().scans_refused, 2u);
  EXPECT_EQ(p->counters().scans, 0u);
  Beams b;
  b.range.fill(2000);
  EXPECT_EQ(test::scan_of(*p, b.spans(), kT0).seq, 1u);
  EXPECT_EQ(p->counters().scans, 1u);
}

}  // namespace
}  // namespace teamscan::onboard
