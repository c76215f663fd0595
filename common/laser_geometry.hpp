// Laser geometry shared by the robot daemon and the simulator: beam angles and times of an LMS 2xx
// scan, and beam -> 3-D point in the map frame (DESIGN.md "Frames, units, time").
//
// Laser frame: x along the scanner's 90° beam, y to the left, z up out of the scanner's top.
// Beam i of a scan with field of view F and resolution r points at angle (i·r − F/2) about the laser
// z axis, index 0 on the right. The mirror turns at 75 Hz; a 0.5° (0.25°) scan is interlaced from
// 2 (4) revolutions, revolution k measuring the beams i ≡ k (mod revolutions). A scan's time stamp is
// the time its last beam was measured (the end of the sweep).
#pragma once

#include <cstdint>
#include <span>

#include "common/pose.hpp"
#include "common/time.hpp"
#include "common/units.hpp"

namespace teamscan {

// The beams of one full sweep as the geometry (common/scan_points.hpp) reads them: spans into the
// decoded telegram (lms200::ScanTelegram::sweep()), never a copy, so not a form of the scan of its own.
// range_mm and flags (kBeam*, common/point_flags.hpp) have the same length.
struct BeamSpans {
  std::span<const std::uint32_t> range_mm;
  std::span<const std::uint8_t> flags;
};

inline constexpr double kLmsMirrorHz = 75.0;
inline constexpr Duration kLmsRevolution{13'333'333};  // 1 / 75 Hz

struct LaserVariant {
  std::uint16_t fov_deg = 180;            // 100 or 180
  std::uint16_t resolution_cdeg = 100;    // 100 (1°), 50 (0.5°), 25 (0.25°)

  [[nodiscard]] constexpr std::uint16_t beams() const {
    return static_cast<std::uint16_t>(fov_deg * 100 / resolution_cdeg + 1);
  }
  [[nodiscard]] constexpr std::uint16_t revolutions() const {
    return static_cast<std::uint16_t>(100 / resolution_cdeg);
  }
  [[nodiscard]] constexpr double beam_angle_rad(std::uint16_t i) const {
    return deg_to_rad(static_cast<double>(i) * resolution_cdeg * 0.01 - fov_deg * 0.5);
  }
  // How long before the scan's time stamp beam i was measured. Revolution k = i mod R measures the
  // beams at angles −F/2 + k·r + j·R·r, starting at the same mirror phase each revolution; revolutions
  // are measured in order k = 0..R−1 and the stamp is the last beam of revolution R−1.
  [[nodiscard]] constexpr Duration beam_age(std::uint16_t i) const {
    const std::int64_t revs = revolutions();
    const std::int64_t k = static_cast<std::int64_t>(i) % revs;
    const std::int64_t last = ((beams() - 1 - (revs - 1)) / revs) * revs + (revs - 1);
    const std::int64_t cdeg = (revs - 1 - k) * 36000 + (last - static_cast<std::int64_t>(i)) * resolution_cdeg;
    return Duration{cdeg * kLmsRevolution.count() / 36000};
  }
  // Time from the first measured beam to the stamp: the length of the sweep that builds one scan.
  [[nodiscard]] constexpr Duration sweep_duration() const { return beam_age(0); }
  friend constexpr bool operator==(LaserVariant, LaserVariant) = default;
};

// The point a beam of `range_m` at `angle_rad` hits, in the laser frame.
[[nodiscard]] inline Vec3 beam_in_laser(double angle_rad, double range_m) {
  return {range_m * std::cos(angle_rad), range_m * std::sin(angle_rad), 0.0};
}

// map_from_laser = map_from_robot(t) * robot_from_laser, with map_from_robot from the planar
// odometry pose already registered in the map frame.
[[nodiscard]] inline Pose3 map_from_laser(const Pose2& map_from_robot, const Pose3& robot_from_laser) {
  return Pose3::from_pose2(map_from_robot) * robot_from_laser;
}

// Linear interpolation of planar poses (heading along the shorter arc). s in [0, 1].
[[nodiscard]] inline Pose2 interpolate(const Pose2& a, const Pose2& b, double s) {
  return {a.x_m + s * (b.x_m - a.x_m), a.y_m + s * (b.y_m - a.y_m),
          normalize_angle(a.theta_rad + s * normalize_angle(b.theta_rad - a.theta_rad))};
}

}  // namespace teamscan
