// 2-D and 3-D poses and vectors, Eigen-free so the robot side stays dependency-light.
// Transforms are named `a_from_b`: p_a = a_from_b * p_b (STYLE.md 9).
#pragma once

#include <cmath>

#include "common/units.hpp"

namespace teamscan {

struct Vec2 {
  double x = 0, y = 0;
  friend constexpr Vec2 operator+(Vec2 a, Vec2 b) { return {a.x + b.x, a.y + b.y}; }
  friend constexpr Vec2 operator-(Vec2 a, Vec2 b) { return {a.x - b.x, a.y - b.y}; }
  friend constexpr Vec2 operator*(double s, Vec2 a) { return {s * a.x, s * a.y}; }
  [[nodiscard]] double norm() const { return std::hypot(x, y); }
};

struct Vec3 {
  double x = 0, y = 0, z = 0;
  friend constexpr Vec3 operator+(Vec3 a, Vec3 b) { return {a.x + b.x, a.y + b.y, a.z + b.z}; }
  friend constexpr Vec3 operator-(Vec3 a, Vec3 b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }
  friend constexpr Vec3 operator*(double s, Vec3 a) { return {s * a.x, s * a.y, s * a.z}; }
  [[nodiscard]] constexpr double dot(Vec3 o) const { return x * o.x + y * o.y + z * o.z; }
  [[nodiscard]] constexpr Vec3 cross(Vec3 o) const {
    return {y * o.z - z * o.y, z * o.x - x * o.z, x * o.y - y * o.x};
  }
  [[nodiscard]] double norm() const { return std::sqrt(dot(*this)); }
};

// Planar pose: position in metres, heading in radians (x forward, y left, z up).
struct Pose2 {
  double x_m = 0, y_m = 0, theta_rad = 0;

  // Exactly the same numbers (a correction held, not re-derived).
  friend constexpr bool operator==(const Pose2&, const Pose2&) = default;

  // this * other: compose (map_from_robot * robot_from_thing = map_from_thing).
  [[nodiscard]] Pose2 operator*(const Pose2& o) const {
    const double c = std::cos(theta_rad), s = std::sin(theta_rad);
    return {x_m + c * o.x_m - s * o.y_m, y_m + s * o.x_m + c * o.y_m, normalize_angle(theta_rad + o.theta_rad)};
  }
  [[nodiscard]] Vec2 apply(Vec2 p) const {
    const double c = std::cos(theta_rad), s = std::sin(theta_rad);
    return {x_m + c * p.x - s * p.y, y_m + s * p.x + c * p.y};
  }
  [[nodiscard]] Pose2 inverse() const {
    const double c = std::cos(theta_rad), s = std::sin(theta_rad);
    return {-(c * x_m + s * y_m), -(-s * x_m + c * y_m), normalize_angle(-theta_rad)};
  }
};

// Forward speed of a robot heading `yaw_rad` that moves with the map-frame velocity (vx, vy): the
// velocity projected on the heading. The tracker takes this speed and uses (v cos yaw, v sin yaw) as
// its velocity measurement; taking vx alone zeroes it for a robot heading along y.
[[nodiscard]] inline double forward_speed_mps(double vx_mps, double vy_mps, double yaw_rad) {
  return vx_mps * std::cos(yaw_rad) + vy_mps * std::sin(yaw_rad);
}

// Row-major 3x3 rotation.
struct Rot3 {
  double m[3][3] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}};

  // Intrinsic Z-Y-X (yaw, then pitch, then roll): R = Rz(yaw) * Ry(pitch) * Rx(roll).
  // Positive pitch turns +x towards -z (nose down) in this right-handed, z-up convention.
  static Rot3 from_rpy(double roll_rad, double pitch_rad, double yaw_rad) {
    const double cr = std::cos(roll_rad), sr = std::sin(roll_rad);
    const double cp = std::cos(pitch_rad), sp = std::sin(pitch_rad);
    const double cy = std::cos(yaw_rad), sy = std::sin(yaw_rad);
    Rot3 r;
    r.m[0][0] = cy * cp; r.m[0][1] = cy * sp * sr - sy * cr; r.m[0][2] = cy * sp * cr + sy * sr;
    r.m[1][0] = sy * cp; r.m[1][1] = sy * sp * sr + cy * cr; r.m[1][2] = sy * sp * cr - cy * sr;
    r.m[2][0] = -sp;     r.m[2][1] = cp * sr;                r.m[2][2] = cp * cr;
    return r;
  }
  [[nodiscard]] Vec3 apply(Vec3 v) const {
    return {m[0][0] * v.x + m[0][1] * v.y + m[0][2] * v.z, m[1][0] * v.x + m[1][1] * v.y + m[1][2] * v.z,
            m[2][0] * v.x + m[2][1] * v.y + m[2][2] * v.z};
  }
  [[nodiscard]] Rot3 operator*(const Rot3& o) const {
    Rot3 r;
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) r.m[i][j] = m[i][0] * o.m[0][j] + m[i][1] * o.m[1][j] + m[i][2] * o.m[2][j];
    return r;
  }
  [[nodiscard]] Rot3 transpose() const {
    Rot3 r;
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) r.m[i][j] = m[j][i];
    return r;
  }
};

// Rigid 3-D transform: p_a = R * p_b + t.
struct Pose3 {
  Rot3 rotation;
  Vec3 translation;

  static Pose3 from_xyz_rpy(double x, double y, double z, double roll, double pitch, double yaw) {
    return {Rot3::from_rpy(roll, pitch, yaw), {x, y, z}};
  }
  // The planar pose lifted to 3-D (z = 0, rotation about z).
  static Pose3 from_pose2(const Pose2& p) { return from_xyz_rpy(p.x_m, p.y_m, 0, 0, 0, p.theta_rad); }
  [[nodiscard]] Vec3 apply(Vec3 p) const { return rotation.apply(p) + translation; }
  [[nodiscard]] Pose3 operator*(const Pose3& o) const { return {rotation * o.rotation, apply(o.translation)}; }
  [[nodiscard]] Pose3 inverse() const {
    const Rot3 rt = rotation.transpose();
    const Vec3 t = rt.apply(translation);
    return {rt, {-t.x, -t.y, -t.z}};
  }
};

}  // namespace teamscan
