// The REP-105 frame tree of the team (ROS2_WIRE.md 6): `map` (the fused map's frame) -> robotN/odom (the
// station's correction of the robot's odometry, map_from_odom) -> robotN/base_link (the odometry), and
// robotN/base_link -> robotN/laser (the laser mount) where it is known. Plain transforms, pure: the rt/tf
// writer and the view's Foxglove channels publish the same tree, and check_frame_tree tests it.
#pragma once

#include <cstdint>
#include <span>
#include <string>
#include <string_view>
#include <vector>

namespace teamscan::dds::ros2 {

// robotN/odom: the robot's odometry frame (continuous, drifts); its parent is `map`.
[[nodiscard]] std::string odom_frame(std::uint32_t robot_id);
// robotN/laser: the laser's frame (x along the 0-degree beam, z up through the scan plane's normal).
[[nodiscard]] std::string laser_frame(std::uint32_t robot_id);

// A unit quaternion (x, y, z, w).
struct Quaternion {
  double x = 0.0, y = 0.0, z = 0.0, w = 1.0;
};

// parent_from_child at a time (CLOCK_REALTIME ns): a point in `child` maps to parent as R p + t.
struct FrameTransform {
  std::string parent;
  std::string child;
  std::int64_t stamp_ns = 0;
  double x_m = 0.0, y_m = 0.0, z_m = 0.0;
  Quaternion rotation;
};

// One robot's place in the tree: its tracked pose in `map` and the correction map_from_odom (identity:
// the robot's odometry is the map frame, no correction yet).
struct RobotFrames {
  std::uint32_t robot_id = 0;
  std::int64_t stamp_ns = 0;
  double x_m = 0.0, y_m = 0.0, yaw_rad = 0.0;  // map_from_base_link
  double map_from_odom_x_m = 0.0, map_from_odom_y_m = 0.0, map_from_odom_yaw_rad = 0.0;
};

// The planar odometry pose odom_from_base_link = inverse(map_from_odom) * map_from_base_link, so that the
// chain map -> odom -> base_link is the tracked pose exactly.
struct PlanarPose {
  double x_m = 0.0, y_m = 0.0, yaw_rad = 0.0;
};
[[nodiscard]] PlanarPose odom_from_base_link(const RobotFrames& r);

// Appends, per robot, map -> robotN/odom and robotN/odom -> robotN/base_link (z 0: base_link is on the
// floor under the robot's centre).
void append_dynamic_transforms(std::span<const RobotFrames> robots, std::vector<FrameTransform>& out);

// A laser mount: base_link_from_laser (position of the scan centre, roll/pitch/yaw, radians).
struct LaserMount {
  double x_m = 0.0, y_m = 0.0, z_m = 0.0;
  double roll_rad = 0.0, pitch_rad = 0.0, yaw_rad = 0.0;
};
// robotN/base_link -> robotN/laser (for /tf_static).
[[nodiscard]] FrameTransform laser_transform(std::uint32_t robot_id, const LaserMount& mount, std::int64_t stamp_ns);

[[nodiscard]] Quaternion yaw_rotation(double yaw_rad);
[[nodiscard]] Quaternion rpy_rotation(double roll_rad, double pitch_rad, double yaw_rad);

// The tree tf2 accepts (ROS2_WIRE.md 6): every frame id non-empty, without a leading '/', not its own
// parent; every child has exactly one parent; the rotation is a unit quaternion (|q|^2 within 0.01); and
// every frame reaches `root` by its parents (so no cycle, one root). Returns the first fault, naming the
// frames; empty: the transforms are such a tree.
[[nodiscard]] std::string frame_tree_fault(std::span<const FrameTransform> transforms, std::string_view root = "map");

}  // namespace teamscan::dds::ros2
