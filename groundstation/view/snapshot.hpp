// What the ground station hands the browser view (the view's whole interface to the station): immutable
// team snapshots, the map voxels that changed, and the points of each scan (for the robot a voxel came
// from). Plain values in SI units and wire millimetres; no station, DDS or mapping type crosses here.
#pragma once

#include <array>
#include <cstdint>

#include "common/capacities.hpp"

namespace teamscan::view {

// One robot as the station sees it at a snapshot.
struct RobotState {
  std::uint32_t robot_id = 0;  // 1..32; 0: slot unused
  bool lost = false;           // the station's liveliness view (or the tracker's)
  double x_m = 0.0;            // tracked position (the team source's estimate), map frame
  double y_m = 0.0;
  double yaw_rad = 0.0;    // heading of the robot's newest pose
  double cov_xx_m2 = 0.0;  // tracked position covariance
  double cov_xy_m2 = 0.0;
  double cov_yy_m2 = 0.0;
  double vx_mps = 0.0;               // tracked velocity, map frame
  double vy_mps = 0.0;
  // The station's correction of the robot's odometry (map_from_odom; identity: none yet): the REP-105
  // frame robotN/odom of the Foxglove channels.
  double map_from_odom_x_m = 0.0;
  double map_from_odom_y_m = 0.0;
  double map_from_odom_yaw_rad = 0.0;
  std::uint64_t scans = 0;           // scans stored by the station
  std::uint64_t scans_lost = 0;      // gaps in the robot's scan sequence numbers
  std::uint64_t ghosts_removed = 0;  // points of this robot's scans the live classification removed
  double latency_ms = 0.0;           // mean scan stamp -> taken by the station, over the snapshot's period
  // Store and forward (docs/radio.md "What the operator sees"): a robot in a radio shadow and its return.
  double shadow_s = 0.0;             // silent this long (the station hears nothing from it); 0: heard
  std::uint32_t scans_buffered = 0;  // scans in its ring the station has not confirmed (its newest status)
  double backfill_pct = -1.0;        // back-filling: the share done, 0..100; -1: not back-filling
  double last_shadow_s = 0.0;        // its last shadow that ended, by its own count; 0: none
  std::int64_t whole_again_ns = 0;   // CLOCK_REALTIME it was last whole again after a shadow; 0: never
};

struct TeamSnapshot {
  std::int64_t stamp_ns = 0;  // CLOCK_REALTIME of the snapshot
  std::uint32_t count = 0;    // robots[0..count) in robot id order
  std::array<RobotState, kMaxRobots> robots{};
  std::uint32_t map_voxels = 0;  // occupied voxels of the station's live map
  std::uint64_t map_release = 0; // the fusion core's release counter the live map last offered shows
  std::uint32_t map_resolution_mm = 0;
};

// One voxel of the live map whose content changed: its centre, point count and class. A viewer replaces
// its copy of the voxel (values are absolute, so applying an update twice is harmless).
struct VoxelUpdate {
  std::int32_t x_mm = 0;
  std::int32_t y_mm = 0;
  std::int32_t z_mm = 0;
  std::uint16_t hits = 0;
  std::uint8_t removed = 0;  // 1: every point in the voxel was removed as a ghost
  std::uint8_t robot = 0;    // the robot whose fused point made the voxel (0: unknown)
};

// A map-frame point of a scan (wire millimetres): the view attributes voxels to robots from these.
struct TapPoint {
  std::int32_t x_mm = 0;
  std::int32_t y_mm = 0;
  std::int32_t z_mm = 0;
};

}  // namespace teamscan::view
