// The REP-105 frame tree: transforms from tracked poses and corrections, and its check (frames.hpp).
#include "dds/ros2/frames.hpp"

#include <cmath>
#include <map>
#include <numbers>

#include "dds/ros2/wire.hpp"

namespace teamscan::dds::ros2 {

std::string odom_frame(std::uint32_t robot_id) { return "robot" + std::to_string(robot_id) + "/odom"; }
std::string laser_frame(std::uint32_t robot_id) { return "robot" + std::to_string(robot_id) + "/laser"; }

Quaternion yaw_rotation(double yaw_rad) { return {0.0, 0.0, std::sin(yaw_rad / 2.0), std::cos(yaw_rad / 2.0)}; }

Quaternion rpy_rotation(double roll_rad, double pitch_rad, double yaw_rad) {
  // R = Rz(yaw) Ry(pitch) Rx(roll), as tf2's setRPY.
  const double cr = std::cos(roll_rad / 2), sr = std::sin(roll_rad / 2);
  const double cp = std::cos(pitch_rad / 2), sp = std::sin(pitch_rad / 2);
  const double cy = std::cos(yaw_rad / 2), sy = std::sin(yaw_rad / 2);
  return {sr * cp * cy - cr * sp * sy, cr * sp * cy + sr * cp * sy, cr * cp * sy - sr * sp * cy,
          cr * cp * cy + sr * sp * sy};
}

PlanarPose odom_from_base_link(const RobotFrames& r) {
  // inverse(map_from_odom) * map_from_base_link
  const double c = std::cos(r.map_from_odom_yaw_rad), s = std::sin(r.map_from_odom_yaw_rad);
  const double dx = r.x_m - r.map_from_odom_x_m, dy = r.y_m - r.map_from_odom_y_m;
  return {c * dx + s * dy, -s * dx + c * dy, std::remainder(r.yaw_rad - r.map_from_odom_yaw_rad, 2.0 * std::numbers::pi)};
}

namespace {

FrameTransform planar_transform(std::string parent, std::string child, std::int64_t stamp_ns, double x_m, double y_m,
                                double yaw_rad) {
  FrameTransform t;
  t.parent = std::move(parent);
  t.child = std::move(child);
  t.stamp_ns = stamp_ns;
  t.x_m = x_m;
  t.y_m = y_m;
  t.rotation = yaw_rotation(yaw_rad);
  return t;
}

}  // namespace

void append_dynamic_transforms(std::span<const RobotFrames> robots, std::vector<FrameTransform>& out) {
  for (const RobotFrames& r : robots) {
    out.push_back(planar_transform("map", odom_frame(r.robot_id), r.stamp_ns, r.map_from_odom_x_m, r.map_from_odom_y_m,
                                   r.map_from_odom_yaw_rad));
    const PlanarPose p = odom_from_base_link(r);
    out.push_back(planar_transform(odom_frame(r.robot_id), base_link_frame(r.robot_id), r.stamp_ns, p.x_m, p.y_m, p.yaw_rad));
  }
}

FrameTransform laser_transform(std::uint32_t robot_id, const LaserMount& m, std::int64_t stamp_ns) {
  FrameTransform t;
  t.parent = base_link_frame(robot_id);
  t.child = laser_frame(robot_id);
  t.stamp_ns = stamp_ns;
  t.x_m = m.x_m;
  t.y_m = m.y_m;
  t.z_m = m.z_m;
  t.rotation = rpy_rotation(m.roll_rad, m.pitch_rad, m.yaw_rad);
  return t;
}

std::string frame_tree_fault(std::span<const FrameTransform> transforms, std::string_view root) {
  std::map<std::string, std::string, std::less<>> parent_of;
  for (const FrameTransform& t : transforms) {
    for (const std::string* id : {&t.parent, &t.child}) {
      if (id->empty()) return "frame tree: an empty frame id";
      if (id->front() == '/') return "frame tree: frame id " + *id + " starts with /";
    }
    if (t.parent == t.child) return "frame tree: " + t.child + " is its own parent";
    const Quaternion& q = t.rotation;
    const double n2 = q.x * q.x + q.y * q.y + q.z * q.z + q.w * q.w;
    if (!(std::abs(n2 - 1.0) < 0.01)) return "frame tree: " + t.parent + " -> " + t.child + " is no unit rotation";
    if (!std::isfinite(t.x_m) || !std::isfinite(t.y_m) || !std::isfinite(t.z_m))
      return "frame tree: " + t.parent + " -> " + t.child + " has a non-finite translation";
    const auto [it, added] = parent_of.try_emplace(t.child, t.parent);
    if (!added && it->second != t.parent)
      return "frame tree: " + t.child + " has two parents, " + it->second + " and " + t.parent;
  }
  if (parent_of.contains(root)) return "frame tree: the root " + std::string(root) + " has a parent";
  for (const auto& entry : parent_of) {
    std::string_view frame = entry.first;
    for (std::size_t steps = 0; frame != root; ++steps) {
      const auto it = parent_of.find(frame);
      if (it == parent_of.end()) return "frame tree: " + entry.first + " does not reach " + std::string(root);
      if (steps > parent_of.size()) return "frame tree: " + entry.first + " is in a cycle";
      frame = it->second;
    }
  }
  return {};
}

}  // namespace teamscan::dds::ros2
