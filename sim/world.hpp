// The simulated world: a room (floor z = 0, four walls, ceiling), furniture made of boxes, and the
// robots' bodies at their real size; exact ray/box intersection (slab method) that tells what a
// laser beam hit, where, and at what distance.
#pragma once

#include <cstdint>
#include <optional>
#include <span>
#include <vector>

#include "common/dataset/dataset.hpp"
#include "common/pose.hpp"

namespace teamscan::sim {

// A ray from `origin` along the unit vector `direction`, map frame, metres.
struct Ray {
  Vec3 origin;
  Vec3 direction;
};

// A box with any orientation: p_world = world_from_box.apply(p_box), the box spans ±half_m in its frame.
struct OrientedBox {
  Pose3 world_from_box;
  Vec3 half_m;

  static OrientedBox axis_aligned(Vec3 min_m, Vec3 max_m);
  // A box standing on the floor (or at z_min_m), yawed about its vertical axis.
  static OrientedBox yawed(Vec2 center_m, double yaw_rad, Vec3 size_m, double z_min_m);
};

// Distance along the ray to where it enters the box, if it enters within [0, max_range_m]. A ray
// that starts inside the box does not hit it (a sensor is never inside an obstacle by design).
[[nodiscard]] std::optional<double> intersect(const Ray& ray, const OrientedBox& box, double max_range_m);

// Distance along a ray that starts inside the axis-aligned box [min, max] to where it leaves it,
// and which face: 0/1 = x min/max, 2/3 = y min/max, 4/5 = z min/max.
struct Exit {
  double distance_m = 0;
  int face = 0;
};
[[nodiscard]] Exit exit_box(const Ray& ray, Vec3 min_m, Vec3 max_m);

// The room: x in [-size_x/2, size_x/2], y in [-size_y/2, size_y/2], z in [0, size_z].
struct Room {
  Vec3 size_m{10.0, 8.0, 3.0};
};

// The body of one robot in its own frame (x forward, y left, z up, origin on the floor under the
// centre): boxes for wheels, chassis, bumpers, top plate and the laser housing, and a bounding box
// tested first so that most rays skip the parts.
struct RobotBody {
  std::vector<OrientedBox> parts;
  Vec3 bound_min_m, bound_max_m;
  double length_m = 0.626, width_m = 0.505, height_m = 0.0;  // footprint and overall height
};

// A Pioneer 3-AT (PROTOCOLS.md §1.11: 626 × 505 mm footprint; body top plate at 277 mm) on four
// wheels (215 mm diameter) with an LMS-200 housing (155 wide × 156 deep × 210 high mm) at the mount
// `robot_from_laser` (the housing turns with the laser's tilt).
[[nodiscard]] RobotBody make_pioneer3at_body(const Pose3& robot_from_laser);

// A robot placed in the world at one instant.
struct PlacedRobot {
  std::uint8_t id = 0;
  Pose2 map_from_robot;
  const RobotBody* body = nullptr;
};

struct Hit {
  bool hit = false;
  double range_m = 0;
  PointClass label = PointClass::none;
  std::uint8_t hit_robot = 0;  // the robot whose body was hit (label == robot)
  Vec3 point_m;
};

class World {
 public:
  explicit World(Room room) : room_{room} {}

  void add_box(Vec2 center_m, double yaw_rad, Vec3 size_m);
  // A table: a top slab of `top_thickness_m` at height size_m.z on four square legs of `leg_m`.
  void add_table(Vec2 center_m, double yaw_rad, Vec3 size_m, double top_thickness_m, double leg_m);

  [[nodiscard]] const Room& room() const { return room_; }
  [[nodiscard]] std::span<const OrientedBox> furniture() const { return furniture_; }

  // What the ray hits first: the room's surfaces, furniture, or the body of any robot except
  // `self_id` (a robot's own rays never hit its own body). The room is closed, so a ray starting
  // inside always hits something; `hit` is false only if the origin is outside the room.
  [[nodiscard]] Hit cast(const Ray& ray, std::span<const PlacedRobot> robots, std::uint8_t self_id) const;

 private:
  Room room_;
  std::vector<OrientedBox> furniture_;
};

// The distance at which a ray (in the robot's own frame) enters the robot's body, if it does.
[[nodiscard]] std::optional<double> intersect_body(const Ray& ray_in_robot, const RobotBody& body, double max_range_m);

}  // namespace teamscan::sim
