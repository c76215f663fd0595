// Tests of the onboard pipeline: odometry -> pose message, scan -> points -> filter -> scan message,
// publish modes.
#include "onboard/core/pipeline.hpp"

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
  ScanBeams at(Time t) const { return {t, LaserVariant{180, 100}, range, flags}; }
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
  const OnboardScan& s = p->on_scan(b.at(kT0 + 60ms));
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
  const OnboardScan& s = p->on_scan(b.at(kT0 + 60ms));
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
  const OnboardScan& s = p->on_scan(b.at(kT0 + 10ms));
  for (std::uint16_t i = 0; i < s.count; ++i) EXPECT_EQ(s.points[i].flags, kPointTeamStale) << i;
  EXPECT_FALSE(p->team_fresh(kT0));
}

TEST(OnboardPipeline, NoOdometryMeansNoPoseAndNoFilter) {
  auto p = OnboardPipeline::create(config());
  ASSERT_TRUE(p.ok());
  Beams b;
  b.range.fill(2000);
  const OnboardScan& s = p->on_scan(b.at(kT0));
  EXPECT_EQ(s.count, 181);
  EXPECT_EQ(p->counters().scans_without_pose, 1u);
  EXPECT_EQ(p->counters().points_no_pose, 181u);
  for (std::uint16_t i = 0; i < s.count; ++i) EXPECT_EQ(s.points[i].flags, kPointNoPose) << i;
}

}  // namespace
}  // namespace teamscan::onboard
