// The robot daemon's configuration (deploy/onboard-*.toml): robot id, serial devices and rates, laser
// variant and mount, registration in the map frame, direction-filter parameters, DDS and status
// settings. Parsed once at start-up (allocation allowed there); a malformed or inconsistent file is
// refused with a message that names the key.
#pragma once

#include <cstdint>
#include <string>
#include <string_view>

#include "common/laser_geometry.hpp"
#include "common/pose.hpp"
#include "common/result.hpp"
#include "common/time.hpp"
#include "onboard/core/direction_filter.hpp"

namespace teamscan::onboard {

enum class LmsUnits : std::uint8_t { mm, cm };       // LMS measuring units (PROTOCOLS.md 2.7)
enum class PublishMode : std::uint8_t { all, kept };  // all points with flags, or only unfiltered valid ones

struct LaserMount {
  // In the file: metres and degrees; robot frame x forward, y left, z up from the floor.
  double x_m = 0, y_m = 0, z_m = 0;
  double roll_deg = 0, pitch_deg = 0, yaw_deg = 0;  // positive pitch = nose down (common/pose.hpp)
  [[nodiscard]] Pose3 robot_from_laser() const;
};

// [ring]: store and forward (docs/onboard.md "The ring"). Every scan and pose the robot publishes is kept in
// a preallocated file of fixed-size records; what the station has not confirmed is back-filled when it is
// reachable again. No path: no ring.
inline constexpr double kRingRecordsPerSecond = 85.0;  // the LMS' 75 scans and the Pioneer's 10 SIPs a second
// With a ring, the live scan writer offers a station that joins late or comes back after a shadow only its
// newest scan (its late-joiner depth; dds/qos.hpp): the ring back-fills the rest, so the live scans after a
// return are not queued behind seconds of history on a slow link (docs/radio.md).
inline constexpr std::uint32_t kRingLiveLateJoinerDepth = 1;
// The live pose writer's history, offered whole to a station that joins late or returns (64 = 6.4 s at the
// 10 Hz SIP rate, at least the scans' 4 s): the ring back-fills the poses older than these.
inline constexpr std::uint32_t kPoseHistoryDepth = 64;
struct RingConfig {
  std::string path;                         // e.g. /var/lib/teamscan/ring.bin; empty: no ring
  double capacity_s = 1800.0;               // the ring holds this long at kRingRecordsPerSecond
  std::uint32_t flush_records = 75;         // fdatasync after this many records...
  Duration flush_period = 1s;               // ...or when the oldest unflushed one is this old
  double backfill_rate_hz = 300.0;          // back-filled scans per second at most (live ones go first)
  [[nodiscard]] bool enabled() const { return !path.empty(); }
  [[nodiscard]] std::uint64_t slots() const;  // records: ceil(capacity_s * kRingRecordsPerSecond)
};

struct OnboardConfig {
  std::uint32_t robot_id = 0;  // 1..32

  std::string arcos_device;            // e.g. /dev/ttyS0
  std::uint32_t arcos_baud = 9600;     // Pioneer 3-AT default; 19200/38400/57600/115200 if configured

  std::string lms_device;              // e.g. /dev/ttyS1
  std::uint32_t lms_baud = 500000;     // target rate after bring-up at 9600 (9600/19200/38400/500000)
  LaserVariant lms_variant{180, 50};   // 180°/0.5° = 361 beams
  LmsUnits lms_units = LmsUnits::mm;   // mm: 8.18 m range, cm: 81.8 m
  double lms_max_range_m = 8.0;        // longer valid beams are flagged out of range

  LaserMount mount;
  double registration_x_m = 0, registration_y_m = 0, registration_theta_deg = 0;  // map_from_odom

  bool filter_enabled = true;
  cone::DirectionFilterParams filter;

  std::uint32_t dds_domain = 0;
  PublishMode publish = PublishMode::all;
  std::uint32_t scan_history_depth = 300;  // scans the DDS writer keeps for a restarting ground station

  Duration status_period = 1s;             // teamscan/status and sd_notify STATUS= period
  Duration odometry_max_extrapolation = kDefaultMaxExtrapolation;
  // [odometry] max_hold_s: the longest a scan waits for a SIP stamped at or after its sweep end before it
  // is published with its last beams extrapolated from the two newest SIPs (0: at once). Default: the
  // extrapolation limit (every scan interpolated whenever the SIPs keep coming).
  Duration odometry_max_hold = kDefaultMaxExtrapolation;

  RingConfig ring;

  [[nodiscard]] Pose2 map_from_odom() const;
  [[nodiscard]] std::uint32_t max_range_mm() const;
};

// Parses and checks a config. On failure `message` says which key is wrong and why, e.g.
// "lms.baud: 57600 is not an LMS rate (9600, 19200, 38400, 500000)"; the Error carries the line.
[[nodiscard]] Result<OnboardConfig> parse_onboard_config(std::string_view toml_text, std::string& message);
[[nodiscard]] Result<OnboardConfig> load_onboard_config(const std::string& path, std::string& message);

// A human-readable summary (for --check-config and the journal at start-up).
[[nodiscard]] std::string describe(const OnboardConfig& config);

}  // namespace teamscan::onboard
