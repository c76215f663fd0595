// ROS 2 message definitions (.msg text, the MCAP `ros2msg` schema encoding) of the messages a session
// export writes, each self-contained: the root definition, then every type it uses after a line of 80
// '=' and `MSG: pkg/Name` (the layout rosbag2's MCAP storage and Foxglove read). Fields and order as in
// ros2/common_interfaces, the same layouts as idl/ros2_wire.idl (ROS2_WIRE.md 3).
#pragma once

#include <string>
#include <vector>

namespace teamscan::mcap_export {

inline constexpr char kSchemaEncoding[] = "ros2msg";
inline constexpr char kMessageEncoding[] = "cdr";

// sensor_msgs/msg/PointCloud2, tf2_msgs/msg/TFMessage, nav_msgs/msg/Odometry.
[[nodiscard]] std::string point_cloud2_definition();
[[nodiscard]] std::string tf_message_definition();
[[nodiscard]] std::string odometry_definition();
// teamscan_msgs/msg/RobotStatus: a std_msgs/Header, then one int64 per column of status.csv (named as
// the file's header row names them), so the message follows whatever columns the session has.
[[nodiscard]] std::string robot_status_definition(const std::vector<std::string>& columns);

}  // namespace teamscan::mcap_export
