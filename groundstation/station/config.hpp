// teamscan-groundstation configuration (TOML, commented example in deploy/groundstation.toml).
// Every key is optional; a present key with a wrong type or out-of-range value is an error that names it.
#pragma once

#include <string>

#include "common/result.hpp"
#include "groundstation/station/station.hpp"
#include "groundstation/station/team_source.hpp"

namespace teamscan::station {

struct GroundStationConfig {
  std::string session_root = "/var/lib/teamscan/sessions";
  Duration sync_interval = std::chrono::seconds(1);     // fdatasync of the session files
  Duration status_interval = std::chrono::seconds(1);   // STATUS= line and journal status
  StationOptions station;
  LastPoseOptions last_pose;
};

struct ConfigError {
  std::string message;  // names the key, e.g. "team.publish_rate_hz: must be in (0, 1000]"
};

// Parses TOML text. On error, returns false and fills `error`.
[[nodiscard]] bool parse_groundstation_config(const std::string& toml_text, const std::string& source_name,
                                              GroundStationConfig& out, ConfigError& error);
[[nodiscard]] bool load_groundstation_config(const std::string& path, GroundStationConfig& out, ConfigError& error);

}  // namespace teamscan::station
