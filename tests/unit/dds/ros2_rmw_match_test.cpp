// Readers set up as rmw_cyclonedds sets them up -- the ROS type name, XCDR1 as the only data
// representation, no XTypes type information, keyless -- with the QoS of RViz2, tf2, the ROS default
// and the sensor-data profile (ROS2_WIRE.md 5), on another participant, match our rt/ writers
// (publication matched on both sides) and decode what they write. Discovery shows our writers as a ROS
// graph sees them (topic, type name, XCDR1, USER_DATA teamscan=1;, no type information). Negative
// control: an XCDR2-only reader does not match (the check can fail).
#include <gtest/gtest.h>

#include <dds/dds.h>

#include <cmath>
#include <cstring>
#include <map>
#include <string>
#include <vector>

#include "dds/ros2/wire.hpp"
#include "tests/support/test_domain.hpp"

namespace teamscan::dds::ros2 {
namespace {

constexpr std::int64_t kStampNs = 1'700'000'000'500'000'000;

struct Profile {
  const char* name;
  bool reliable;
  bool transient_local;
  std::int32_t depth;
};
// RViz2 displays, tf2_ros /tf listener, rclcpp default, sensor data (ROS2_WIRE.md 5).
constexpr Profile kRviz{"rviz2", true, false, 5};
constexpr Profile kTf2{"tf2", true, false, 100};
constexpr Profile kDefault{"default", true, false, 10};
constexpr Profile kSensor{"sensor_data", false, false, 5};
constexpr Profile kLatched{"transient_local", true, true, 1};

class RmwLikeReaders : public ::testing::Test {
 protected:
  void SetUp() override {
    writer_participant_ = dds_create_participant(test::test_domain_id(), nullptr, nullptr);
    reader_participant_ = dds_create_participant(test::test_domain_id(), nullptr, nullptr);
    ASSERT_GT(writer_participant_, 0);
    ASSERT_GT(reader_participant_, 0);
    auto w = Ros2Writers::create(writer_participant_);
    ASSERT_TRUE(w.ok());
    writers_ = std::move(w.value());
  }
  void TearDown() override {
    writers_.reset();
    (void)dds_delete(reader_participant_);
    (void)dds_delete(writer_participant_);
  }

  dds_entity_t reader(const dds_topic_descriptor_t* desc, const std::string& topic, const Profile& p) {
    const dds_entity_t t = dds_create_topic(reader_participant_, desc, topic.c_str(), nullptr, nullptr);
    dds_qos_t* q = make_rmw_like_reader_qos(p.reliable, p.transient_local, p.depth);
    const dds_entity_t r = dds_create_reader(reader_participant_, t, q, nullptr);
    dds_delete_qos(q);
    return r;
  }

  // Waits (up to 5 s) until `writer` has `n` matched readers.
  static std::uint32_t wait_matched(dds_entity_t writer, std::uint32_t n) {
    dds_publication_matched_status_t st{};
    for (int i = 0; i < 500; ++i) {
      (void)dds_get_publication_matched_status(writer, &st);
      if (st.current_count >= n) break;
      dds_sleepfor(DDS_MSECS(10));
    }
    return st.current_count;
  }
  static std::uint32_t reader_matched(dds_entity_t reader) {
    dds_subscription_matched_status_t st{};
    (void)dds_get_subscription_matched_status(reader, &st);
    return st.current_count;
  }

  // Takes one sample (waits up to 5 s); the loan is returned by the caller through `release`.
  template <class T, class F>
  static bool take_one(dds_entity_t reader, F&& check) {
    for (int i = 0; i < 500; ++i) {
      void* samples[1] = {nullptr};
      dds_sample_info_t info;
      if (dds_take(reader, samples, &info, 1, 1) == 1) {
        const bool valid = info.valid_data;
        if (valid) check(*static_cast<const T*>(samples[0]));
        (void)dds_return_loan(reader, samples, 1);
        if (valid) return true;
      }
      dds_sleepfor(DDS_MSECS(10));
    }
    return false;
  }

  dds_entity_t writer_participant_ = 0;
  dds_entity_t reader_participant_ = 0;
  std::unique_ptr<Ros2Writers> writers_;
};

TEST_F(RmwLikeReaders, MapCloudMatchesEveryRosProfileAndDecodes) {
  std::vector<dds_entity_t> readers;
  for (const Profile& p : {kRviz, kTf2, kDefault, kSensor, kLatched})
    readers.push_back(reader(&sensor_msgs_msg_dds__PointCloud2__desc, kTopicMapCloud, p));
  EXPECT_EQ(wait_matched(writers_->cloud_writer(), 5), 5u);
  for (dds_entity_t r : readers) EXPECT_EQ(reader_matched(r), 1u);
  PointCloudMessage cloud;
  std::vector<CloudPoint> points;
  for (int i = 0; i < 1000; ++i) points.push_back({0.1f * static_cast<float>(i), -0.05f * static_cast<float>(i), 1.5f, 3.0f});
  cloud.set(kStampNs, kFrameMap, points);
  ASSERT_TRUE(writers_->write_cloud(cloud).ok());
  for (dds_entity_t r : readers) {
    EXPECT_TRUE(take_one<sensor_msgs_msg_dds__PointCloud2_>(r, [&](const sensor_msgs_msg_dds__PointCloud2_& m) {
      EXPECT_STREQ(m.header.frame_id, "map");
      EXPECT_EQ(m.header.stamp.sec, 1'700'000'000);
      EXPECT_EQ(m.height, 1u);
      EXPECT_EQ(m.width, 1000u);
      ASSERT_EQ(m.fields._length, 4u);
      EXPECT_STREQ(m.fields._buffer[0].name, "x");
      EXPECT_STREQ(m.fields._buffer[2].name, "z");
      EXPECT_EQ(m.fields._buffer[2].offset, 8u);
      EXPECT_EQ(m.fields._buffer[2].datatype, sensor_msgs_msg_dds__PointField_Constants_FLOAT32);
      // RViz2 drops a cloud whose data size is not width * height * point_step.
      ASSERT_EQ(m.data._length, m.width * m.height * m.point_step);
      float p[4];
      std::memcpy(p, m.data._buffer + 16 * 999, sizeof p);
      EXPECT_FLOAT_EQ(p[0], points[999].x_m);
      EXPECT_FLOAT_EQ(p[1], points[999].y_m);
      EXPECT_FLOAT_EQ(p[3], 3.0f);
    }));
  }
  // A transient-local reader that joins late (RViz2 set to transient local, `ros2 topic echo`) gets it.
  const dds_entity_t late = reader(&sensor_msgs_msg_dds__PointCloud2__desc, kTopicMapCloud, kLatched);
  EXPECT_TRUE(take_one<sensor_msgs_msg_dds__PointCloud2_>(
      late, [](const sensor_msgs_msg_dds__PointCloud2_& m) { EXPECT_EQ(m.width, 1000u); }));
}

TEST_F(RmwLikeReaders, TfAndOdometryMatchTheirRosProfilesAndDecode) {
  PlanarState s;
  s.robot_id = 5;
  s.stamp_ns = kStampNs;
  s.x_m = 2.0;
  s.y_m = 1.0;
  s.yaw_rad = 0.5;
  s.vx_mps = 0.3 * std::cos(0.5);
  s.vy_mps = 0.3 * std::sin(0.5);
  s.yaw_rate_radps = 0.1;
  s.cov_xx_m2 = 0.01;
  s.cov_yy_m2 = 0.02;
  OdometryMessage odom;
  odom.set(s);
  ASSERT_TRUE(writers_->write_odometry(5, odom).ok());  // creates rt/robot5/odom's writer

  std::vector<dds_entity_t> tf_readers, odom_readers;
  for (const Profile& p : {kTf2, kRviz, kDefault, kSensor}) {
    tf_readers.push_back(reader(&tf2_msgs_msg_dds__TFMessage__desc, kTopicTf, p));
    odom_readers.push_back(reader(&nav_msgs_msg_dds__Odometry__desc, odometry_topic(5), p));
  }
  EXPECT_EQ(wait_matched(writers_->tf_writer(), 4), 4u);
  EXPECT_EQ(wait_matched(writers_->odometry_writer(5), 4), 4u);
  // tf2's /tf_static profile (transient local) asks more durability than rt/tf offers: no match, as
  // with ROS's own /tf broadcasters.
  const dds_entity_t tl = reader(&tf2_msgs_msg_dds__TFMessage__desc, kTopicTf, kLatched);
  dds_sleepfor(DDS_MSECS(200));
  EXPECT_EQ(reader_matched(tl), 0u);

  TfMessage tf;
  tf.set(std::span<const PlanarState>(&s, 1));
  ASSERT_TRUE(writers_->write_tf(tf).ok());
  ASSERT_TRUE(writers_->write_odometry(5, odom).ok());
  for (dds_entity_t r : tf_readers) {
    EXPECT_TRUE(take_one<tf2_msgs_msg_dds__TFMessage_>(r, [](const tf2_msgs_msg_dds__TFMessage_& m) {
      ASSERT_EQ(m.transforms._length, 2u);  // REP-105: map -> robot5/odom (no correction) -> robot5/base_link
      EXPECT_STREQ(m.transforms._buffer[0].header.frame_id, "map");
      EXPECT_STREQ(m.transforms._buffer[0].child_frame_id, "robot5/odom");
      const auto& t = m.transforms._buffer[1];
      EXPECT_STREQ(t.header.frame_id, "robot5/odom");
      EXPECT_STREQ(t.child_frame_id, "robot5/base_link");
      EXPECT_DOUBLE_EQ(t.transform.translation.x, 2.0);
      EXPECT_NEAR(2.0 * std::atan2(t.transform.rotation.z, t.transform.rotation.w), 0.5, 1e-12);
    }));
  }
  for (dds_entity_t r : odom_readers) {
    EXPECT_TRUE(take_one<nav_msgs_msg_dds__Odometry_>(r, [](const nav_msgs_msg_dds__Odometry_& m) {
      EXPECT_STREQ(m.header.frame_id, "robot5/odom");
      EXPECT_STREQ(m.child_frame_id, "robot5/base_link");
      EXPECT_DOUBLE_EQ(m.pose.pose.position.y, 1.0);
      EXPECT_NEAR(m.twist.twist.linear.x, 0.3, 1e-12);  // forward in the robot's frame
      EXPECT_NEAR(m.twist.twist.linear.y, 0.0, 1e-12);
      EXPECT_DOUBLE_EQ(m.twist.twist.angular.z, 0.1);
      EXPECT_DOUBLE_EQ(m.pose.covariance[7], 0.02);
    }));
  }
}

TEST_F(RmwLikeReaders, Xcdr2OnlyReaderDoesNotMatch) {
  const dds_entity_t t = dds_create_topic(reader_participant_, &tf2_msgs_msg_dds__TFMessage__desc, kTopicTf, nullptr, nullptr);
  dds_qos_t* q = make_rmw_like_reader_qos(true, false, 10);
  const dds_data_representation_id_t xcdr2 = DDS_DATA_REPRESENTATION_XCDR2;
  dds_qset_data_representation(q, 1, &xcdr2);
  const dds_entity_t r = dds_create_reader(reader_participant_, t, q, nullptr);
  dds_delete_qos(q);
  const dds_entity_t control = reader(&tf2_msgs_msg_dds__TFMessage__desc, kTopicTf, kTf2);
  EXPECT_EQ(wait_matched(writers_->tf_writer(), 1), 1u);
  dds_sleepfor(DDS_MSECS(200));
  EXPECT_EQ(reader_matched(control), 1u);
  EXPECT_EQ(reader_matched(r), 0u);
  dds_requested_incompatible_qos_status_t st{};
  ASSERT_EQ(dds_get_requested_incompatible_qos_status(r, &st), DDS_RETCODE_OK);
  EXPECT_GE(st.total_count, 1u);
  EXPECT_EQ(st.last_policy_id, static_cast<dds_qos_policy_id_t>(DDS_DATA_REPRESENTATION_QOS_POLICY_ID));
}

// What a ROS graph sees of our writers in discovery (DCPSPublication on the reading participant).
TEST_F(RmwLikeReaders, DiscoveryShowsRosNamesXcdr1AndUserData) {
  PlanarState s;
  s.robot_id = 2;
  OdometryMessage odom;
  odom.set(s);
  ASSERT_TRUE(writers_->write_odometry(2, odom).ok());
  const dds_entity_t pubs = dds_create_reader(reader_participant_, DDS_BUILTIN_TOPIC_DCPSPUBLICATION, nullptr, nullptr);
  std::map<std::string, std::string> types;
  for (int i = 0; i < 500 && types.size() < 3; ++i) {
    void* samples[16] = {nullptr};
    dds_sample_info_t infos[16];
    const int n = dds_take(pubs, samples, infos, 16, 16);
    for (int k = 0; k < n; ++k) {
      if (!infos[k].valid_data) continue;
      auto* e = static_cast<dds_builtintopic_endpoint_t*>(samples[k]);
      const std::string topic = e->topic_name;
      if (topic.rfind("rt/", 0) != 0) continue;
      types[topic] = e->type_name;
      std::uint32_t nrep = 0;
      dds_data_representation_id_t* reps = nullptr;
      ASSERT_TRUE(dds_qget_data_representation(e->qos, &nrep, &reps)) << topic;
      ASSERT_EQ(nrep, 1u) << topic;
      EXPECT_EQ(reps[0], DDS_DATA_REPRESENTATION_XCDR1) << topic;
      dds_free(reps);
      void* ud = nullptr;
      std::size_t ud_size = 0;
      ASSERT_TRUE(dds_qget_userdata(e->qos, &ud, &ud_size)) << topic;
      EXPECT_EQ(std::string(static_cast<const char*>(ud), ud_size), kWriterUserData) << topic;
      dds_free(ud);
      const dds_typeinfo_t* info = nullptr;
      (void)dds_builtintopic_get_endpoint_type_info(e, &info);
      EXPECT_EQ(info, nullptr) << topic << " carries type information";
    }
    if (n > 0) (void)dds_return_loan(pubs, samples, n);
    if (types.size() < 3) dds_sleepfor(DDS_MSECS(10));
  }
  EXPECT_EQ(types["rt/teamscan/map_cloud"], "sensor_msgs::msg::dds_::PointCloud2_");
  EXPECT_EQ(types["rt/tf"], "tf2_msgs::msg::dds_::TFMessage_");
  EXPECT_EQ(types["rt/robot2/odom"], "nav_msgs::msg::dds_::Odometry_");
}

}  // namespace
}  // namespace teamscan::dds::ros2
