// Plain fixed-size message structs the onboard pipeline hands to the DDS bridge (onboard/bridge) and gets
// back from it: the robot-side mirror of idl/teamscan.idl, free of DDS so the core stays testable. The
// scan (teamscan/scan) is common/scan_points.hpp ScanPoints itself: the projector's output, flagged in
// place by the direction filter, published as it is.
// Fixed capacities only (common/capacities.hpp); field layout agreed with the dds branch.
#pragma once

#include <cstdint>

#include "common/capacities.hpp"
#include "common/odom_correction.hpp"
#include "common/scan_points.hpp"

namespace teamscan::onboard {

// Odometry pose in the odometry-map frame (teamscan/pose: the configured start pose, no correction), one per SIP.
struct OnboardPose {
  std::uint32_t robot_id = 0;
  std::uint32_t seq = 0;
  std::int64_t stamp_ns = 0;        // CLOCK_REALTIME of the SIP (arrival, back-dated)
  std::int32_t x_mm = 0;
  std::int32_t y_mm = 0;
  std::int32_t yaw_urad = 0;        // heading, microradians, (-pi, pi]
  std::int32_t vx_mmps = 0;         // map-frame velocity
  std::int32_t vy_mmps = 0;
  std::int32_t yaw_rate_mradps = 0;
};

// Device states and counters (teamscan/status).
struct OnboardStatus {
  std::uint32_t robot_id = 0;
  std::uint32_t seq = 0;
  std::int64_t stamp_ns = 0;
  std::uint8_t arcos_state = 0;     // 0 = down (no port), see onboard/daemon DeviceState
  std::uint8_t lms_state = 0;
  bool team_fresh = false;          // the last team state is younger than max_team_age
  std::uint8_t clock_sync = 0;      // ClockSync (onboard/daemon/clock_sync.hpp): 0 unknown, 1 synchronised, 2 not
  std::uint32_t sip_rate_mhz = 0;   // SIPs per 1000 s
  std::uint32_t scan_rate_mhz = 0;  // sweeps per 1000 s
  std::uint32_t arcos_bad_packets = 0;
  std::uint32_t lms_bad_telegrams = 0;
  std::uint32_t lms_resyncs = 0;
  std::uint32_t scans_published = 0;
  std::uint32_t points_direction_filtered = 0;
  std::uint32_t dds_write_errors = 0;
  std::uint32_t uptime_s = 0;
  // Onboard extras (not yet on the wire; the bridge may ignore them).
  std::uint32_t arcos_reopens = 0;  // times the Pioneer's port was (re)opened
  std::uint32_t lms_reopens = 0;
  std::uint32_t points_team_stale = 0;
  std::uint32_t points_no_pose = 0;
  std::uint32_t loop_max_us = 0;    // longest loop iteration since the last status
  std::uint32_t teams_rejected = 0;   // team states refused by check_team (team_validation.hpp)
  std::uint32_t last_team_reject = 0; // TeamReject of the newest refused one
  std::uint32_t corrections_applied = 0;   // own corrections taken into use (pipeline.hpp)
  std::uint32_t corrections_rejected = 0;  // own corrections refused as an absurd step
  // Store and forward (onboard/ring): see RobotStatus in idl/teamscan.idl.
  std::uint32_t ring_unconfirmed = 0;
  std::uint32_t ring_dropped = 0;
  std::uint32_t ring_confirmed_seq = 0;
  std::uint32_t shadow_ms = 0;
  std::uint32_t backfill_total = 0;
  std::uint32_t backfill_remaining = 0;
  std::uint32_t confirmations_refused = 0;
  std::uint32_t last_shadow_ms = 0;
};

// What the station has stored of one robot's scans and poses (teamscan/stored).
struct RobotStoredState {
  std::uint32_t robot_id = 0;
  std::uint32_t contiguous_seq = 0;  // every scan from first_seq up to this one is stored
  std::uint32_t first_seq = 0;
  std::uint32_t stored = 0;
  std::uint32_t pose_contiguous_seq = 0;  // every pose from the first stored up to this one is stored; 0: none
};

struct StoredSnapshot {
  std::int64_t stamp_ns = 0;  // the station's publication time (CLOCK_REALTIME)
  std::uint32_t count = 0;
  RobotStoredState robots[kMaxRobots];
};

// One teammate as tracked by the ground station (teamscan/team).
struct TeamMemberState {
  std::uint32_t robot_id = 0;
  std::int32_t x_mm = 0;            // map frame, predicted to valid_ns
  std::int32_t y_mm = 0;
  std::int32_t vx_mmps = 0;
  std::int32_t vy_mmps = 0;
  float cov_xx = 0.0f;              // mm^2
  float cov_xy = 0.0f;
  float cov_yy = 0.0f;
  std::uint16_t length_mm = 0;      // footprint along the robot's x axis
  std::uint16_t width_mm = 0;
  std::uint16_t height_mm = 0;      // top of the robot (with its laser) above the floor
  std::int64_t valid_ns = 0;        // time the position is predicted to, CLOCK_REALTIME
  bool lost = false;
  OdomCorrection correction;        // this member's odometry correction (none: identity)
  std::uint32_t correction_sigma_mm = 0;
  std::uint32_t correction_sigma_yaw_urad = 0;
};

struct TeamSnapshot {
  std::uint32_t count = 0;
  TeamMemberState members[kMaxRobots];
};

}  // namespace teamscan::onboard
