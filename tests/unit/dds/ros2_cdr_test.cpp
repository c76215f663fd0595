// The ROS 2 messages' bytes on the wire: each message our writers put on an rt/ topic,
// captured by a reader in serialized form (dds_takecdr, as ROS2_WIRE.md 4 was verified), equals an
// independently hand-encoded sample: the two vectors of ROS2_WIRE.md 4 (checked there against a Cyclone
// writer in another process, for raw messages through our writers) and, for our message builders, the
// bytes ros2_cdr_vectors.py encodes from the XCDR1 rules (not from the code under test).
#include <gtest/gtest.h>

#include <dds/dds.h>
#include <dds/ddsi/ddsi_serdata.h>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <string>
#include <vector>

#include "dds/ros2/cdr.hpp"
#include "dds/ros2/wire.hpp"
#include "tests/support/test_domain.hpp"

namespace teamscan::dds::ros2 {
namespace {

std::string to_hex(const std::vector<std::uint8_t>& b) {
  static const char* const kDigits = "0123456789abcdef";
  std::string s;
  for (std::uint8_t v : b) {
    s += kDigits[v >> 4];
    s += kDigits[v & 15];
  }
  return s;
}

// A participant with our writers and, per topic, a reader that takes samples in serialized form.
class Capture {
 public:
  Capture() {
    participant_ = dds_create_participant(test::test_domain_id(), nullptr, nullptr);
    auto w = Ros2Writers::create(participant_);
    EXPECT_TRUE(w.ok());
    if (w.ok()) writers = std::move(w.value());
  }
  ~Capture() {
    writers.reset();
    (void)dds_delete(participant_);
  }
  Capture(const Capture&) = delete;
  Capture& operator=(const Capture&) = delete;

  dds_entity_t reader(const dds_topic_descriptor_t* desc, const std::string& topic) {
    const dds_entity_t t = dds_create_topic(participant_, desc, topic.c_str(), nullptr, nullptr);
    // Volatile: serves every writer (a transient-local reader does not match a volatile writer); the
    // reader exists before the write.
    dds_qos_t* q = make_rmw_like_reader_qos(true, false, 10);
    const dds_entity_t r = dds_create_reader(participant_, t, q, nullptr);
    dds_delete_qos(q);
    return r;
  }

  // The next sample's bytes from the 4-byte encapsulation header on (waits up to 5 s).
  static std::vector<std::uint8_t> take(dds_entity_t reader) {
    for (int i = 0; i < 500; ++i) {
      struct ddsi_serdata* sd = nullptr;
      dds_sample_info_t info;
      if (dds_takecdr(reader, &sd, 1, &info, DDS_ANY_STATE) == 1) {
        std::vector<std::uint8_t> bytes(ddsi_serdata_size(sd));
        ddsi_serdata_to_ser(sd, 0, bytes.size(), bytes.data());
        ddsi_serdata_unref(sd);
        return bytes;
      }
      dds_sleepfor(DDS_MSECS(10));
    }
    return {};
  }

  std::unique_ptr<Ros2Writers> writers;

 private:
  dds_entity_t participant_ = 0;
};

constexpr std::int64_t kStampNs = 1'700'000'000'500'000'000;  // 1700000000 s + 500000000 ns

// The PointCloud2 vector of ROS2_WIRE.md 4 as printed there (offsets 00..87): frame `map`, 1x2 points
// (1,2,3), (-1.5,0.25,10), x/y/z FLOAT32, stamp 1700000000.5 s.
constexpr char kReferencePointCloud2Hex[] =
      "00010003" "00f15365" "0065cd1d" "04000000" "6d617000" "01000000" "02000000" "03000000"
      "02000000" "78000000" "00000000" "07000000" "01000000" "02000000" "79000000" "04000000"
      "07000000" "01000000" "02000000" "7a000000" "08000000" "07000000" "01000000" "00000000"
      "0c000000" "18000000" "18000000" "0000803f" "00000040" "00004040" "0000c0bf" "0000803e"
      "00002041" "01000000";

// The sample of that vector, field by field.
struct ReferenceCloud {
  sensor_msgs_msg_dds__PointField_ fields[3] = {
      {const_cast<char*>("x"), 0, sensor_msgs_msg_dds__PointField_Constants_FLOAT32, 1},
      {const_cast<char*>("y"), 4, sensor_msgs_msg_dds__PointField_Constants_FLOAT32, 1},
      {const_cast<char*>("z"), 8, sensor_msgs_msg_dds__PointField_Constants_FLOAT32, 1}};
  std::uint8_t data[24] = {};
  sensor_msgs_msg_dds__PointCloud2_ msg{};
  ReferenceCloud() {
    const float xyz[6] = {1.0f, 2.0f, 3.0f, -1.5f, 0.25f, 10.0f};
    std::memcpy(data, xyz, sizeof data);
    msg.header.stamp = ros_time(kStampNs);
    msg.header.frame_id = const_cast<char*>("map");
    msg.height = 1;
    msg.width = 2;
    msg.fields = {3, 3, fields, false};
    msg.is_bigendian = false;
    msg.point_step = 12;
    msg.row_step = 24;
    msg.data = {24, 24, data, false};
    msg.is_dense = true;
  }
};

TEST(Ros2Cdr, ReferencePointCloud2ThroughOurCloudWriter) {
  Capture cap;
  const dds_entity_t r = cap.reader(&sensor_msgs_msg_dds__PointCloud2__desc, kTopicMapCloud);
  const ReferenceCloud ref;
  ASSERT_EQ(dds_write(cap.writers->cloud_writer(), &ref.msg), DDS_RETCODE_OK);
  EXPECT_EQ(to_hex(Capture::take(r)), kReferencePointCloud2Hex);
}

// Outside DDS (the view's Foxglove channels): cdr_bytes is the same serialisation, header included.
TEST(Ros2Cdr, CdrBytesOfTheReferencePointCloud2) {
  const ReferenceCloud ref;
  const std::string b = cdr_bytes(sensor_msgs_msg_dds__PointCloud2__desc, &ref.msg);
  EXPECT_EQ(to_hex(std::vector<std::uint8_t>(b.begin(), b.end())), kReferencePointCloud2Hex);
}

TEST(Ros2Cdr, ReferenceTfMessageThroughOurTfWriter) {
  const std::string expected =
      "00010000" "01000000" "00f15365" "0065cd1d" "04000000" "6d617000" "11000000" "726f626f"
      "74312f62" "6173655f" "6c696e6b" "00000000" "00000000" "00000000" "0000f83f" "00000000"
      "000000c0" "00000000" "00000000" "00000000" "00000000" "00000000" "00000000" "cd3b7f66"
      "9ea0e63f" "cd3b7f66" "9ea0e63f";
  Capture cap;
  const dds_entity_t r = cap.reader(&tf2_msgs_msg_dds__TFMessage__desc, kTopicTf);
  geometry_msgs_msg_dds__TransformStamped_ t{};
  t.header.stamp = ros_time(kStampNs);
  t.header.frame_id = const_cast<char*>("map");
  t.child_frame_id = const_cast<char*>("robot1/base_link");
  t.transform.translation = {1.5, -2.0, 0.0};
  t.transform.rotation = {0.0, 0.0, std::sqrt(0.5), std::sqrt(0.5)};
  tf2_msgs_msg_dds__TFMessage_ m{};
  m.transforms = {1, 1, &t, false};
  ASSERT_EQ(dds_write(cap.writers->tf_writer(), &m), DDS_RETCODE_OK);
  const std::vector<std::uint8_t> got = Capture::take(r);
  EXPECT_EQ(got.size(), 108u);
  EXPECT_EQ(to_hex(got), expected);
}

TEST(Ros2Cdr, MapCloudMessageEqualsHandEncoding) {
  // ros2_cdr_vectors.py "map cloud": 168 bytes; fields x y z hits FLOAT32 at 0 4 8 12, point_step 16.
  const std::string expected =
      "0001000300f153650065cd1d040000006d617000010000000200000004000000"
      "0200000078000000000000000700000001000000020000007900000004000000"
      "0700000001000000020000007a00000008000000070000000100000005000000"
      "68697473000000000c0000000700000001000000000000001000000020000000"
      "200000000000803f0000004000004040000080400000c0bf0000803e00002041"
      "0000803f01000000";
  Capture cap;
  const dds_entity_t r = cap.reader(&sensor_msgs_msg_dds__PointCloud2__desc, kTopicMapCloud);
  PointCloudMessage cloud;
  const CloudPoint points[2] = {{1.0f, 2.0f, 3.0f, 4.0f}, {-1.5f, 0.25f, 10.0f, 1.0f}};
  cloud.set(kStampNs, kFrameMap, points);
  ASSERT_TRUE(cap.writers->write_cloud(cloud).ok());
  EXPECT_EQ(to_hex(Capture::take(r)), expected);
  EXPECT_EQ(cap.writers->counters().clouds, 1u);
}

TEST(Ros2Cdr, EmptyMapCloudIsAValidCloud) {
  Capture cap;
  const dds_entity_t r = cap.reader(&sensor_msgs_msg_dds__PointCloud2__desc, kTopicMapCloud);
  PointCloudMessage cloud;
  cloud.set(kStampNs, kFrameMap, {});
  ASSERT_TRUE(cap.writers->write_cloud(cloud).ok());
  const std::vector<std::uint8_t> b = Capture::take(r);
  // header 0..4, stamp 4..12, "map" 12..20, height 20..24, width 24..28, 4 fields 28..116 (x y z: 20
  // bytes each, hits: 24), is_bigendian 116 + 3 pad, point_step 120, row_step 124, data length 128,
  // is_dense 132 + 3 pad (the pad count in the header's option byte).
  ASSERT_EQ(b.size(), 136u);
  EXPECT_EQ(to_hex({b.begin(), b.begin() + 4}), "00010003");
  EXPECT_EQ(to_hex({b.begin() + 20, b.begin() + 32}), "010000000000000004000000");  // height 1, width 0, 4 fields
  EXPECT_EQ(to_hex({b.begin() + 116, b.end()}), "00000000" "10000000" "00000000" "00000000" "01000000");
}

TEST(Ros2Cdr, TfMessageEqualsHandEncoding) {
  // ros2_cdr_vectors.py "tf" (REP-105): robot 1 at (1.5,-2) yaw 0 without a correction, robot 7 at
  // (-3.25,0.5) yaw pi with the correction (0.5,-1,0.25): map -> robotN/odom -> robotN/base_link each.
  const std::string expected =
      "000100000400000000f153650065cd1d040000006d6170000c000000726f626f"
      "74312f6f646f6d00000000000000000000000000000000000000000000000000"
      "0000000000000000000000000000000000000000000000000000000000000000"
      "0000f03f00f153650065cd1d0c000000726f626f74312f6f646f6d0011000000"
      "726f626f74312f626173655f6c696e6b00000000000000000000f83f00000000"
      "000000c000000000000000000000000000000000000000000000000000000000"
      "00000000000000000000f03f00f153650065cd1d040000006d6170000c000000"
      "726f626f74372f6f646f6d00000000000000e03f000000000000f0bf00000000"
      "000000000000000000000000000000000000000036ee86eeaeeabf3fd35b7d52"
      "15c0ef3f00f153650065cd1d0c000000726f626f74372f6f646f6d0011000000"
      "726f626f74372f626173655f6c696e6b00000000b4458ff138190ac08432b8b5"
      "8f0c0340000000000000000000000000000000000000000000000000d35b7d52"
      "15c0ef3f3aee86eeaeeabf3f";
  Capture cap;
  const dds_entity_t r = cap.reader(&tf2_msgs_msg_dds__TFMessage__desc, kTopicTf);
  PlanarState a, b;
  a.robot_id = 1;
  a.stamp_ns = kStampNs;
  a.x_m = 1.5;
  a.y_m = -2.0;
  b.robot_id = 7;
  b.stamp_ns = kStampNs;
  b.x_m = -3.25;
  b.y_m = 0.5;
  b.yaw_rad = M_PI;
  b.vx_mps = 9.0;  // velocities and covariances are not part of a transform
  b.cov_xx_m2 = 1.0;
  b.map_from_odom_x_m = 0.5;
  b.map_from_odom_y_m = -1.0;
  b.map_from_odom_yaw_rad = 0.25;
  const PlanarState states[2] = {a, b};
  TfMessage tf;
  tf.set(states);
  ASSERT_TRUE(cap.writers->write_tf(tf).ok());
  EXPECT_EQ(to_hex(Capture::take(r)), expected);
}

TEST(Ros2Cdr, OdometryMessageEqualsHandEncoding) {
  // ros2_cdr_vectors.py "odometry": 732 bytes (the 724 of ROS2_WIRE.md's Odometry with the longer frame id
  // robot3/odom); the pose and its covariance in robot3/odom under the correction (0.2,0.1,0.3).
  const std::string expected =
      "0001000000f153650065cd1d0c000000726f626f74332f6f646f6d0011000000"
      "726f626f74332f626173655f6c696e6b00000000c1f812a5e16cea3f647451d4"
      "9d45ecbf00000000000000000000000000000000000000000000000037e95e3e"
      "03a4ef3f21eddfe9c920c33f70719a3191288c3f98a872caf4b9843f00000000"
      "0000000000000000000000000000000000000000000000000000000098a872ca"
      "f4b9843f3dfd324d758fa23f0000000000000000000000000000000000000000"
      "0000000000000000000000000000000000000000000000000000000000000000"
      "0000000000000000000000000000000000000000000000000000000000000000"
      "0000000000000000000000000000000000000000000000000000000000000000"
      "0000000000000000000000000000000000000000000000000000000000000000"
      "0000000000000000000000000000000000000000000000000000000000000000"
      "0000000000000000000000000000000000000000000000000000000000000000"
      "000000007b14ae47e17a643f00000000000000c0020000000000e0bf00000000"
      "0000000000000000000000000000000000000000000000000000d03f00000000"
      "0000000000000000000000000000000000000000000000000000000000000000"
      "0000000000000000000000000000000000000000000000000000000000000000"
      "0000000000000000000000000000000000000000000000000000000000000000"
      "0000000000000000000000000000000000000000000000000000000000000000"
      "0000000000000000000000000000000000000000000000000000000000000000"
      "0000000000000000000000000000000000000000000000000000000000000000"
      "0000000000000000000000000000000000000000000000000000000000000000"
      "0000000000000000000000000000000000000000000000000000000000000000"
      "00000000000000000000000000000000000000000000000000000000";
  Capture cap;
  const dds_entity_t r = cap.reader(&nav_msgs_msg_dds__Odometry__desc, odometry_topic(3));
  PlanarState s;
  s.robot_id = 3;
  s.stamp_ns = kStampNs;
  s.x_m = 1.25;
  s.y_m = -0.5;
  s.yaw_rad = M_PI;
  s.vx_mps = 2.0;
  s.vy_mps = 0.5;
  s.yaw_rate_radps = 0.25;
  s.cov_xx_m2 = 0.01;
  s.cov_xy_m2 = 0.002;
  s.cov_yy_m2 = 0.04;
  s.yaw_var_rad2 = 0.0025;
  s.map_from_odom_x_m = 0.2;
  s.map_from_odom_y_m = 0.1;
  s.map_from_odom_yaw_rad = 0.3;
  OdometryMessage odom;
  odom.set(s);
  ASSERT_TRUE(cap.writers->write_odometry(3, odom).ok());
  const std::vector<std::uint8_t> got = Capture::take(r);
  EXPECT_EQ(got.size(), 732u);
  EXPECT_EQ(to_hex(got), expected);
  EXPECT_GT(cap.writers->odometry_writer(3), 0);
  EXPECT_EQ(cap.writers->odometry_writer(4), 0);
}

TEST(Ros2Names, TopicsFramesAndTimes) {
  EXPECT_STREQ(kTopicMapCloud, "rt/teamscan/map_cloud");
  EXPECT_STREQ(kTopicTf, "rt/tf");
  EXPECT_EQ(odometry_topic(12), "rt/robot12/odom");
  EXPECT_EQ(base_link_frame(32), "robot32/base_link");
  EXPECT_EQ(odom_frame(5), "robot5/odom");
  EXPECT_EQ(laser_frame(5), "robot5/laser");
  const auto t = ros_time(-1);  // just before the epoch: -1 s + 999999999 ns
  EXPECT_EQ(t.sec, -1);
  EXPECT_EQ(t.nanosec, 999'999'999u);
  const auto u = ros_time(kStampNs);
  EXPECT_EQ(u.sec, 1'700'000'000);
  EXPECT_EQ(u.nanosec, 500'000'000u);
  const auto q = yaw_quaternion(0.3);
  EXPECT_NEAR(q.x * q.x + q.y * q.y + q.z * q.z + q.w * q.w, 1.0, 1e-12);
  EXPECT_NEAR(2.0 * std::atan2(q.z, q.w), 0.3, 1e-12);
}

// Type names are the rmw_cyclonedds mangling, and the descriptors carry no XTypes type information
// (idlc -t), so a ROS peer (which sends none) is matched on the name alone (ROS2_WIRE.md 2).
TEST(Ros2Types, RosTypeNamesWithoutTypeInformation) {
  EXPECT_STREQ(sensor_msgs_msg_dds__PointCloud2__desc.m_typename, "sensor_msgs::msg::dds_::PointCloud2_");
  EXPECT_STREQ(tf2_msgs_msg_dds__TFMessage__desc.m_typename, "tf2_msgs::msg::dds_::TFMessage_");
  EXPECT_STREQ(nav_msgs_msg_dds__Odometry__desc.m_typename, "nav_msgs::msg::dds_::Odometry_");
  for (const dds_topic_descriptor_t* d :
       {&sensor_msgs_msg_dds__PointCloud2__desc, &tf2_msgs_msg_dds__TFMessage__desc, &nav_msgs_msg_dds__Odometry__desc}) {
    EXPECT_EQ(d->m_nkeys, 0u) << d->m_typename;
    EXPECT_EQ(d->type_information.sz, 0u) << d->m_typename;
    EXPECT_EQ(d->type_mapping.sz, 0u) << d->m_typename;
    EXPECT_EQ(d->m_flagset & DDS_TOPIC_XTYPES_METADATA, 0u) << d->m_typename;
  }
}

}  // namespace
}  // namespace teamscan::dds::ros2
