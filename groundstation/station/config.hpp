// teamscan-groundstation configuration (TOML, commented example in deploy/groundstation.toml).
// Every key is optional; a present key with a wrong type or out-of-range value is an error that names it.
#pragma once

#include <string>

#include "common/result.hpp"
#include "groundstation/station/station.hpp"
#include "groundstation/station/team_source.hpp"

namespace teamscan::station {

// Parameters of the Kalman team source (groundstation/mapping/tracker.hpp TrackerOptions), kept here as
// plain values so the config parses without the mapping library.
struct KalmanConfig {
  double accel_noise_mps2 = 0.5;
  double position_noise_m = 0.02;
  double velocity_noise_mps = 0.05;
  double lost_after_s = 1.0;
};

enum class TeamSourceKind { kKalman, kLastPose };

struct GroundStationConfig {
  std::string session_root = "/var/lib/teamscan/sessions";
  Duration sync_interval = std::chrono::seconds(1);     // fdatasync of the session files
  Duration status_interval = std::chrono::seconds(1);   // STATUS= line and journal status
  StationOptions station;
  LastPoseOptions last_pose;
  // "kalman" (default; needs groundstation/mapping in the build) or "last_pose".
  TeamSourceKind team_source = TeamSourceKind::kKalman;
  KalmanConfig kalman;
};

// True when this build has the Kalman tracker (groundstation/mapping).
[[nodiscard]] bool kalman_tracker_available();

struct ConfigError {
  std::string message;  // names the key, e.g. "team.publish_rate_hz: must be in (0, 1000]"
};

// Parses TOML text. On error, returns false and fills `error`.
[[nodiscard]] bool parse_groundstation_config(const std::string& toml_text, const std::string& source_name,
                                              GroundStationConfig& out, ConfigError& error);
[[nodiscard]] bool load_groundstation_config(const std::string& path, GroundStationConfig& out, ConfigError& error);

}  // namespace teamscan::station
