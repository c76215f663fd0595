// The ROS 2 side of the DDS layer (ROS2_WIRE.md; docs/ros2.md): topic and frame names, the QoS that
// RViz2 and tf2 readers match, and the three messages the ground station publishes -- the fused map as
// sensor_msgs/PointCloud2, poses as tf2_msgs/TFMessage, odometry as nav_msgs/Odometry -- filled from
// plain SI values into the C types idlc generates from idl/ros2_wire.idl. Ros2Writers owns the writers.
// Ground-station code: it allocates (strings, the cloud's bytes grow with the map), no ROS 2 dependency.
#pragma once

#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include <dds/dds.h>

#include "common/result.hpp"
#include "dds/ros2/frames.hpp"
#include "ros2_wire.h"

namespace teamscan::dds::ros2 {

// rmw naming: "rt" + the fully qualified ROS topic name (ROS2_WIRE.md 1).
inline constexpr char kTopicMapCloud[] = "rt/teamscan/map_cloud";
inline constexpr char kTopicTf[] = "rt/tf";
inline constexpr char kTopicTfStatic[] = "rt/tf_static";
// rt/robotN/odom
[[nodiscard]] std::string odometry_topic(std::uint32_t robot_id);
// rt/robotN/scan
[[nodiscard]] std::string scan_topic(std::uint32_t robot_id);

// Frames (REP-105, ROS2_WIRE.md 6): one shared fixed frame, robots under distinct prefixes.
inline constexpr char kFrameMap[] = "map";
// robotN/base_link: x forward, y left, z up, origin on the floor under the robot's centre (DESIGN.md).
[[nodiscard]] std::string base_link_frame(std::uint32_t robot_id);

// USER_DATA of every rt/ writer: parses as a key-value list in rmw (zero type hash), never an invented hash
// (ROS2_WIRE.md 7.3); empty USER_DATA makes Iron+ rmw log a parse error per endpoint.
inline constexpr char kWriterUserData[] = "teamscan=1;";

// Writer QoS (ROS2_WIRE.md 5), each XCDR1 only, with kWriterUserData; delete with dds_delete_qos.
// Map cloud: reliable, transient-local, keep-last 1 (a late RViz2 or a transient-local echo gets the
// current map; a reliable writer also serves best-effort readers, a transient-local one volatile ones).
[[nodiscard]] dds_qos_t* make_map_cloud_writer_qos();
// rt/tf: reliable, volatile, keep-last 100 (tf2_ros's listener QoS).
[[nodiscard]] dds_qos_t* make_tf_writer_qos();
// rt/tf_static: reliable, transient-local, keep-last 1, every static transform in one TFMessage (as
// tf2_ros's static broadcaster; its listener reads transient local).
[[nodiscard]] dds_qos_t* make_tf_static_writer_qos();
// Odometry: reliable, volatile, keep-last 10 (the ROS default profile).
[[nodiscard]] dds_qos_t* make_odometry_writer_qos();
// Scans: reliable, volatile, keep-last 5 (serves RViz2's reliable and the sensor-data best-effort readers;
// keep-last: a slow reader never makes the writer wait).
[[nodiscard]] dds_qos_t* make_scan_writer_qos();
// A reader as rmw_cyclonedds makes one: XCDR1 only; `reliable`/`transient_local`/`depth` per profile
// (RViz2: reliable, volatile, 5; tf2: reliable, volatile, 100; sensor data: best effort, volatile, 5).
[[nodiscard]] dds_qos_t* make_rmw_like_reader_qos(bool reliable, bool transient_local, std::int32_t depth);

// builtin_interfaces/Time from CLOCK_REALTIME ns (sec may be negative; nanosec in [0, 1e9)).
[[nodiscard]] builtin_interfaces_msg_dds__Time_ ros_time(std::int64_t stamp_ns);
// A rotation by `yaw_rad` about z (unit quaternion, w set: tf2 drops |q| != 1).
[[nodiscard]] geometry_msgs_msg_dds__Quaternion_ yaw_quaternion(double yaw_rad);

// One point of a cloud: for the map a voxel centre (map frame, metres) and the points that fell into it
// (field "hits"); for a scan a point (robotN/odom, metres) and its kPoint* flags (field "flags").
struct CloudPoint {
  float x_m = 0.0f;
  float y_m = 0.0f;
  float z_m = 0.0f;
  float hits = 0.0f;
};
static_assert(sizeof(CloudPoint) == 16);

// sensor_msgs/PointCloud2 of CloudPoints: height 1, fields x y z and `fourth` (FLOAT32 at 0 4 8 12),
// point_step 16, little-endian, dense. The message points into this object's buffers (valid until the
// next set()).
class PointCloudMessage {
 public:
  explicit PointCloudMessage(const char* fourth = "hits");
  PointCloudMessage(const PointCloudMessage&) = delete;
  PointCloudMessage& operator=(const PointCloudMessage&) = delete;
  void set(std::int64_t stamp_ns, const std::string& frame_id, std::span<const CloudPoint> points);
  [[nodiscard]] const sensor_msgs_msg_dds__PointCloud2_& msg() const { return msg_; }

 private:
  std::string frame_id_;
  std::string fourth_;
  std::vector<sensor_msgs_msg_dds__PointField_> fields_;
  std::vector<std::uint8_t> data_;
  sensor_msgs_msg_dds__PointCloud2_ msg_{};
};

// A robot on the floor at a time: map-frame position, heading, velocity and 2-D position covariance.
struct PlanarState {
  std::uint32_t robot_id = 0;
  std::int64_t stamp_ns = 0;     // CLOCK_REALTIME the state is valid at
  double x_m = 0.0;
  double y_m = 0.0;
  double yaw_rad = 0.0;
  double vx_mps = 0.0;           // map frame
  double vy_mps = 0.0;
  double yaw_rate_radps = 0.0;
  double cov_xx_m2 = 0.0;
  double cov_xy_m2 = 0.0;
  double cov_yy_m2 = 0.0;
  double yaw_var_rad2 = 0.0;
  // The station's correction of the robot's odometry, map_from_odom (identity: none yet).
  double map_from_odom_x_m = 0.0;
  double map_from_odom_y_m = 0.0;
  double map_from_odom_yaw_rad = 0.0;
};

// The state's place in the frame tree (frames.hpp).
[[nodiscard]] RobotFrames robot_frames(const PlanarState& state);

// tf2_msgs/TFMessage. From states: per state `map` -> robotN/odom (the correction) and robotN/odom ->
// robotN/base_link (REP-105, frames.hpp append_dynamic_transforms).
class TfMessage {
 public:
  TfMessage() = default;
  TfMessage(const TfMessage&) = delete;
  TfMessage& operator=(const TfMessage&) = delete;
  void set(std::span<const PlanarState> states);
  void set_transforms(std::span<const FrameTransform> transforms);
  [[nodiscard]] const tf2_msgs_msg_dds__TFMessage_& msg() const { return msg_; }

 private:
  std::vector<FrameTransform> frames_;
  std::vector<geometry_msgs_msg_dds__TransformStamped_> transforms_;
  tf2_msgs_msg_dds__TFMessage_ msg_{};
};

// nav_msgs/Odometry of one robot: header.frame_id robotN/odom (the pose's frame: odom_from_base_link,
// frames.hpp), child_frame_id robotN/base_link (the twist's frame: velocity rotated into the robot's axes,
// REP-105). Pose covariance 6x6 row-major (x y z roll pitch yaw): xx xy yy rotated into the odom frame
// and the yaw variance; z, roll, pitch 0 (the robot is on the floor). Twist covariance all 0: not estimated.
class OdometryMessage {
 public:
  OdometryMessage() = default;
  OdometryMessage(const OdometryMessage&) = delete;
  OdometryMessage& operator=(const OdometryMessage&) = delete;
  void set(const PlanarState& state);
  [[nodiscard]] const nav_msgs_msg_dds__Odometry_& msg() const { return msg_; }

 private:
  std::string frame_;
  std::string child_;
  nav_msgs_msg_dds__Odometry_ msg_{};
};

struct Ros2WriterCounters {
  std::uint64_t clouds = 0;
  std::uint64_t tf_messages = 0;
  std::uint64_t odometry = 0;
  std::uint64_t scans = 0;
  std::uint64_t write_errors = 0;
};

// The rt/ writers on one participant (created and deleted with it): the map cloud, rt/tf, and an
// rt/robotN/odom and an rt/robotN/scan writer per robot, each created on its first message.
class Ros2Writers {
 public:
  // `participant`: the caller's (this object does not delete it).
  [[nodiscard]] static Result<std::unique_ptr<Ros2Writers>> create(dds_entity_t participant);
  ~Ros2Writers();
  Ros2Writers(const Ros2Writers&) = delete;
  Ros2Writers& operator=(const Ros2Writers&) = delete;

  [[nodiscard]] Status write_cloud(const PointCloudMessage& cloud);
  [[nodiscard]] Status write_tf(const TfMessage& tf);
  [[nodiscard]] Status write_tf_static(const TfMessage& tf);
  [[nodiscard]] Status write_odometry(std::uint32_t robot_id, const OdometryMessage& odometry);
  [[nodiscard]] Status write_scan(std::uint32_t robot_id, const PointCloudMessage& scan);
  [[nodiscard]] const Ros2WriterCounters& counters() const { return counters_; }
  [[nodiscard]] dds_entity_t cloud_writer() const { return cloud_writer_; }
  [[nodiscard]] dds_entity_t tf_writer() const { return tf_writer_; }
  [[nodiscard]] dds_entity_t tf_static_writer() const { return tf_static_writer_; }
  [[nodiscard]] dds_entity_t odometry_writer(std::uint32_t robot_id) const;  // 0 before its first message

 private:
  explicit Ros2Writers(dds_entity_t participant) : participant_{participant} {}
  dds_entity_t participant_;
  dds_entity_t cloud_writer_ = 0;
  dds_entity_t tf_writer_ = 0;
  dds_entity_t tf_static_writer_ = 0;
  // The writer of a robot's topic in `writers` (index robot id), created on first use; 0 if it cannot be.
  dds_entity_t robot_writer(std::vector<dds_entity_t>& writers, std::uint32_t robot_id, const std::string& topic,
                            const dds_topic_descriptor_t* desc, dds_qos_t* (*make_qos)());
  std::vector<dds_entity_t> odometry_writers_;  // index robot id
  std::vector<dds_entity_t> scan_writers_;      // index robot id
  Ros2WriterCounters counters_;
};

}  // namespace teamscan::dds::ros2
