// Pure conversions of the DDS bridge (onboard structs <-> IDL types) and option validation.
#include <gtest/gtest.h>

#include <cstring>

#include "onboard/bridge/bridge.hpp"
#include "teamscan.h"

namespace teamscan::onboard {
namespace {

TEST(DdsCodec, IdlConstantsMatchCapacities) {
  EXPECT_EQ(teamscan_msg_MAX_BEAMS, kMaxBeams);
  EXPECT_EQ(teamscan_msg_MAX_ROBOTS, kMaxRobots);
  EXPECT_EQ(teamscan_msg_POINT_DIRECTION_FILTERED, kPointDirectionFiltered);
  EXPECT_EQ(teamscan_msg_POINT_INVALID, kPointInvalid);
  EXPECT_EQ(teamscan_msg_POINT_DAZZLED, kPointDazzled);
  EXPECT_EQ(teamscan_msg_POINT_POSITION_FILTERED, kPointPositionFiltered);
  EXPECT_EQ(teamscan_msg_POINT_OUT_OF_RANGE, kPointOutOfRange);
  EXPECT_EQ(teamscan_msg_POINT_NO_POSE, kPointNoPose);
  EXPECT_EQ(teamscan_msg_POINT_TEAM_STALE, kPointTeamStale);
  EXPECT_EQ(sizeof(teamscan_msg_ScanPoints::points) / sizeof(teamscan_msg_ScanPoint), kMaxBeams);
}

TEST(DdsCodec, ScanFieldsCopiedAndTailZeroed) {
  static ScanPoints in;
  in.robot_id = 7;
  in.seq = 123456;
  in.stamp = Time::from_ns(1'700'000'000'123'456'789);
  in.origin_x_mm = -1500;
  in.origin_y_mm = 2500;
  in.origin_z_mm = 420;
  in.applied = OdomCorrection{-120, 340, -2'000'000, 12};
  in.count = 3;
  in.points[0] = ScanPoint{1, -2, 3, 0, kPointInvalid};
  in.points[1] = ScanPoint{-80000, 80000, -1, 200, kPointDirectionFiltered | kPointDazzled};
  in.points[2] = ScanPoint{INT32_MAX, INT32_MIN, 0, 400, 0};
  static teamscan_msg_ScanPoints out;
  std::memset(&out, 0xAB, sizeof out);  // stale bytes from a longer sweep
  encode_scan(in, out);
  EXPECT_EQ(out.robot_id, 7u);
  EXPECT_EQ(out.seq, 123456u);
  EXPECT_EQ(out.stamp_ns, 1'700'000'000'123'456'789);
  EXPECT_EQ(out.origin_x_mm, -1500);
  EXPECT_EQ(out.origin_y_mm, 2500);
  EXPECT_EQ(out.origin_z_mm, 420);
  EXPECT_EQ(out.corr_x_mm, -120);
  EXPECT_EQ(out.corr_y_mm, 340);
  EXPECT_EQ(out.corr_yaw_urad, -2'000'000);
  EXPECT_EQ(out.corr_seq, 12u);
  ASSERT_EQ(out.count, 3);
  EXPECT_EQ(out.points[1].x_mm, -80000);
  EXPECT_EQ(out.points[1].y_mm, 80000);
  EXPECT_EQ(out.points[1].beam, 200);
  EXPECT_EQ(out.points[1].flags, 5);
  EXPECT_EQ(out.points[2].x_mm, INT32_MAX);
  EXPECT_EQ(out.points[2].y_mm, INT32_MIN);
  EXPECT_EQ(out.points[2].beam, 400);
  for (std::size_t i = 3; i < kMaxBeams; ++i) {
    ASSERT_EQ(out.points[i].x_mm, 0) << i;
    ASSERT_EQ(out.points[i].flags, 0) << i;
  }
}

TEST(DdsCodec, ScanCountAboveCapacityIsClamped) {
  static ScanPoints in;
  in.robot_id = 1;
  in.count = 999;  // corrupt count from a bug upstream: never read past the array
  static teamscan_msg_ScanPoints out;
  encode_scan(in, out);
  EXPECT_EQ(out.count, kMaxBeams);
}

TEST(DdsCodec, TeamDecodeCopiesEveryMemberAndRejectsBadCount) {
  static teamscan_msg_TeamState in;
  std::memset(&in, 0, sizeof in);
  in.count = 2;
  in.members[0] = teamscan_msg_TeamMember{3, 1000, -2000, 10, -20, 25.0f, 1.5f, 36.0f, 508, 497, 900, 0, 0, 42,
                                          -150, 260, 1'234'567, 35, 8'000, 77};
  in.members[1] = teamscan_msg_TeamMember{9, 0, 0, 0, 0, 0.0f, 0.0f, 0.0f, 0, 0, 0, 1, 0, -1, 0, 0, 0, 0, 0, 0};
  TeamSnapshot out;
  ASSERT_TRUE(decode_team(in, out));
  ASSERT_EQ(out.count, 2u);
  EXPECT_EQ(out.members[0].robot_id, 3u);
  EXPECT_EQ(out.members[0].x_mm, 1000);
  EXPECT_EQ(out.members[0].y_mm, -2000);
  EXPECT_EQ(out.members[0].vx_mmps, 10);
  EXPECT_EQ(out.members[0].vy_mmps, -20);
  EXPECT_FLOAT_EQ(out.members[0].cov_xx, 25.0f);
  EXPECT_FLOAT_EQ(out.members[0].cov_xy, 1.5f);
  EXPECT_FLOAT_EQ(out.members[0].cov_yy, 36.0f);
  EXPECT_EQ(out.members[0].length_mm, 508);
  EXPECT_EQ(out.members[0].width_mm, 497);
  EXPECT_EQ(out.members[0].height_mm, 900);
  EXPECT_EQ(out.members[0].valid_ns, 42);
  EXPECT_FALSE(out.members[0].lost);
  EXPECT_EQ(out.members[0].correction.x_mm, -150);
  EXPECT_EQ(out.members[0].correction.y_mm, 260);
  EXPECT_EQ(out.members[0].correction.yaw_urad, 1'234'567);
  EXPECT_EQ(out.members[0].correction_sigma_mm, 35u);
  EXPECT_EQ(out.members[0].correction_sigma_yaw_urad, 8'000u);
  EXPECT_EQ(out.members[0].correction.seq, 77u);
  EXPECT_TRUE(out.members[1].lost);
  EXPECT_TRUE(out.members[1].correction.none());

  in.count = 33;
  TeamSnapshot untouched;
  untouched.count = 5;
  EXPECT_FALSE(decode_team(in, untouched));
  EXPECT_EQ(untouched.count, 5u);
}

TEST(DdsCodec, PoseAndStatusFieldsCopied) {
  OnboardPose p{4, 77, 99, -1, 2, -3141592, 500, -600, 70};
  teamscan_msg_RobotPose q{};
  encode_pose(p, q);
  EXPECT_EQ(q.robot_id, 4u);
  EXPECT_EQ(q.seq, 77u);
  EXPECT_EQ(q.stamp_ns, 99);
  EXPECT_EQ(q.x_mm, -1);
  EXPECT_EQ(q.y_mm, 2);
  EXPECT_EQ(q.yaw_urad, -3141592);
  EXPECT_EQ(q.vx_mmps, 500);
  EXPECT_EQ(q.vy_mmps, -600);
  EXPECT_EQ(q.yaw_rate_mradps, 70);

  OnboardStatus s;
  s.robot_id = 4;
  s.arcos_state = 3;
  s.lms_state = 5;
  s.team_fresh = true;
  s.lms_resyncs = 11;
  s.uptime_s = 3600;
  s.lms_reopens = 2;
  s.loop_max_us = 1234;
  s.clock_sync = 2;
  s.teams_rejected = 17;
  s.last_team_reject = 4;
  s.corrections_applied = 41;
  s.corrections_rejected = 3;
  teamscan_msg_RobotStatus t{};
  encode_status(s, t);
  EXPECT_EQ(t.corrections_applied, 41u);
  EXPECT_EQ(t.corrections_rejected, 3u);
  EXPECT_EQ(t.clock_sync, 2);
  EXPECT_EQ(t.teams_rejected, 17u);
  EXPECT_EQ(t.last_team_reject, 4u);
  EXPECT_EQ(t.arcos_state, 3);
  EXPECT_EQ(t.lms_state, 5);
  EXPECT_EQ(t.team_fresh, 1);
  EXPECT_EQ(t.lms_resyncs, 11u);
  EXPECT_EQ(t.uptime_s, 3600u);
  EXPECT_EQ(t.lms_reopens, 2u);
  EXPECT_EQ(t.loop_max_us, 1234u);
}

TEST(DdsBridgeOptions, BadRobotIdOrDepthRefusedBeforeTouchingDds) {
  DdsBridgeOptions o;
  o.robot_id = 0;
  EXPECT_FALSE(DdsBridge::create(o).ok());
  o.robot_id = 33;
  EXPECT_FALSE(DdsBridge::create(o).ok());
  o.robot_id = 1;
  o.scan_history_depth = 0;
  EXPECT_FALSE(DdsBridge::create(o).ok());
}

}  // namespace
}  // namespace teamscan::onboard
