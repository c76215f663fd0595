// Ros2Publisher (groundstation/station/ros2_publisher.hpp): the heading it puts on a tracked position,
// and its copy of the map built from teamscan/map updates as a viewer merges them (changed voxels; a
// whole map replaces everything), published as the cloud of the kept voxels; lost robots and robots
// without a heading stay off rt/tf; each accepted scan's placed points on rt/robotN/scan in robotN/odom, or in robotN/base_link with its pose.
// One process, loopback DDS.
#include <gtest/gtest.h>

#include <dds/dds.h>

#include <cmath>
#include <cstring>
#include <numbers>
#include <set>
#include <tuple>
#include <vector>

#include "common/clock.hpp"
#include "dds/ros2/wire.hpp"
#include "groundstation/station/ros2_publisher.hpp"
#include "teamscan.h"
#include "tests/support/test_domain.hpp"

namespace teamscan::station {
namespace {

using Voxel = std::tuple<int, int, int>;

TEST(Ros2Heading, MovedOnWithTheYawRateForAtMostHalfASecond) {
  Heading h{true, Time::from_ns(1'000'000'000), 0.5, 0.2};
  EXPECT_DOUBLE_EQ(heading_at(h, Time::from_ns(1'000'000'000)), 0.5);
  EXPECT_NEAR(heading_at(h, Time::from_ns(1'250'000'000)), 0.55, 1e-12);
  EXPECT_NEAR(heading_at(h, Time::from_ns(9'000'000'000)), 0.6, 1e-12);  // capped at 0.5 s
  EXPECT_DOUBLE_EQ(heading_at(h, Time::from_ns(0)), 0.5);                 // never backwards
  Heading w{true, Time::from_ns(0), 3.1, 1.0};
  EXPECT_NEAR(heading_at(w, Time::from_ns(200'000'000)), 3.3 - 2.0 * std::numbers::pi, 1e-12);  // wrapped
}

class Ros2PublisherTest : public ::testing::Test {
 protected:
  void SetUp() override {
    participant_ = dds_create_participant(test::test_domain_id(), nullptr, nullptr);
    ASSERT_GT(participant_, 0);
    Ros2Config c;
    c.map_interval = std::chrono::milliseconds(20);
    c.pose_rate_hz = 1.0;  // one /tf per second: two ticks in a row publish once
    auto p = Ros2Publisher::create(c, participant_);
    ASSERT_TRUE(p.ok()) << p.error().what;
    publisher_ = std::move(p.value());
    cloud_ = reader(&sensor_msgs_msg_dds__PointCloud2__desc, dds::ros2::kTopicMapCloud, 1);
    tf_ = reader(&tf2_msgs_msg_dds__TFMessage__desc, dds::ros2::kTopicTf, 100);
  }
  void TearDown() override {
    publisher_.reset();
    (void)dds_delete(participant_);
  }
  dds_entity_t reader(const dds_topic_descriptor_t* desc, const char* topic, std::int32_t depth) {
    const dds_entity_t t = dds_create_topic(participant_, desc, topic, nullptr, nullptr);
    dds_qos_t* q = dds::ros2::make_rmw_like_reader_qos(true, false, depth);
    const dds_entity_t r = dds_create_reader(participant_, t, q, nullptr);
    dds_delete_qos(q);
    return r;
  }
  // Waits (up to 5 s) for the first valid sample on `r` and hands it to `check`; false if none came.
  template <class Message, class Check>
  bool take_first(dds_entity_t r, Check check) {
    for (int i = 0; i < 500; ++i) {
      void* samples[1] = {};
      dds_sample_info_t info;
      if (dds_take(r, samples, &info, 1, 1) != 1) {
        dds_sleepfor(DDS_MSECS(10));
        continue;
      }
      const bool valid = info.valid_data;
      if (valid) check(*static_cast<const Message*>(samples[0]));
      (void)dds_return_loan(r, samples, 1);
      if (valid) return true;
    }
    return false;
  }
  // Waits (up to 5 s) for a cloud with the expected voxels (mm); returns the last cloud seen.
  std::set<Voxel> cloud_until(const std::set<Voxel>& expected) {
    std::set<Voxel> last;
    for (int i = 0; i < 500 && last != expected; ++i) {
      void* samples[4] = {};
      dds_sample_info_t infos[4];
      const int n = dds_take(cloud_, samples, infos, 4, 4);
      for (int k = 0; k < n; ++k) {
        if (!infos[k].valid_data) continue;
        const auto* m = static_cast<const sensor_msgs_msg_dds__PointCloud2_*>(samples[k]);
        last.clear();
        for (std::uint32_t j = 0; j < m->width; ++j) {
          float p[4];
          std::memcpy(p, m->data._buffer + j * m->point_step, sizeof p);
          last.insert({static_cast<int>(std::lround(p[0] * 1000)), static_cast<int>(std::lround(p[1] * 1000)),
                        static_cast<int>(std::lround(p[2] * 1000))});
          EXPECT_GT(p[3], 0.0f);  // hits
        }
      }
      if (n > 0) (void)dds_return_loan(cloud_, samples, n);
      if (last != expected) dds_sleepfor(DDS_MSECS(10));
    }
    return last;
  }

  dds_entity_t participant_ = 0;
  std::unique_ptr<Ros2Publisher> publisher_;
  dds_entity_t cloud_ = 0, tf_ = 0;
};

teamscan_msg_MapVoxel voxel(int x, int y, int z, std::uint16_t hits, std::uint16_t flags) {
  return teamscan_msg_MapVoxel{x, y, z, hits, flags};
}

TEST_F(Ros2PublisherTest, CloudFollowsTheMapUpdatesAndKeepsOnlyKeptVoxels) {
  // A whole map (total == length): two kept voxels, one removed.
  const std::vector<teamscan_msg_MapVoxel> full = {voxel(50, 50, 50, 3, 0), voxel(150, 50, 50, 1, 1), voxel(50, 150, 250, 2, 0)};
  publisher_->offer_map(full, 3);
  EXPECT_EQ(cloud_until({{50, 50, 50}, {50, 150, 250}}), (std::set<Voxel>{{50, 50, 50}, {50, 150, 250}}));
  // A change: the removed voxel got kept points, a new voxel (total 4 > 2 entries: not a whole map).
  const std::vector<teamscan_msg_MapVoxel> change = {voxel(150, 50, 50, 4, 0), voxel(-50, -50, 50, 1, 0)};
  publisher_->offer_map(change, 4);
  const std::set<Voxel> all4 = {{50, 50, 50}, {150, 50, 50}, {50, 150, 250}, {-50, -50, 50}};
  EXPECT_EQ(cloud_until(all4), all4);
  // A whole map again replaces the copy (voxels no longer in the map go).
  const std::vector<teamscan_msg_MapVoxel> full2 = {voxel(-50, -50, 50, 2, 0)};
  publisher_->offer_map(full2, 1);
  EXPECT_EQ(cloud_until({{-50, -50, 50}}), (std::set<Voxel>{{-50, -50, 50}}));
  const Ros2Counters c = publisher_->counters();
  EXPECT_EQ(c.map_updates, 3u);
  EXPECT_EQ(c.map_voxels, 1u);
  EXPECT_GE(c.clouds, 3u);
  EXPECT_EQ(c.write_errors, 0u);
}

// The stop's flush (Ros2Publisher::flush): with a cloud interval of an hour, a map offered after the first
// cloud does not go out by itself; flush() sends it at once, whatever the interval, and returns once the
// reader acknowledged it. Nothing to send is flushed at once too.
TEST(Ros2PublisherFlush, TheLastMapGoesOutAtOnceWhateverTheInterval) {
  const dds_entity_t participant = dds_create_participant(test::test_domain_id(), nullptr, nullptr);
  ASSERT_GT(participant, 0);
  Ros2Config c;
  c.map_interval = std::chrono::hours(1);
  auto created = Ros2Publisher::create(c, participant);
  ASSERT_TRUE(created.ok()) << created.error().what;
  Ros2Publisher& publisher = *created.value();
  EXPECT_TRUE(publisher.flush(std::chrono::seconds(2))) << "no map yet: nothing to acknowledge";
  const dds_entity_t t = dds_create_topic(participant, &sensor_msgs_msg_dds__PointCloud2__desc, dds::ros2::kTopicMapCloud, nullptr, nullptr);
  dds_qos_t* q = dds::ros2::make_rmw_like_reader_qos(true, false, 1);
  const dds_entity_t reader = dds_create_reader(participant, t, q, nullptr);
  dds_delete_qos(q);
  auto clouds = [&](std::uint32_t& width) {
    int got = 0;
    void* samples[4] = {};
    dds_sample_info_t infos[4];
    const int n = dds_take(reader, samples, infos, 4, 4);
    for (int k = 0; k < n; ++k)
      if (infos[k].valid_data) {
        width = static_cast<const sensor_msgs_msg_dds__PointCloud2_*>(samples[k])->width;
        ++got;
      }
    if (n > 0) (void)dds_return_loan(reader, samples, n);
    return got;
  };
  std::uint32_t width = 0;
  // The first map goes out at once (the first cloud is due at the start), the next waits an hour.
  const std::vector<teamscan_msg_MapVoxel> first = {voxel(50, 50, 50, 1, 0)};
  publisher.offer_map(first, 1);
  int got = 0;
  for (int i = 0; i < 500 && got == 0; ++i, dds_sleepfor(DDS_MSECS(10))) got = clouds(width);
  ASSERT_EQ(got, 1);
  EXPECT_EQ(width, 1u);
  const std::vector<teamscan_msg_MapVoxel> last = {voxel(50, 50, 50, 1, 0), voxel(150, 50, 50, 2, 0), voxel(250, 50, 50, 1, 0)};
  publisher.offer_map(last, 3);
  dds_sleepfor(DDS_MSECS(300));
  EXPECT_EQ(clouds(width), 0) << "within the interval: no cloud";
  EXPECT_TRUE(publisher.flush(std::chrono::seconds(2)));
  EXPECT_EQ(clouds(width), 1) << "flush() returns once the reader has it";
  EXPECT_EQ(width, 3u);
  EXPECT_EQ(publisher.counters().clouds, 2u);
  created.value().reset();
  (void)dds_delete(participant);
}

TEST_F(Ros2PublisherTest, TfCarriesLiveRobotsWithAHeading) {
  // The team source knows robots 1, 2 and 3; the publisher has seen poses of 2 and 3 only (its pose
  // hook), and 3 is lost.
  LastPoseTeamSource team;
  PoseObservation p;
  p.stamp = now_realtime();
  for (std::uint32_t id : {1u, 2u, 3u}) {
    p.robot_id = id;
    p.x_m = 1.0 + id;
    p.yaw_rad = id == 2 ? 1.0 : -1.0;
    team.add_pose(p);
    if (id != 1) publisher_->add_pose(p);
  }
  team.set_lost(3, true);
  publisher_->tick(now_monotonic(), team);
  publisher_->tick(now_monotonic(), team);  // not due yet
  bool got = false;
  for (int i = 0; i < 500 && !got; ++i) {
    void* samples[1] = {};
    dds_sample_info_t info;
    if (dds_take(tf_, samples, &info, 1, 1) == 1) {
      if (info.valid_data) {
        const auto* m = static_cast<const tf2_msgs_msg_dds__TFMessage_*>(samples[0]);
        // REP-105: map -> robot2/odom (no correction from this team source: the identity) -> robot2/base_link.
        ASSERT_EQ(m->transforms._length, 2u);
        EXPECT_STREQ(m->transforms._buffer[0].header.frame_id, "map");
        EXPECT_STREQ(m->transforms._buffer[0].child_frame_id, "robot2/odom");
        EXPECT_EQ(m->transforms._buffer[0].transform.translation.x, 0.0);
        EXPECT_EQ(m->transforms._buffer[0].transform.rotation.w, 1.0);
        EXPECT_STREQ(m->transforms._buffer[1].header.frame_id, "robot2/odom");
        EXPECT_STREQ(m->transforms._buffer[1].child_frame_id, "robot2/base_link");
        EXPECT_NEAR(m->transforms._buffer[1].transform.translation.x, 3.0, 1e-9);
        EXPECT_NEAR(2.0 * std::atan2(m->transforms._buffer[1].transform.rotation.z, m->transforms._buffer[1].transform.rotation.w), 1.0, 1e-9);
        got = true;
      }
      (void)dds_return_loan(tf_, samples, 1);
    } else {
      dds_sleepfor(DDS_MSECS(10));
    }
  }
  EXPECT_TRUE(got);
  dds_sleepfor(DDS_MSECS(100));
  void* samples[1] = {};
  dds_sample_info_t info;
  const int n = dds_take(tf_, samples, &info, 1, 1);
  if (n > 0) (void)dds_return_loan(tf_, samples, n);
  EXPECT_EQ(n, 0) << "the second tick within 1 / pose_rate_hz published again";
}

TEST_F(Ros2PublisherTest, AScansPlacedPointsGoOnItsScanTopicInTheOdomFrame) {
  const dds_entity_t scans = reader(&sensor_msgs_msg_dds__PointCloud2__desc, dds::ros2::scan_topic(4).c_str(), 10);
  dds_sleepfor(DDS_MSECS(100));  // matched before the write (volatile)
  ScanPoints s;
  s.robot_id = 4;
  s.stamp = Time::from_ns(1'700'000'000'250'000'000);
  s.count = 3;
  s.points[0] = ScanPoint{1000, 2000, 300, 0, 0};
  s.points[1] = ScanPoint{0, 0, 0, 1, kPointNoPose};  // unplaced: left out
  s.points[2] = ScanPoint{-1500, 250, 800, 2, kPointDirectionFiltered};
  publisher_->add_scan(s, Receipt{});
  Receipt refused;
  refused.rejected = 3;
  publisher_->add_scan(s, refused);  // refused scans are not published
  const bool got = take_first<sensor_msgs_msg_dds__PointCloud2_>(scans, [](const sensor_msgs_msg_dds__PointCloud2_& cloud) {
    const auto* m = &cloud;
    EXPECT_STREQ(m->header.frame_id, "robot4/odom");
    EXPECT_EQ(m->header.stamp.sec, 1'700'000'000);
    EXPECT_EQ(m->header.stamp.nanosec, 250'000'000u);
    ASSERT_EQ(m->width, 2u);
    ASSERT_EQ(m->fields._length, 4u);
    EXPECT_STREQ(m->fields._buffer[3].name, "flags");
    float v[8];
    ASSERT_EQ(m->data._length, sizeof v);
    std::memcpy(v, m->data._buffer, sizeof v);
    EXPECT_FLOAT_EQ(v[0], 1.0f);
    EXPECT_FLOAT_EQ(v[1], 2.0f);
    EXPECT_FLOAT_EQ(v[2], 0.3f);
    EXPECT_FLOAT_EQ(v[3], 0.0f);
    EXPECT_FLOAT_EQ(v[4], -1.5f);
    EXPECT_FLOAT_EQ(v[7], static_cast<float>(kPointDirectionFiltered));
  });
  EXPECT_TRUE(got);
  dds_sleepfor(DDS_MSECS(100));
  EXPECT_EQ(publisher_->counters().scans, 1u);
  EXPECT_EQ(publisher_->counters().scans_dropped, 0u);
}

TEST(Ros2PublisherStatic, LaserMountsOnTfStaticForALateTransientLocalReader) {
  const dds_entity_t participant = dds_create_participant(test::test_domain_id(), nullptr, nullptr);
  ASSERT_GT(participant, 0);
  Ros2Config c;
  c.laser_mounts = {{1, {0.125, 0.0, 0.462, 0.0, -0.35, 0.0}}, {2, {0.1, 0.0, 0.5, 0.0, 0.0, 0.0}}};
  {
    auto p = Ros2Publisher::create(c, participant);
    ASSERT_TRUE(p.ok()) << p.error().what;
    // tf2's /tf_static listener: reliable, transient local, created after the write.
    const dds_entity_t t = dds_create_topic(participant, &tf2_msgs_msg_dds__TFMessage__desc, dds::ros2::kTopicTfStatic,
                                            nullptr, nullptr);
    dds_qos_t* q = dds::ros2::make_rmw_like_reader_qos(true, true, 100);
    const dds_entity_t r = dds_create_reader(participant, t, q, nullptr);
    dds_delete_qos(q);
    bool got = false;
    for (int i = 0; i < 500 && !got; ++i) {
      void* samples[1] = {};
      dds_sample_info_t info;
      if (dds_take(r, samples, &info, 1, 1) == 1) {
        if (info.valid_data) {
          const auto* m = static_cast<const tf2_msgs_msg_dds__TFMessage_*>(samples[0]);
          ASSERT_EQ(m->transforms._length, 2u);
          EXPECT_STREQ(m->transforms._buffer[0].header.frame_id, "robot1/base_link");
          EXPECT_STREQ(m->transforms._buffer[0].child_frame_id, "robot1/laser");
          EXPECT_DOUBLE_EQ(m->transforms._buffer[0].transform.translation.z, 0.462);
          EXPECT_NEAR(m->transforms._buffer[0].transform.rotation.y, std::sin(-0.35 / 2), 1e-12);
          EXPECT_STREQ(m->transforms._buffer[1].child_frame_id, "robot2/laser");
          got = true;
        }
        (void)dds_return_loan(r, samples, 1);
      } else {
        dds_sleepfor(DDS_MSECS(10));
      }
    }
    EXPECT_TRUE(got);
  }
  (void)dds_delete(participant);
}

}  // namespace
TEST_F(Ros2PublisherTest, AScanWithTheRobotsPoseAtItsStampGoesOutInBaseLink) {
  const dds_entity_t scans = reader(&sensor_msgs_msg_dds__PointCloud2__desc, dds::ros2::scan_topic(5).c_str(), 10);
  dds_sleepfor(DDS_MSECS(100));  // matched before the write (volatile)
  ScanPoints s;
  s.robot_id = 5;
  s.stamp = Time::from_ns(1'700'000'001'000'000'000);
  s.count = 2;
  // The robot at (2, 1) heading +90 deg in its odometry frame: odom (2, 3) is 2 m ahead of it, odom (3, 1)
  // is 1 m to its right; z is kept.
  s.points[0] = ScanPoint{2000, 3000, 400, 0, 0};
  s.points[1] = ScanPoint{3000, 1000, 100, 1, 0};
  const Pose2 odom_from_base{2.0, 1.0, std::numbers::pi / 2};
  publisher_->add_scan(s, Receipt{}, &odom_from_base);
  const bool got = take_first<sensor_msgs_msg_dds__PointCloud2_>(scans, [](const sensor_msgs_msg_dds__PointCloud2_& cloud) {
    const auto* m = &cloud;
    EXPECT_STREQ(m->header.frame_id, "robot5/base_link");
    EXPECT_EQ(m->header.stamp.sec, 1'700'000'001);
    ASSERT_EQ(m->width, 2u);
    float v[8];
    ASSERT_EQ(m->data._length, sizeof v);
    std::memcpy(v, m->data._buffer, sizeof v);
    EXPECT_NEAR(v[0], 2.0f, 1e-5);  // ahead
    EXPECT_NEAR(v[1], 0.0f, 1e-5);
    EXPECT_NEAR(v[2], 0.4f, 1e-6);
    EXPECT_NEAR(v[4], 0.0f, 1e-5);
    EXPECT_NEAR(v[5], -1.0f, 1e-5);  // to the right
    EXPECT_NEAR(v[6], 0.1f, 1e-6);
  });
  EXPECT_TRUE(got);
}

}  // namespace teamscan::station
