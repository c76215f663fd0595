// teamscan-groundstation configuration (TOML, commented example in deploy/groundstation.toml).
// Every key is optional; a present key with a wrong type or out-of-range value is an error that names it.
#pragma once

#include <string>
#include <vector>

#include "common/result.hpp"
#include "groundstation/fusion/core.hpp"
#include "groundstation/mapping/tracker.hpp"
#include "groundstation/station/station.hpp"
#include "groundstation/station/team_source.hpp"

namespace teamscan::station {

// Parameters of the Kalman tracker ([team.kalman]) in the config's units; tracker_options() turns
// them into groundstation/mapping's TrackerOptions for the team source and the fusion stage alike.
struct KalmanConfig {
  double accel_noise_mps2 = 0.5;
  double position_noise_m = 0.02;
  double velocity_noise_mps = 0.05;
  double lost_after_s = 1.0;
  // Odometry drift model (TrackerOptions::drift_*, docs/beyond.md "Drift"): grows the position
  // covariance the fusion stage's filters and the published team state see.
  double drift_m_per_m = 0.005;
  double drift_deg_per_m = 0.0;
  double drift_deg_per_deg = 0.0;
};

// The one conversion of [team.kalman] into the tracker's options (degrees -> radians).
[[nodiscard]] mapping::TrackerOptions tracker_options(const KalmanConfig& kalman);

// The live fusion stage (groundstation/station/fusion.hpp), plain values so the config parses without
// the mapping library. Default method: `best` (issue 7: chosen by the numbers, docs/beyond.md); the
// paper's combined method (direction 7°, then visibility 0.1 m) keeps its parameters below.
struct FusionConfig {
  bool enabled = true;
  std::string method = "best";         // frequency | visibility | position | direction | combined | freespace | tracked | best
  // Further methods decided side by side, each by its own core with its own model store (memory: one
  // more model store, map and pose history per method), written as fused.<method>.pcd (and
  // fused_all.<method>.pcd) at the same times; only `method` feeds teamscan/map, the view and ROS 2.
  std::vector<std::string> compare_methods;
  double write_slice_ms = 2.0;         // a periodic write's snapshot takes at most this much of one loop turn
  std::vector<int> writer_cpus;        // the model writer thread's CPUs (empty: the process's)
  double resolution_m = 0.1;           // frequency / visibility / combined voxel edge
  double half_angle_deg = 7.0;         // direction / combined cone half-angle
  double grid_origin_z_m = 0.0;        // vertical voxel grid offset (paper: 0)
  double frequency_k = 0.0;            // eq. 4: removed below mean − k·σ
  double position_sigma_m = 0.35;      // eq. 6
  double position_n = 1.0;
  bool direction_from_flags = false;   // use the onboard decisions instead of recomputing eq. 7
  Duration write_interval = std::chrono::seconds(10);  // fused PCD; 0 = only on shutdown
  bool write_all_points = false;       // also fused_all.pcd with a `keep` field
  bool latency_log = false;            // also fused_latency.csv: one line per fused scan (docs/demo.md)
  Duration map_interval = std::chrono::seconds(1);     // teamscan/map; 0 = off
  double map_resolution_m = 0.1;
  // The fusion core (groundstation/fusion/core.hpp): how long a scan waits for every robot's poses to
  // pass its stamp, and the model store (points kept per voxel of model_resolution_m).
  double hold_s = fusion::CoreOptions{}.hold_s;
  // The decision lag (mapping::TrackerOptions::team_lag_s): 0 = the exact team at each scan's stamp.
  double team_lag_s = 0.0;
  // With the registration: a robot's scans are stamped at least this far apart (fusion::CoreOptions).
  double min_scan_interval_s = fusion::CoreOptions{}.min_scan_interval_s;
  double model_resolution_m = fusion::CoreOptions{}.model_resolution_m;
  std::uint32_t max_points_per_voxel = fusion::CoreOptions{}.max_points_per_voxel;
  // Scan-to-map registration in the fusion core (docs/registration.md; `teamscan eval --registration`
  // runs the same): on with `registration = true` here or with a [registration] section.
  bool registration = false;
};

// [registration]: its presence turns the registration on (unless `enabled = false`); its keys set the
// registration's options, whose defaults live in registration::RegistrationOptions (the one place): the
// matching cadence and each robot's odometry prior (the team's default in [registration], a calibrated
// robot's in a [[registration.robot]] table: docs/registration.md "Odometry prior and calibration").
struct RegistrationConfig : registration::RegistrationOptions {};

// [ros2]: the fused map and the tracked robots on ROS 2 wire names (ros2_publisher.hpp, docs/ros2.md).
// On by default: RViz2 and Foxglove see the survey without a ROS 2 install on the station, and the cost
// is a copy of each teamscan/map update and of the team estimates (docs/ros2.md "Cost").
struct Ros2Config {
  bool enabled = true;
  Duration map_interval = std::chrono::seconds(1);   // rt/teamscan/map_cloud republished this often
  double pose_rate_hz = 10.0;                        // rt/tf and rt/robotN/odom
  // The tracker estimates no heading: the odometry's yaw variance is this sigma squared.
  double heading_sigma_deg = 3.0;
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
  KalmanConfig kalman;
  FusionConfig fusion;
  RegistrationConfig registration;
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
