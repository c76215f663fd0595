// SampleValidator (groundstation/station/sample_validation.hpp): every reason of the bad-sample
// publisher is refused and counted per robot and reason, sane samples pass, sequence wrap / replay /
// restart / jump + resync, clock offset reports, the rate-limited log.
#include <gtest/gtest.h>

#include <climits>
#include <cstring>

#include "groundstation/station/sample_validation.hpp"
#include "teamscan.h"

namespace teamscan::station {
namespace {

constexpr std::int64_t kNow = 1'800'000'000'000'000'000;  // 2027-01-15
const Time kRecv = Time::from_ns(kNow);

teamscan_msg_RobotPose pose(std::uint32_t id, std::uint32_t seq, std::int64_t stamp = kNow - 20'000'000) {
  teamscan_msg_RobotPose p{};
  p.robot_id = id;
  p.seq = seq;
  p.stamp_ns = stamp;
  p.x_mm = 1200;
  p.y_mm = -3400;
  p.yaw_urad = 1'000'000;
  p.vx_mmps = 300;
  p.yaw_rate_mradps = 200;
  return p;
}

teamscan_msg_ScanPoints& scan(std::uint32_t id, std::uint32_t seq, std::int64_t stamp = kNow - 30'000'000) {
  static teamscan_msg_ScanPoints s;
  std::memset(&s, 0, sizeof s);
  s.robot_id = id;
  s.seq = seq;
  s.stamp_ns = stamp;
  s.origin_z_mm = 462;
  s.count = 401;
  for (std::uint16_t b = 0; b < 401; ++b) s.points[b] = teamscan_msg_ScanPoint{1000 + b, 2000, 300, b, 0};
  return s;
}

TEST(SampleValidation, SaneSamplesPass) {
  SampleValidator v;
  for (std::uint32_t seq = 1; seq <= 10; ++seq) {
    EXPECT_TRUE(v.check_pose(pose(3, seq), kRecv).ok());
    EXPECT_TRUE(v.check_scan(scan(3, seq), kRecv).ok());
    teamscan_msg_RobotStatus st{};
    st.robot_id = 3;
    st.seq = seq;
    st.stamp_ns = kNow;
    EXPECT_TRUE(v.check_status(st, kRecv).ok());
  }
  EXPECT_EQ(v.counters().rejected, 0u);
  EXPECT_EQ(v.counters().by_reason[0], 30u);
  EXPECT_TRUE(v.status_text().empty());
}

TEST(SampleValidation, EveryBadValueOfTheIssueIsRefusedWithItsReason) {
  SampleValidator v;
  EXPECT_EQ(v.check_pose(pose(0, 1), kRecv).reason, Reject::kRobotId);
  EXPECT_EQ(v.check_pose(pose(33, 1), kRecv).reason, Reject::kRobotId);
  EXPECT_EQ(v.check_scan(scan(999999, 1), kRecv).reason, Reject::kRobotId);
  auto& s = scan(1, 1);
  s.count = 65535;
  EXPECT_EQ(v.check_scan(s, kRecv).reason, Reject::kBeamCount);
  auto& s2 = scan(1, 2);
  s2.count = 402;
  EXPECT_EQ(v.check_scan(s2, kRecv).reason, Reject::kBeamCount);
  EXPECT_EQ(v.check_pose(pose(2, 1, 0), kRecv).reason, Reject::kClockUnset);
  EXPECT_EQ(v.check_pose(pose(2, 2, INT64_MIN), kRecv).reason, Reject::kClockUnset);
  EXPECT_EQ(v.check_pose(pose(2, 3, INT64_MAX), kRecv).reason, Reject::kStampAhead);
  EXPECT_EQ(v.check_pose(pose(2, 4, kNow - 3'600'000'000'000), kRecv).reason, Reject::kStampBehind);
  auto far = pose(7, 1);
  far.x_mm = INT32_MAX;
  EXPECT_EQ(v.check_pose(far, kRecv).reason, Reject::kOutsideSite);
  far.x_mm = 0;
  far.y_mm = INT32_MIN;
  EXPECT_EQ(v.check_pose(far, kRecv).reason, Reject::kOutsideSite);
  auto yaw = pose(7, 2);
  yaw.yaw_urad = INT32_MAX;  // 2^31 µrad does not fit; the largest int32
  EXPECT_EQ(v.check_pose(yaw, kRecv).reason, Reject::kYaw);
  yaw.yaw_urad = -3'141'593;  // −π rounded: just outside (−π, π] is still accepted as the robots round
  EXPECT_TRUE(v.check_pose(yaw, kRecv).ok());
  yaw.yaw_urad = -3'141'595;
  EXPECT_EQ(v.check_pose(yaw, kRecv).reason, Reject::kYaw);
  auto fast = pose(7, 4);
  fast.vx_mmps = 2'000'000;
  EXPECT_EQ(v.check_pose(fast, kRecv).reason, Reject::kVelocity);
  auto& origin = scan(4, 1);
  origin.origin_x_mm = INT32_MIN;
  EXPECT_EQ(v.check_scan(origin, kRecv).reason, Reject::kOutsideSite);
  auto& point = scan(4, 2);
  point.points[200].z_mm = INT32_MAX;
  EXPECT_EQ(v.check_scan(point, kRecv).reason, Reject::kOutsideSite);
  auto& unplaced = scan(4, 3);
  unplaced.points[200].z_mm = INT32_MAX;
  unplaced.points[200].flags = teamscan_msg_POINT_INVALID;  // no echo: coordinates unused
  EXPECT_TRUE(v.check_scan(unplaced, kRecv).ok());
  auto& beam = scan(4, 4);
  beam.points[5].beam = 401;
  EXPECT_EQ(v.check_scan(beam, kRecv).reason, Reject::kBeamIndex);

  const ValidationCounters& c = v.counters();
  EXPECT_EQ(c.by_robot[0][static_cast<std::size_t>(Reject::kRobotId)], 3u);
  EXPECT_EQ(c.by_robot[1][static_cast<std::size_t>(Reject::kBeamCount)], 2u);
  EXPECT_EQ(c.by_robot[2][static_cast<std::size_t>(Reject::kClockUnset)], 2u);
  EXPECT_EQ(c.by_robot[2][static_cast<std::size_t>(Reject::kStampAhead)], 1u);
  EXPECT_EQ(c.by_robot[2][static_cast<std::size_t>(Reject::kStampBehind)], 1u);
  EXPECT_EQ(c.by_robot[7][static_cast<std::size_t>(Reject::kOutsideSite)], 2u);
  EXPECT_EQ(c.by_robot[7][static_cast<std::size_t>(Reject::kYaw)], 2u);
  EXPECT_EQ(c.by_robot[7][static_cast<std::size_t>(Reject::kVelocity)], 1u);
  EXPECT_EQ(c.by_robot[4][static_cast<std::size_t>(Reject::kOutsideSite)], 2u);
  EXPECT_EQ(c.by_robot[4][static_cast<std::size_t>(Reject::kBeamIndex)], 1u);
  EXPECT_EQ(c.rejected, 17u);
  EXPECT_EQ(c.rejected_by_topic[static_cast<std::size_t>(SampleTopic::kPose)], 11u);
  EXPECT_NE(v.csv().find("0,robot_id,3\n"), std::string::npos);
  EXPECT_NE(v.status_text().find("rejected 17"), std::string::npos);
}

// The correction a robot says it applied to a scan (ScanPoints.corr_*): none is all zeros; a correction
// turns within (−π, π] and shifts by at most the site's extent. Anything else: kCorrection, not fused.
TEST(SampleValidation, TheAppliedCorrectionOfAScanIsChecked) {
  SampleValidator v;
  std::uint32_t seq = 0;
  const auto with = [&](std::int32_t x, std::int32_t y, std::int32_t yaw, std::uint32_t corr_seq) {
    auto& s = scan(5, ++seq);
    s.corr_x_mm = x;
    s.corr_y_mm = y;
    s.corr_yaw_urad = yaw;
    s.corr_seq = corr_seq;
    return v.check_scan(s, kRecv);
  };
  EXPECT_TRUE(with(0, 0, 0, 0).ok());
  EXPECT_TRUE(with(-150, 37, -3'141'593, 1).ok());
  EXPECT_TRUE(with(20'000'000, -20'000'000, 3'141'593, 2).ok());  // the site's whole width (±10 km)
  EXPECT_EQ(with(0, 0, 3'141'594, 3).reason, Reject::kCorrection);
  EXPECT_EQ(with(0, 0, INT32_MIN, 3).reason, Reject::kCorrection);
  EXPECT_EQ(with(20'000'001, 0, 0, 3).reason, Reject::kCorrection);
  EXPECT_EQ(with(0, INT32_MIN, 0, 3).reason, Reject::kCorrection);
  EXPECT_EQ(with(5, 0, 0, 0).reason, Reject::kCorrection);  // values, but "none applied"
  EXPECT_EQ(v.counters().by_robot[5][static_cast<std::size_t>(Reject::kCorrection)], 5u);
  EXPECT_STREQ(reject_name(Reject::kCorrection), "correction");
}

TEST(SampleValidation, SequenceWrapReplayRestartJumpAndResync) {
  SampleValidator v;
  const std::uint32_t top = 0xFFFFFFFEu;
  EXPECT_TRUE(v.check_pose(pose(5, top), kRecv).ok());
  EXPECT_TRUE(v.check_pose(pose(5, top + 1), kRecv).ok());
  EXPECT_TRUE(v.check_pose(pose(5, 0), kRecv).ok());  // wrapped: progress
  EXPECT_TRUE(v.check_pose(pose(5, 1), kRecv).ok());
  EXPECT_TRUE(v.check_pose(pose(5, top), kRecv).ok());  // 3 back: a replay of the history
  // A jump of 2^31 is refused, and the numbering stays where it was.
  EXPECT_EQ(v.check_pose(pose(5, 0x80000001u), kRecv).reason, Reject::kSeqJump);
  EXPECT_TRUE(v.check_pose(pose(5, 2), kRecv).ok());
  // A restarted robot counts from 1 again (far below, small seq): accepted at once.
  for (std::uint32_t s = 3; s < 5000; ++s) ASSERT_TRUE(v.check_pose(pose(5, s), kRecv).ok());
  EXPECT_TRUE(v.check_pose(pose(5, 1), kRecv).ok());
  EXPECT_EQ(v.counters().seq_restarts, 1u);
  // A new numbering far away is accepted after resync_after samples in a row continue it.
  EXPECT_EQ(v.check_pose(pose(5, 900'000), kRecv).reason, Reject::kSeqJump);
  EXPECT_EQ(v.check_pose(pose(5, 900'001), kRecv).reason, Reject::kSeqJump);
  EXPECT_TRUE(v.check_pose(pose(5, 900'002), kRecv).ok());
  EXPECT_EQ(v.counters().seq_resyncs, 1u);
  EXPECT_TRUE(v.check_pose(pose(5, 900'003), kRecv).ok());
  // Scans have their own numbering.
  EXPECT_TRUE(v.check_scan(scan(5, 77), kRecv).ok());
}

TEST(SampleValidation, ClockOffsetIsReportedOnceAndClears) {
  ValidationOptions o;
  o.clock_window = std::chrono::seconds(1);
  SampleValidator v(o);
  std::vector<std::string> reports;
  auto collect = [&](std::uint32_t, const std::string& text) { reports.push_back(text); };
  // Robot 6's stamps are 12 s behind (inside the 30 s window: accepted, but reported).
  for (int i = 0; i < 30; ++i) {
    const Time at = Time::from_ns(kNow + i * 100'000'000LL);
    EXPECT_TRUE(v.check_pose(pose(6, static_cast<std::uint32_t>(i + 1), at.ns() - 12'000'000'000), at).ok());
  }
  v.clock_changes(collect);
  ASSERT_EQ(reports.size(), 1u);
  EXPECT_NE(reports[0].find("robot 6 clock off: stamps 12.000 s behind"), std::string::npos) << reports[0];
  v.clock_changes(collect);
  EXPECT_EQ(reports.size(), 1u);  // once per change
  EXPECT_NE(v.status_text().find("r6 -12.0 s"), std::string::npos) << v.status_text();
  // The clock is set right: back in step after a window.
  for (int i = 30; i < 60; ++i) {
    const Time at = Time::from_ns(kNow + i * 100'000'000LL);
    EXPECT_TRUE(v.check_pose(pose(6, static_cast<std::uint32_t>(i + 1), at.ns() - 5'000'000), at).ok());
  }
  v.clock_changes(collect);
  ASSERT_EQ(reports.size(), 2u);
  EXPECT_NE(reports[1].find("back in step"), std::string::npos);
  // A clock never set (1970): every sample refused and reported as unset.
  EXPECT_EQ(v.check_scan(scan(8, 1, 1'000'000'000), kRecv).reason, Reject::kClockUnset);
  v.clock_changes(collect);
  ASSERT_EQ(reports.size(), 3u);
  EXPECT_NE(reports[2].find("never set"), std::string::npos);
  EXPECT_NE(v.status_text().find("r8 unset"), std::string::npos);
}

TEST(SampleValidation, LogLineOncePerReasonPerInterval) {
  SampleValidator v;
  const Verdict bad{Reject::kRobotId, 33};
  const Time t0 = Time::from_ns(1'000'000'000);
  EXPECT_FALSE(v.log_line(bad, SampleTopic::kScan, 33, t0).empty());
  for (int i = 1; i < 50; ++i) EXPECT_TRUE(v.log_line(bad, SampleTopic::kScan, 33, t0 + std::chrono::milliseconds(i)).empty());
  // Another reason has its own budget.
  EXPECT_FALSE(v.log_line({Reject::kYaw, 1}, SampleTopic::kPose, 2, t0).empty());
  const std::string later = v.log_line(bad, SampleTopic::kScan, 33, t0 + std::chrono::seconds(11));
  EXPECT_NE(later.find("49 more refused"), std::string::npos) << later;
  EXPECT_TRUE(v.log_line(Verdict{}, SampleTopic::kScan, 1, t0).empty());
}

}  // namespace
}  // namespace teamscan::station

namespace teamscan::station {
namespace {

// A back-filled scan (teamscan/backfill): old stamps within max_backfill_age pass, its seq going back
// by a whole shadow is no seq jump and leaves the live numbering alone, its bad values are refused as
// a live scan's, and its stamp does not move the robot's clock offset.
TEST(SampleValidation, BackfilledScansHaveOldStampsAndSeqsFarBack) {
  SampleValidator v;
  for (std::uint32_t seq = 20'000; seq < 20'010; ++seq) ASSERT_TRUE(v.check_scan(scan(3, seq), kRecv).ok());
  const std::int64_t offset = v.clock(3).offset_ns;
  const std::int64_t ten_minutes_ago = kNow - 600'000'000'000;
  EXPECT_FALSE(v.check_scan(scan(3, 20'010, ten_minutes_ago), kRecv).ok());  // live: too old
  for (std::uint32_t seq = 10'000; seq < 10'010; ++seq)
    EXPECT_TRUE(v.check_backfill(scan(3, seq, ten_minutes_ago), kRecv).ok()) << seq;
  EXPECT_EQ(v.clock(3).offset_ns, offset);
  EXPECT_EQ(v.counters().seq_resyncs, 0u);
  EXPECT_TRUE(v.check_scan(scan(3, 20'011), kRecv).ok());  // the live numbering goes on
  // Older than max_backfill_age, or ahead of receipt: refused.
  EXPECT_EQ(v.check_backfill(scan(3, 9'000, kNow - 25LL * 3600 * 1'000'000'000), kRecv).reason, Reject::kStampBehind);
  EXPECT_EQ(v.check_backfill(scan(3, 9'001, kNow + 5'000'000'000), kRecv).reason, Reject::kStampAhead);
  teamscan_msg_ScanPoints& bad = scan(3, 9'002, ten_minutes_ago);
  bad.count = 402;
  EXPECT_EQ(v.check_backfill(bad, kRecv).reason, Reject::kBeamCount);
  EXPECT_EQ(v.counters().rejected_by_topic[static_cast<std::size_t>(SampleTopic::kBackfill)], 3u);
  EXPECT_STREQ(topic_name(SampleTopic::kBackfill), "backfill");
}

// A back-filled pose (teamscan/backfill_pose): the same rules as a back-filled scan, a pose's body checks.
TEST(SampleValidation, BackfilledPosesHaveOldStampsAndSeqsFarBack) {
  SampleValidator v;
  for (std::uint32_t seq = 5'000; seq < 5'010; ++seq) ASSERT_TRUE(v.check_pose(pose(3, seq), kRecv).ok());
  const std::int64_t offset = v.clock(3).offset_ns;
  const std::int64_t ten_minutes_ago = kNow - 600'000'000'000;
  EXPECT_FALSE(v.check_pose(pose(3, 5'010, ten_minutes_ago), kRecv).ok());  // live: too old
  for (std::uint32_t seq = 1'000; seq < 1'010; ++seq)
    EXPECT_TRUE(v.check_backfill_pose(pose(3, seq, ten_minutes_ago), kRecv).ok()) << seq;
  EXPECT_EQ(v.clock(3).offset_ns, offset);
  EXPECT_TRUE(v.check_pose(pose(3, 5'011), kRecv).ok());  // the live numbering goes on
  EXPECT_EQ(v.check_backfill_pose(pose(3, 900, kNow - 25LL * 3600 * 1'000'000'000), kRecv).reason, Reject::kStampBehind);
  teamscan_msg_RobotPose bad = pose(3, 901, ten_minutes_ago);
  bad.yaw_urad = 4'000'000;
  EXPECT_EQ(v.check_backfill_pose(bad, kRecv).reason, Reject::kYaw);
  bad = pose(3, 902, ten_minutes_ago);
  bad.vx_mmps = 20'000;
  EXPECT_EQ(v.check_backfill_pose(bad, kRecv).reason, Reject::kVelocity);
  EXPECT_EQ(v.counters().rejected_by_topic[static_cast<std::size_t>(SampleTopic::kBackfillPose)], 3u);
  EXPECT_STREQ(topic_name(SampleTopic::kBackfillPose), "backfill_pose");
}

}  // namespace
}  // namespace teamscan::station
