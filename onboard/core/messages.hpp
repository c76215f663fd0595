// Plain message structs the onboard pipeline hands to the DDS bridge and gets back from it.
// Placeholder written by the dds branch until the onboard branch commits its own version of this file;
// on a merge conflict the onboard engineer's file wins. Fixed capacities only (common/capacities.hpp).
#pragma once

#include <cstdint>

#include "common/capacities.hpp"

namespace teamscan::onboard {

// Odometry pose in the map frame (teamscan/pose).
struct OnboardPose {
  std::uint32_t robot_id = 0;
  std::uint32_t seq = 0;
  std::int64_t stamp_ns = 0;        // CLOCK_REALTIME
  std::int32_t x_mm = 0;
  std::int32_t y_mm = 0;
  std::int32_t yaw_urad = 0;        // heading, microradians
  std::int32_t vx_mmps = 0;         // map-frame velocity
  std::int32_t vy_mmps = 0;
  std::int32_t yaw_rate_mradps = 0;
};

// Per-point flags (same bits as teamscan.idl POINT_*).
inline constexpr std::uint16_t kPointDirectionFiltered = 1;
inline constexpr std::uint16_t kPointInvalid = 2;
inline constexpr std::uint16_t kPointDazzled = 4;
inline constexpr std::uint16_t kPointPositionFiltered = 8;

struct OnboardPoint {
  std::int32_t x_mm = 0;            // map frame
  std::int32_t y_mm = 0;
  std::int32_t z_mm = 0;
  std::uint16_t beam = 0;           // beam index, 0 = rightmost
  std::uint16_t flags = 0;          // kPoint* bits
};

// One sweep in the map frame (teamscan/scan).
struct OnboardScan {
  std::uint32_t robot_id = 0;
  std::uint32_t seq = 0;
  std::int64_t stamp_ns = 0;        // end of the mirror sweep, CLOCK_REALTIME
  std::int32_t origin_x_mm = 0;     // laser origin in the map frame
  std::int32_t origin_y_mm = 0;
  std::int32_t origin_z_mm = 0;
  std::uint16_t count = 0;          // valid entries in points
  OnboardPoint points[kMaxBeams];
};

// Device states and counters (teamscan/status).
struct OnboardStatus {
  std::uint32_t robot_id = 0;
  std::uint32_t seq = 0;
  std::int64_t stamp_ns = 0;
  std::uint8_t arcos_state = 0;
  std::uint8_t lms_state = 0;
  bool team_fresh = false;
  std::uint32_t sip_rate_mhz = 0;
  std::uint32_t scan_rate_mhz = 0;
  std::uint32_t arcos_bad_packets = 0;
  std::uint32_t lms_bad_telegrams = 0;
  std::uint32_t lms_resyncs = 0;
  std::uint32_t scans_published = 0;
  std::uint32_t points_direction_filtered = 0;
  std::uint32_t dds_write_errors = 0;
  std::uint32_t uptime_s = 0;
};

// One teammate as tracked by the ground station (teamscan/team).
struct TeamMemberState {
  std::uint32_t robot_id = 0;
  std::int32_t x_mm = 0;
  std::int32_t y_mm = 0;
  std::int32_t vx_mmps = 0;
  std::int32_t vy_mmps = 0;
  float cov_xx = 0.0f;              // mm^2
  float cov_xy = 0.0f;
  float cov_yy = 0.0f;
  std::uint16_t length_mm = 0;
  std::uint16_t width_mm = 0;
  std::uint16_t height_mm = 0;
  std::int64_t valid_ns = 0;        // time the position is predicted to
  bool lost = false;
};

struct TeamSnapshot {
  std::uint32_t count = 0;
  TeamMemberState members[kMaxRobots];
};

}  // namespace teamscan::onboard
