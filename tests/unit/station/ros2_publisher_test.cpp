// Ros2Publisher (groundstation/station/ros2_publisher.hpp): the heading it puts on a tracked position,
// and its copy of the map built from teamscan/map updates as a viewer merges them (changed voxels; a
// whole map replaces everything), published as the cloud of the kept voxels; lost robots and robots
// without a heading stay off rt/tf. One process, loopback DDS.
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
        ASSERT_EQ(m->transforms._length, 1u);
        EXPECT_STREQ(m->transforms._buffer[0].child_frame_id, "robot2/base_link");
        EXPECT_NEAR(m->transforms._buffer[0].transform.translation.x, 3.0, 1e-9);
        EXPECT_NEAR(2.0 * std::atan2(m->transforms._buffer[0].transform.rotation.z, m->transforms._buffer[0].transform.rotation.w), 1.0, 1e-9);
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

}  // namespace
}  // namespace teamscan::station
