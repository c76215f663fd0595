// Every IDL type through loopback DDS (CYCLONEDDS_URI from ctest): the bridge's writers and reader
// against independent test subscribers/writers, plus the transient-local late-joiner behaviour.
#include <gtest/gtest.h>

#include <map>
#include <set>
#include <vector>

#include "onboard/bridge/bridge.hpp"
#include "dds/qos.hpp"
#include "teamscan.h"
#include "tests/support/dds_test_subscriber.hpp"
#include "tests/support/test_domain.hpp"

namespace teamscan::onboard {
namespace {

using namespace teamscan::dds;

using test::DdsTestSubscriber;
constexpr auto kWait = std::chrono::seconds(10);

DdsBridge make_bridge(std::uint32_t robot, std::uint32_t depth = 300) {
  DdsBridgeOptions o;
  o.robot_id = robot;
  o.scan_history_depth = depth;
  o.domain_id = test::test_domain_id();
  auto b = DdsBridge::create(o);
  if (!b) ADD_FAILURE() << b.error().what << " " << b.error().detail;
  return std::move(b.value());
}

TEST(DdsRoundTrip, PoseArrivesWithEveryField) {
  dds_qos_t* q = make_state_reader_qos();
  DdsTestSubscriber<teamscan_msg_RobotPose> sub(&teamscan_msg_RobotPose_desc, kTopicPose, q, 64, test::test_domain_id());
  dds_delete_qos(q);
  ASSERT_TRUE(sub.ok());
  DdsBridge b = make_bridge(5);
  ASSERT_TRUE(sub.wait_matched(1, kWait));
  OnboardPose p{5, 41, 1'700'000'000'000'000'001, -12345, 67890, 1570796, -250, 300, -15};
  ASSERT_TRUE(b.publish_pose(p).ok());
  std::vector<teamscan_msg_RobotPose> got;
  ASSERT_TRUE(sub.take_until(got, 1, kWait));
  EXPECT_EQ(got[0].robot_id, 5u);
  EXPECT_EQ(got[0].seq, 41u);
  EXPECT_EQ(got[0].stamp_ns, 1'700'000'000'000'000'001);
  EXPECT_EQ(got[0].x_mm, -12345);
  EXPECT_EQ(got[0].y_mm, 67890);
  EXPECT_EQ(got[0].yaw_urad, 1570796);
  EXPECT_EQ(got[0].vx_mmps, -250);
  EXPECT_EQ(got[0].vy_mmps, 300);
  EXPECT_EQ(got[0].yaw_rate_mradps, -15);
  EXPECT_EQ(b.counters().poses_written, 1u);
}

TEST(DdsRoundTrip, FullScanArrivesPointForPoint) {
  dds_qos_t* q = make_scan_reader_qos();
  DdsTestSubscriber<teamscan_msg_ScanPoints> sub(&teamscan_msg_ScanPoints_desc, kTopicScan, q, 8, test::test_domain_id());
  dds_delete_qos(q);
  ASSERT_TRUE(sub.ok());
  DdsBridge b = make_bridge(6);
  ASSERT_TRUE(sub.wait_matched(1, kWait));
  static ScanPoints s;
  s.robot_id = 6;
  s.seq = 9;
  s.stamp = Time::from_ns(123);
  s.origin_x_mm = 1;
  s.origin_y_mm = 2;
  s.origin_z_mm = 3;
  s.applied = OdomCorrection{-321, 654, -1'234'567, 42};  // the odometry correction the robot applied
  s.count = kMaxBeams;
  for (std::uint16_t i = 0; i < kMaxBeams; ++i) {
    s.points[i] = ScanPoint{i * 7 - 1000, -i * 3, i % 5 == 0 ? -400 : 400, i,
                               static_cast<std::uint16_t>(i % 16)};
  }
  ASSERT_TRUE(b.publish_scan(s).ok());
  std::vector<teamscan_msg_ScanPoints> got;
  ASSERT_TRUE(sub.take_until(got, 1, kWait));
  const teamscan_msg_ScanPoints& r = got[0];
  EXPECT_EQ(r.robot_id, 6u);
  EXPECT_EQ(r.seq, 9u);
  EXPECT_EQ(r.stamp_ns, 123);
  EXPECT_EQ(r.origin_x_mm, 1);
  EXPECT_EQ(r.origin_y_mm, 2);
  EXPECT_EQ(r.origin_z_mm, 3);
  EXPECT_EQ(r.corr_x_mm, -321);
  EXPECT_EQ(r.corr_y_mm, 654);
  EXPECT_EQ(r.corr_yaw_urad, -1'234'567);
  EXPECT_EQ(r.corr_seq, 42u);
  ASSERT_EQ(r.count, kMaxBeams);
  for (std::uint16_t i = 0; i < kMaxBeams; ++i) {
    ASSERT_EQ(r.points[i].x_mm, i * 7 - 1000) << i;
    ASSERT_EQ(r.points[i].y_mm, -i * 3) << i;
    ASSERT_EQ(r.points[i].z_mm, i % 5 == 0 ? -400 : 400) << i;
    ASSERT_EQ(r.points[i].beam, i) << i;
    ASSERT_EQ(r.points[i].flags, i % 16) << i;
  }
}

TEST(DdsRoundTrip, StatusArrives) {
  dds_qos_t* q = make_state_reader_qos();
  DdsTestSubscriber<teamscan_msg_RobotStatus> sub(&teamscan_msg_RobotStatus_desc, kTopicStatus, q, 64, test::test_domain_id());
  dds_delete_qos(q);
  DdsBridge b = make_bridge(7);
  ASSERT_TRUE(sub.wait_matched(1, kWait));
  OnboardStatus s;
  s.robot_id = 7;
  s.seq = 3;
  s.lms_state = 4;
  s.scan_rate_mhz = 75000;
  s.lms_bad_telegrams = 17;
  ASSERT_TRUE(b.publish_status(s).ok());
  std::vector<teamscan_msg_RobotStatus> got;
  ASSERT_TRUE(sub.take_until(got, 1, kWait));
  EXPECT_EQ(got[0].robot_id, 7u);
  EXPECT_EQ(got[0].lms_state, 4);
  EXPECT_EQ(got[0].scan_rate_mhz, 75000u);
  EXPECT_EQ(got[0].lms_bad_telegrams, 17u);
}

TEST(DdsRoundTrip, SampleOfAnotherRobotIsRefusedAndCounted) {
  DdsBridge b = make_bridge(8);
  OnboardPose p;
  p.robot_id = 9;
  EXPECT_FALSE(b.publish_pose(p).ok());
  EXPECT_EQ(b.counters().write_errors, 1u);
  EXPECT_EQ(b.counters().poses_written, 0u);
}

// A ground-station-side team writer, created before the robot: transient-local hands the robot the
// last team state as soon as it joins.
TEST(DdsRoundTrip, TeamStateReachesLateJoiningRobot) {
  const dds_entity_t pp = dds_create_participant(test::test_domain_id(), nullptr, nullptr);
  ASSERT_GT(pp, 0);
  const dds_entity_t tp = dds_create_topic(pp, &teamscan_msg_TeamState_desc, kTopicTeam, nullptr, nullptr);
  dds_qos_t* q = make_team_writer_qos(std::chrono::seconds(2));
  const dds_entity_t wr = dds_create_writer(pp, tp, q, nullptr);
  dds_delete_qos(q);
  ASSERT_GT(wr, 0);
  static teamscan_msg_TeamState ts;
  ts.seq = 1;
  ts.count = 3;
  for (std::uint32_t i = 0; i < 3; ++i) {
    ts.members[i].robot_id = i + 1;
    ts.members[i].x_mm = static_cast<std::int32_t>(1000 * i);
    ts.members[i].lost = i == 2 ? 1 : 0;
  }
  // Robot 1's odometry correction, as the station's registration estimated it.
  ts.members[0].corr_x_mm = 120;
  ts.members[0].corr_y_mm = -45;
  ts.members[0].corr_yaw_urad = 17'453;
  ts.members[0].corr_sigma_mm = 25;
  ts.members[0].corr_sigma_yaw_urad = 3'000;
  ts.members[0].corr_seq = 6;
  ASSERT_EQ(dds_write(wr, &ts), DDS_RETCODE_OK);

  DdsBridge b = make_bridge(1);
  TeamSnapshot snap;
  bool got = false;
  for (int i = 0; i < 500 && !got; ++i) {
    got = b.take_team(snap);
    if (!got) dds_sleepfor(DDS_MSECS(10));
  }
  ASSERT_TRUE(got);
  ASSERT_EQ(snap.count, 3u);
  EXPECT_EQ(snap.members[1].robot_id, 2u);
  EXPECT_EQ(snap.members[1].x_mm, 1000);
  EXPECT_TRUE(snap.members[2].lost);
  EXPECT_EQ(snap.members[0].correction.x_mm, 120);
  EXPECT_EQ(snap.members[0].correction.y_mm, -45);
  EXPECT_EQ(snap.members[0].correction.yaw_urad, 17'453);
  EXPECT_EQ(snap.members[0].correction.seq, 6u);
  EXPECT_EQ(snap.members[0].correction_sigma_mm, 25u);
  EXPECT_EQ(snap.members[0].correction_sigma_yaw_urad, 3'000u);
  EXPECT_TRUE(snap.members[1].correction.none());
  EXPECT_FALSE(b.take_team(snap));  // nothing new
  dds_delete(pp);
}

TEST(DdsRoundTrip, MapUpdateWithVoxels) {
  dds_qos_t* q = make_map_qos();
  DdsTestSubscriber<teamscan_msg_MapUpdate> sub(&teamscan_msg_MapUpdate_desc, kTopicMap, q, 1, test::test_domain_id());
  const dds_entity_t pp = dds_create_participant(test::test_domain_id(), nullptr, nullptr);
  const dds_entity_t tp = dds_create_topic(pp, &teamscan_msg_MapUpdate_desc, kTopicMap, nullptr, nullptr);
  const dds_entity_t wr = dds_create_writer(pp, tp, q, nullptr);
  dds_delete_qos(q);
  ASSERT_TRUE(sub.wait_matched(1, kWait));
  std::vector<teamscan_msg_MapVoxel> voxels(1000);
  for (std::size_t i = 0; i < voxels.size(); ++i) {
    voxels[i] = teamscan_msg_MapVoxel{static_cast<std::int32_t>(i * 50), 25, -25, static_cast<std::uint16_t>(i), 1};
  }
  teamscan_msg_MapUpdate m{};
  m.seq = 2;
  m.resolution_mm = 50;
  m.total_voxels = 1000;
  m.voxels._buffer = voxels.data();
  m.voxels._length = 1000;
  m.voxels._maximum = 1000;
  m.voxels._release = false;
  ASSERT_EQ(dds_write(wr, &m), DDS_RETCODE_OK);
  // The subscriber's samples were value-initialised (null buffers): Cyclone allocates them on take.
  std::vector<teamscan_msg_MapUpdate> got;
  ASSERT_TRUE(sub.take_until(got, 1, kWait));
  ASSERT_EQ(got[0].voxels._length, 1000u);
  EXPECT_EQ(got[0].resolution_mm, 50u);
  EXPECT_EQ(got[0].voxels._buffer[999].x_mm, 999 * 50);
  EXPECT_EQ(got[0].voxels._buffer[999].hits, 999);
  // The copy in `got` owns the buffer Cyclone allocated (the subscriber never frees sample contents).
  dds_sample_free(&got[0], &teamscan_msg_MapUpdate_desc, DDS_FREE_CONTENTS);
  dds_delete(pp);
}

// Transient-local scan history in one process: scans written before the reader exists all arrive, in
// order, as long as they fit the history depth (the multi-process restart test is in tests/hil/station).
TEST(DdsRoundTrip, LateScanReaderGetsTheWholeHistory) {
  DdsBridge b = make_bridge(2, 100);
  static ScanPoints s;
  s.robot_id = 2;
  s.count = 1;
  for (std::uint32_t seq = 1; seq <= 150; ++seq) {
    s.seq = seq;
    ASSERT_TRUE(b.publish_scan(s).ok());
  }
  dds_qos_t* q = make_scan_reader_qos();
  DdsTestSubscriber<teamscan_msg_ScanPoints> sub(&teamscan_msg_ScanPoints_desc, kTopicScan, q, 64, test::test_domain_id());
  dds_delete_qos(q);
  std::vector<teamscan_msg_ScanPoints> got;
  ASSERT_TRUE(sub.take_until(got, 100, kWait));
  // Depth 100: the newest 100 (51..150), nothing older, nothing twice.
  ASSERT_EQ(got.size(), 100u);
  for (std::size_t i = 0; i < got.size(); ++i) EXPECT_EQ(got[i].seq, 51u + i);
}

// Store and forward: back-filled scans go out on dds::kBackfillLanes writers of teamscan/backfill, a scan's
// lane fixed by its seq, so that each lane repairs its own losses (dds/qos.hpp).
TEST(DdsRoundTrip, BackfillGoesOutOnItsLanesEveryScanOnce) {
  dds_qos_t* q = make_scan_reader_qos();
  DdsTestSubscriber<teamscan_msg_ScanPoints> sub(&teamscan_msg_ScanPoints_desc, kTopicBackfill, q, 64, test::test_domain_id());
  dds_delete_qos(q);
  ASSERT_TRUE(sub.ok());
  DdsBridgeOptions o;
  o.robot_id = 3;
  o.domain_id = test::test_domain_id();
  o.store_and_forward = true;
  Result<DdsBridge> b = DdsBridge::create(o);
  ASSERT_TRUE(b.ok()) << b.error().what;
  ASSERT_TRUE(sub.wait_matched(kBackfillLanes, kWait));
  static ScanPoints s;
  s.robot_id = 3;
  s.count = 1;
  constexpr std::uint32_t kScans = 3 * kBackfillLanes;
  for (std::uint32_t seq = 101; seq < 101 + kScans; ++seq) {
    s.seq = seq;
    ASSERT_TRUE(b.value().publish_backfill(s).ok());
  }
  std::vector<teamscan_msg_ScanPoints> got;
  ASSERT_TRUE(sub.take_until(got, kScans, kWait));
  ASSERT_EQ(got.size(), kScans);
  EXPECT_EQ(b.value().counters().backfills_written, kScans);
  std::map<std::uint32_t, dds_instance_handle_t> writer_of;
  for (std::size_t i = 0; i < got.size(); ++i) {
    EXPECT_EQ(got[i].robot_id, 3u);
    EXPECT_TRUE(writer_of.emplace(got[i].seq, sub.publications()[i]).second) << "seq " << got[i].seq << " twice";
  }
  std::set<dds_instance_handle_t> lanes;
  for (const auto& [seq, writer] : writer_of) {
    lanes.insert(writer);
    if (seq >= 101 + kBackfillLanes) {
      EXPECT_EQ(writer, writer_of.at(seq - kBackfillLanes)) << seq;
    }
    if (seq > 101) {
      EXPECT_NE(writer, writer_of.at(seq - 1)) << seq;
    }
  }
  EXPECT_EQ(lanes.size(), kBackfillLanes);
}

}  // namespace
}  // namespace teamscan::onboard
