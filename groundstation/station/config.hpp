// teamscan-groundstation configuration (TOML, commented example in deploy/groundstation.toml).
// Every key is optional; a present key with a wrong type or out-of-range value is an error that names it.
#pragma once

#include <string>
#include <vector>

#include "common/result.hpp"
#include "dds/ros2/frames.hpp"
#include "groundstation/registration/registration.hpp"
#include "groundstation/station/fusion.hpp"
#include "groundstation/station/station.hpp"
#include "groundstation/station/team_source.hpp"

namespace teamscan::station {

// Each section is read straight into the options struct of the part it configures, whose defaults are
// the one place for them: [team.kalman] into the station's one tracker (mapping::TrackerOptions, the
// fusion core's and the team source's: `fusion.core.tracker`), [fusion] into station::FusionOptions
// (fusion.hpp: its core's fusion::CoreOptions and mapping::MethodOptions), [registration] into the
// core's registration::RegistrationOptions (`fusion.core.registration_options`; the section's presence
// turns the registration on unless `enabled = false`; docs/registration.md "Odometry prior and
// calibration"). Units: the config's (degrees, seconds) are converted where they are read.

// The station's [fusion] defaults: the owners' (FusionOptions, fusion::CoreOptions, MethodOptions),
// but for the map-based methods' voxel edge (fusion.resolution_m): 0.1 m, the paper's combined method's,
// for frequency and visibility too (the library's default for them, and `teamscan eval`'s, is 0.05 m).
[[nodiscard]] FusionOptions station_fusion_defaults();

// [ros2]: the fused map and the tracked robots on ROS 2 wire names (ros2_publisher.hpp, docs/ros2.md).
// On by default: RViz2 and Foxglove see the survey without a ROS 2 install on the station, and the cost
// is a copy of each teamscan/map update and of the team estimates (docs/ros2.md "Cost").
struct Ros2Config {
  bool enabled = true;
  Duration map_interval = std::chrono::seconds(1);   // rt/teamscan/map_cloud republished this often
  double pose_rate_hz = 10.0;                        // rt/tf and rt/robotN/odom
  // The tracker estimates no heading: the odometry's yaw variance is this sigma squared.
  double heading_sigma_deg = 3.0;
  // Each robot's laser mount ([[ros2.laser_mount]]: id, and x_m y_m z_m roll_deg pitch_deg yaw_deg as in
  // the robot's own [mount]): robotN/base_link -> robotN/laser on rt/tf_static and the view's /tf_static.
  // None listed: no static transforms.
  struct RobotLaserMount {
    std::uint32_t robot_id = 0;
    dds::ros2::LaserMount mount;  // radians inside
  };
  std::vector<RobotLaserMount> laser_mounts;
};

// The browser view (groundstation/view, docs/view.md): HTTP + WebSocket on `listen`; empty: off.
struct ViewConfig {
  std::string listen = "127.0.0.1:8080";
  std::string web_root;                // the built page; empty: found next to the executable
  double period_s = 0.1;               // team snapshots to the view
  std::vector<int> cpus;               // the server thread's CPUs (empty: the process's)
};

enum class TeamSourceKind { kKalman, kLastPose };

struct GroundStationConfig {
  std::string session_root = "/var/lib/teamscan/sessions";
  Duration sync_interval = std::chrono::seconds(1);     // fdatasync of the session files
  Duration status_interval = std::chrono::seconds(1);   // STATUS= line and journal status
  StationOptions station;
  LastPoseOptions last_pose;
  // "kalman" (default) or "last_pose".
  TeamSourceKind team_source = TeamSourceKind::kKalman;
  FusionOptions fusion = station_fusion_defaults();  // [fusion], [team.kalman] and [registration]
  Ros2Config ros2;
  ViewConfig view;
};

struct ConfigError {
  std::string message;  // names the key, e.g. "team.publish_rate_hz: must be in (0, 1000]"
};

// Parses TOML text. On error, returns false and fills `error`.
[[nodiscard]] bool parse_groundstation_config(const std::string& toml_text, const std::string& source_name,
                                              GroundStationConfig& out, ConfigError& error);
[[nodiscard]] bool load_groundstation_config(const std::string& path, GroundStationConfig& out, ConfigError& error);

// The odometry priors of a station config or of a calibration fragment (`teamscan calibrate`'s output:
// [[registration.robot]] tables) read onto `options` (`teamscan eval --calibration FILE`): the file is
// parsed and checked as a station config, and only its [registration] priors are taken.
[[nodiscard]] bool load_registration_priors(const std::string& path, registration::RegistrationOptions& options,
                                            ConfigError& error);

}  // namespace teamscan::station
