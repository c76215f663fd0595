// Ray casting against the room, furniture and robot bodies (world.hpp).
#include "sim/world.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace teamscan::sim {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

// Slab test in the box's own frame; returns the entry distance or nothing.
std::optional<double> slab_entry(const double o[3], const double d[3], const double h[3], double max_range_m) {
  double t_near = -kInf, t_far = kInf;
  for (int axis = 0; axis < 3; ++axis) {
    if (std::abs(d[axis]) < 1e-15) {
      // Parallel to this pair of faces: inside the slab or never.
      if (o[axis] < -h[axis] || o[axis] > h[axis]) return std::nullopt;
      continue;
    }
    const double inv = 1.0 / d[axis];
    double t1 = (-h[axis] - o[axis]) * inv;
    double t2 = (h[axis] - o[axis]) * inv;
    if (t1 > t2) std::swap(t1, t2);
    t_near = std::max(t_near, t1);
    t_far = std::min(t_far, t2);
    if (t_near > t_far) return std::nullopt;
  }
  if (t_near < 0.0 || t_near > max_range_m) return std::nullopt;  // behind, inside, or too far
  return t_near;
}

Vec3 at(const Ray& ray, double t) { return ray.origin + t * ray.direction; }

}  // namespace

OrientedBox OrientedBox::axis_aligned(Vec3 min_m, Vec3 max_m) {
  OrientedBox box;
  box.world_from_box.translation = 0.5 * (min_m + max_m);
  box.half_m = 0.5 * (max_m - min_m);
  return box;
}

OrientedBox OrientedBox::yawed(Vec2 center_m, double yaw_rad, Vec3 size_m, double z_min_m) {
  OrientedBox box;
  box.world_from_box = Pose3::from_xyz_rpy(center_m.x, center_m.y, z_min_m + 0.5 * size_m.z, 0, 0, yaw_rad);
  box.half_m = 0.5 * size_m;
  return box;
}

std::optional<double> intersect(const Ray& ray, const OrientedBox& box, double max_range_m) {
  const Rot3& r = box.world_from_box.rotation;
  const Vec3 rel = ray.origin - box.world_from_box.translation;
  // Into the box frame: R^T * v.
  const double o[3] = {r.m[0][0] * rel.x + r.m[1][0] * rel.y + r.m[2][0] * rel.z,
                       r.m[0][1] * rel.x + r.m[1][1] * rel.y + r.m[2][1] * rel.z,
                       r.m[0][2] * rel.x + r.m[1][2] * rel.y + r.m[2][2] * rel.z};
  const Vec3& dv = ray.direction;
  const double d[3] = {r.m[0][0] * dv.x + r.m[1][0] * dv.y + r.m[2][0] * dv.z,
                       r.m[0][1] * dv.x + r.m[1][1] * dv.y + r.m[2][1] * dv.z,
                       r.m[0][2] * dv.x + r.m[1][2] * dv.y + r.m[2][2] * dv.z};
  const double h[3] = {box.half_m.x, box.half_m.y, box.half_m.z};
  return slab_entry(o, d, h, max_range_m);
}

Exit exit_box(const Ray& ray, Vec3 min_m, Vec3 max_m) {
  const double o[3] = {ray.origin.x, ray.origin.y, ray.origin.z};
  const double d[3] = {ray.direction.x, ray.direction.y, ray.direction.z};
  const double lo[3] = {min_m.x, min_m.y, min_m.z};
  const double hi[3] = {max_m.x, max_m.y, max_m.z};
  Exit best{kInf, 0};
  for (int axis = 0; axis < 3; ++axis) {
    if (d[axis] > 1e-15) {
      const double t = (hi[axis] - o[axis]) / d[axis];
      if (t < best.distance_m) best = {t, 2 * axis + 1};
    } else if (d[axis] < -1e-15) {
      const double t = (lo[axis] - o[axis]) / d[axis];
      if (t < best.distance_m) best = {t, 2 * axis};
    }
  }
  return best;
}

RobotBody make_pioneer3at_body(const Pose3& robot_from_laser) {
  RobotBody body;
  auto aabb = [&](Vec3 lo, Vec3 hi) { body.parts.push_back(OrientedBox::axis_aligned(lo, hi)); };
  // Four wheels, 215 mm diameter, 110 mm wide, wheelbase 268 mm; their outer faces span the 505 mm width.
  for (double x : {-0.134, 0.134}) {
    for (double sign : {-1.0, 1.0}) {
      const double y_in = sign * 0.1425, y_out = sign * 0.2525;
      aabb({x - 0.1075, std::min(y_in, y_out), 0.0}, {x + 0.1075, std::max(y_in, y_out), 0.215});
    }
  }
  aabb({-0.255, -0.1425, 0.09}, {0.255, 0.1425, 0.250});     // chassis between the wheels
  aabb({-0.261, -0.195, 0.250}, {0.261, 0.195, 0.277});      // top plate (277 mm above the floor)
  aabb({0.255, -0.16, 0.10}, {0.313, 0.16, 0.20});           // front bumper (RobotLengthFront 313 mm)
  aabb({-0.313, -0.16, 0.10}, {-0.255, 0.16, 0.20});         // rear bumper
  // LMS-200 housing in the laser frame: the scan plane lies 185 mm above the housing's base and the
  // mirror axis 93 mm behind its 156 mm deep front; it tilts with the mount.
  OrientedBox housing;
  const Pose3 laser_from_housing = Pose3::from_xyz_rpy(-0.015, 0.0, -0.080, 0, 0, 0);
  housing.world_from_box = robot_from_laser * laser_from_housing;
  housing.half_m = {0.078, 0.0775, 0.105};
  body.parts.push_back(housing);
  // A mount post from the top plate up to the housing's base, so a high mount is not floating.
  const Vec3 housing_c = housing.world_from_box.translation;
  if (housing_c.z - 0.105 > 0.277) {
    aabb({housing_c.x - 0.03, housing_c.y - 0.03, 0.277}, {housing_c.x + 0.03, housing_c.y + 0.03, housing_c.z - 0.05});
  }

  Vec3 lo{kInf, kInf, kInf}, hi{-kInf, -kInf, -kInf};
  for (const OrientedBox& part : body.parts) {
    const Rot3& r = part.world_from_box.rotation;
    // Extent of an oriented box along each world axis: sum of |R_ij| * h_j.
    const double h[3] = {part.half_m.x, part.half_m.y, part.half_m.z};
    double ext[3];
    for (int i = 0; i < 3; ++i) ext[i] = std::abs(r.m[i][0]) * h[0] + std::abs(r.m[i][1]) * h[1] + std::abs(r.m[i][2]) * h[2];
    const Vec3& c = part.world_from_box.translation;
    lo = {std::min(lo.x, c.x - ext[0]), std::min(lo.y, c.y - ext[1]), std::min(lo.z, c.z - ext[2])};
    hi = {std::max(hi.x, c.x + ext[0]), std::max(hi.y, c.y + ext[1]), std::max(hi.z, c.z + ext[2])};
  }
  body.bound_min_m = lo;
  body.bound_max_m = hi;
  body.height_m = hi.z;
  return body;
}

std::optional<double> intersect_body(const Ray& ray_in_robot, const RobotBody& body, double max_range_m) {
  const OrientedBox bound = OrientedBox::axis_aligned(body.bound_min_m, body.bound_max_m);
  if (!intersect(ray_in_robot, bound, max_range_m)) return std::nullopt;
  std::optional<double> best;
  for (const OrientedBox& part : body.parts) {
    if (auto t = intersect(ray_in_robot, part, best ? *best : max_range_m)) best = t;
  }
  return best;
}

void World::add_box(Vec2 center_m, double yaw_rad, Vec3 size_m) {
  furniture_.push_back(OrientedBox::yawed(center_m, yaw_rad, size_m, 0.0));
}

void World::add_table(Vec2 center_m, double yaw_rad, Vec3 size_m, double top_thickness_m, double leg_m) {
  furniture_.push_back(
      OrientedBox::yawed(center_m, yaw_rad, {size_m.x, size_m.y, top_thickness_m}, size_m.z - top_thickness_m));
  const Pose2 map_from_table{center_m.x, center_m.y, yaw_rad};
  const double lx = 0.5 * size_m.x - 0.5 * leg_m - 0.02, ly = 0.5 * size_m.y - 0.5 * leg_m - 0.02;
  for (double sx : {-1.0, 1.0}) {
    for (double sy : {-1.0, 1.0}) {
      const Vec2 leg = map_from_table.apply({sx * lx, sy * ly});
      furniture_.push_back(OrientedBox::yawed(leg, yaw_rad, {leg_m, leg_m, size_m.z - top_thickness_m}, 0.0));
    }
  }
}

Hit World::cast(const Ray& ray, std::span<const PlacedRobot> robots, std::uint8_t self_id) const {
  Hit hit;
  const Vec3 lo{-0.5 * room_.size_m.x, -0.5 * room_.size_m.y, 0.0};
  const Vec3 hi{0.5 * room_.size_m.x, 0.5 * room_.size_m.y, room_.size_m.z};
  const Vec3& o = ray.origin;
  if (o.x < lo.x || o.x > hi.x || o.y < lo.y || o.y > hi.y || o.z < lo.z || o.z > hi.z) return hit;
  const Exit exit = exit_box(ray, lo, hi);
  hit.hit = true;
  hit.range_m = exit.distance_m;
  hit.label = exit.face == 4 ? PointClass::floor : exit.face == 5 ? PointClass::ceiling : PointClass::wall;

  for (const OrientedBox& box : furniture_) {
    if (auto t = intersect(ray, box, hit.range_m)) {
      hit.range_m = *t;
      hit.label = PointClass::furniture;
    }
  }
  for (const PlacedRobot& robot : robots) {
    if (robot.id == self_id || robot.body == nullptr) continue;
    // Into the robot's frame: the planar inverse, z unchanged.
    const Pose2& p = robot.map_from_robot;
    const double c = std::cos(p.theta_rad), s = std::sin(p.theta_rad);
    const double rx = o.x - p.x_m, ry = o.y - p.y_m;
    const Ray local{{c * rx + s * ry, -s * rx + c * ry, o.z},
                    {c * ray.direction.x + s * ray.direction.y, -s * ray.direction.x + c * ray.direction.y,
                     ray.direction.z}};
    if (auto t = intersect_body(local, *robot.body, hit.range_m)) {
      hit.range_m = *t;
      hit.label = PointClass::robot;
      hit.hit_robot = robot.id;
    }
  }
  hit.point_m = at(ray, hit.range_m);
  return hit;
}

}  // namespace teamscan::sim
