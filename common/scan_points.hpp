// One LMS 2xx scan -> 3-D points in the map frame: the single definition of the laser geometry,
// shared by the robot daemon (live) and the simulator (to build the data set), so that both produce
// the same millimetres for the same beams (DESIGN.md "Frames, units, time"). The input is the
// scanner's own decoded telegram, viewed in place (lms200::ScanTelegram::sweep(), the daemon's and the
// simulator's receiver's alike: common/laser_geometry.hpp BeamSpans); the output, ScanPoints, is the scan the robot publishes on teamscan/scan and the
// ground station records. Firmware-clean: no heap, no exceptions; fixed capacities from
// common/capacities.hpp.
#pragma once

#include <array>
#include <cstdint>
#include <span>

#include "common/capacities.hpp"
#include "common/laser_geometry.hpp"
#include "common/odometry_history.hpp"
#include "common/point_flags.hpp"
#include "common/pose.hpp"
#include "common/odom_correction.hpp"
#include "common/time.hpp"

namespace teamscan {

// One point in the map frame: int32 millimetres (wire unit), the beam it came from, kPoint* flags.
struct ScanPoint {
  std::int32_t x_mm = 0;
  std::int32_t y_mm = 0;
  std::int32_t z_mm = 0;
  std::uint16_t beam = 0;
  std::uint16_t flags = 0;
};

// One sweep in the map frame: what the projector makes, the direction filter flags in place and the
// robot publishes (teamscan/scan, idl/teamscan.idl ScanPoints, field for field), and what the station
// records (beside a station::Receipt, scan_record.hpp). Corrected by `applied` (none: odometry-map frame).
struct ScanPoints {
  std::uint32_t robot_id = 0;    // set by the publisher (the projector leaves it)
  std::uint32_t seq = 0;         // the robot's scan sequence number, set by the publisher
  Time stamp;                    // the scan's stamp (end of sweep), CLOCK_REALTIME
  std::int32_t origin_x_mm = 0;  // laser centre in the map frame at the stamp
  std::int32_t origin_y_mm = 0;
  std::int32_t origin_z_mm = 0;
  OdomCorrection applied;        // the robot's own correction in origin and points (none: identity)
  std::uint16_t count = 0;       // points[0..count): beams 0..count-1 in order, or (published "kept")
                                 // only the kept ones, still in beam order
  std::array<ScanPoint, kMaxBeams> points{};
  // The projection's result, not on the wire (the ground station decides poses itself).
  Pose2 map_from_robot;          // robot pose at the stamp (valid only if pose_ok)
  bool pose_ok = false;
  std::uint16_t unplaced = 0;    // beams with kPointNoPose
};

struct ScanPointsOptions {
  // Valid beams longer than this are flagged kPointOutOfRange (LMS mm mode: 8.182 m useful maximum,
  // PROTOCOLS.md 2.7; cm mode: 81.82 m).
  std::uint32_t max_range_mm = 8182;
  // How far a beam's time may lie outside the odometry history (odometry_history.hpp).
  Duration max_extrapolation = kDefaultMaxExtrapolation;
};

// Converts scans of a robot with a fixed laser mount and registration. Holds the beam directions of
// the current variant in the robot frame, precomputed at construction (recomputed, without
// allocation, if a scan of another variant arrives).
//
// Geometry of beam i with range r (mm), measured at t_i = stamp − variant.beam_age(i):
//   p_laser = r · (cos a_i, sin a_i, 0),  a_i = variant.beam_angle_rad(i)
//   p_robot = robot_from_laser · p_laser
//   p_map   = map_from_odom · odom_from_robot(t_i) · p_robot   (planar poses lifted to 3-D, z = 0)
// with odom_from_robot(t_i) from OdometryHistory::interpolate. Coordinates are rounded to the nearest
// millimetre (ties away from zero, std::llround) and saturated to int32.
//
// Flags: kBeamInvalid (a reserved distance code) or range 0 -> kPointInvalid, kBeamDazzled -> kPointDazzled; both put the point
// at the laser centre at t_i (so a consumer that ignores flags sees no phantom far point); a valid
// range > max_range_mm -> kPointOutOfRange with the measured position; a beam whose time the odometry
// cannot cover -> kPointNoPose with coordinates 0.
class ScanProjector {
 public:
  ScanProjector(const Pose3& robot_from_laser, const Pose2& map_from_odom, const ScanPointsOptions& options = {});

  // Fills `out`'s geometry (stamp, origin, points, pose; robot_id, seq and applied are the caller's)
  // from the beams of one full sweep of `variant` ending at `stamp`. False, `out` unchanged, when they
  // are not one (a partial scan: no beams; another beam count; flags not one per beam): its beams would
  // land at wrong angles; the caller drops and counts it.
  [[nodiscard]] bool project(BeamSpans beams, Time stamp, LaserVariant variant, const OdometryHistory<>& odometry,
                             ScanPoints& out);

  [[nodiscard]] const Pose3& robot_from_laser() const { return robot_from_laser_; }
  [[nodiscard]] const Pose2& map_from_odom() const { return map_from_odom_; }
  // A new map_from_odom for the scans that follow (the robot's registration correction composed with
  // its configured start pose). No allocation.
  void set_map_from_odom(const Pose2& map_from_odom) { map_from_odom_ = map_from_odom; }
  [[nodiscard]] const ScanPointsOptions& options() const { return options_; }

 private:
  void prepare(LaserVariant variant);

  Pose3 robot_from_laser_;
  Pose2 map_from_odom_;
  ScanPointsOptions options_;
  LaserVariant variant_{0, 100};  // fov 0: no table yet
  std::array<Vec3, kMaxBeams> direction_robot_{};  // unit beam direction in the robot frame
};


}  // namespace teamscan
