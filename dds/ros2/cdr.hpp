// ROS 2 messages as bytes outside DDS: a sample of an idl/ros2_wire.idl type serialised by Cyclone's own
// XCDR1 serialiser (the bytes a writer puts on rt/ topics, ROS2_WIRE.md 4), with the 4-byte encapsulation
// header, and the types' ROS 2 message definitions (`ros2msg`: the .msg text, then each nested type after
// a line of 80 '=' and `MSG: pkg/Name`, as rosbag2 and Foxglove read them). For the view's Foxglove
// channels (message encoding `cdr`, schema encoding `ros2msg`) and recorded files.
#pragma once

#include <string>
#include <string_view>

#include <dds/dds.h>

namespace teamscan::dds::ros2 {

// The serialised sample, from the encapsulation header (00 01 00 pp: CDR_LE, pp pad bytes at the end, as
// Cyclone writes it) on. `desc` must be the sample's type (e.g. sensor_msgs_msg_dds__PointCloud2__desc).
[[nodiscard]] std::string cdr_bytes(const dds_topic_descriptor_t& desc, const void* sample);

// ROS 2 type names as the ROS tools show them.
inline constexpr char kPointCloud2Type[] = "sensor_msgs/msg/PointCloud2";
inline constexpr char kTfMessageType[] = "tf2_msgs/msg/TFMessage";
inline constexpr char kOdometryType[] = "nav_msgs/msg/Odometry";
inline constexpr char kPoseStampedType[] = "geometry_msgs/msg/PoseStamped";

// The `ros2msg` definition of one of the types above, with its dependencies; empty for another name.
[[nodiscard]] std::string_view ros2msg_definition(std::string_view type_name);

}  // namespace teamscan::dds::ros2
