// A robot's odometry correction map_from_odom (x, y, yaw: the floor is flat) as it crosses the wire:
// the station's registration estimates it (docs/registration.md), teamscan/team carries it to the robot
// (TeamMember.corr_*), the robot applies it to the scans it publishes and says which one it applied
// (ScanPoints.corr_*), and the station undoes that to get back the odometry-map frame it matches in.
// Whole millimetres and microradians, so both ends use exactly the same transform. No allocation.
#pragma once

#include <cmath>
#include <cstdint>

#include "common/pose.hpp"
#include "common/units.hpp"

namespace teamscan {

// π in microradians, rounded: a yaw on the wire is valid in [−kPiUrad, kPiUrad] (the rounding of (−π, π]).
inline constexpr std::int32_t kPiUrad = 3'141'593;

struct OdomCorrection {
  std::int32_t x_mm = 0;
  std::int32_t y_mm = 0;
  std::int32_t yaw_urad = 0;  // (−π, π], µrad
  std::uint32_t seq = 0;      // the station's number of this correction; 0 = none (the identity)

  [[nodiscard]] bool none() const { return seq == 0; }
  [[nodiscard]] bool yaw_in_range() const { return yaw_urad >= -kPiUrad && yaw_urad <= kPiUrad; }
  // map_from_odom in SI units (the identity when none()).
  [[nodiscard]] Pose2 map_from_odom() const {
    if (none()) return Pose2{};
    return Pose2{x_mm * 1e-3, y_mm * 1e-3, yaw_urad * 1e-6};
  }
  // The wire form of a correction (rounded to mm and µrad, ties away from zero; yaw wrapped first).
  [[nodiscard]] static OdomCorrection from_pose(const Pose2& map_from_odom, std::uint32_t seq) {
    OdomCorrection c;
    c.x_mm = to_mm(map_from_odom.x_m);
    c.y_mm = to_mm(map_from_odom.y_m);
    c.yaw_urad = static_cast<std::int32_t>(std::lround(normalize_angle(map_from_odom.theta_rad) * 1e6));
    c.seq = seq;
    return c;
  }
};

}  // namespace teamscan
