// A simulation scenario: room, furniture, robots with their tracks, lasers and noise, seed and
// duration. Loaded from TOML (sim/scenarios/*.toml; every key is documented in
// sim/scenarios/README.md); a malformed file gives an error that names the key.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "common/laser_geometry.hpp"
#include "common/pose.hpp"
#include "sim/devices.hpp"
#include "sim/track.hpp"

namespace teamscan::sim {

struct FurnitureSpec {
  enum class Kind : std::uint8_t { box, table };
  Kind kind = Kind::box;
  Vec2 center_m;
  double yaw_rad = 0;
  Vec3 size_m{1, 1, 1};          // length (x), width (y), height (z; a table's top surface height)
  double top_thickness_m = 0.03;  // table only
  double leg_m = 0.05;            // table only: square leg side
};

struct TrackSpec {
  Track::Kind kind = Track::Kind::oval;
  Vec2 center_m;
  double yaw_rad = 0;
  double semi_x_m = 3.0, semi_y_m = 1.6;     // oval
  double half_length_m = 3.0, width_m = 3.0;  // figure8
  std::vector<Vec2> waypoints_m;              // waypoints
  bool closed = true;                         // waypoints
  Track::Spline spline = Track::Spline::uniform;  // waypoints
  bool ccw = true;
};

struct RobotSpec {
  std::uint8_t id = 1;
  std::string name;                      // default "robotN"
  std::string role = "down-laser";
  std::string subclass = "p3at-sh";
  TrackSpec track;
  double speed_mps = 0.3;
  double accel_mps2 = 0.3;               // speed ramps at starts and stops; 0 = instant
  double max_turn_rate_deg_s = 140.0;    // slows where the track would turn it faster; 0 = no limit
  double laps = 2.0;
  double start_offset_m = 0;             // from `start_offset_m` or `start_phase` × track length
  std::optional<double> start_phase;     // fraction of the track length, resolved after the track is built
  double start_s = 0;                    // when it starts to drive
  std::vector<Pause> pauses;
  Pose3 robot_from_laser;                // mount
  double mount_xyz_m[3] = {0.125, 0.0, 0.462};
  double mount_rpy_rad[3] = {0, 0, 0};
  LaserVariant variant;
  std::uint32_t lms_baud = 500000;
  std::uint32_t arcos_baud = 38400;      // after HOSTBAUD (p3at SwitchToBaudRate, §1.11)
  double sip_cycle_s = 0.1;              // §1.7
  double scan_phase_s = 0.0;             // offset of this robot's first scan stamp
  double range_noise_mm = 5.0;
  OdometryNoise odometry;
};

struct Scenario {
  std::string name = "unnamed";
  std::uint64_t seed = 1;
  std::optional<double> duration_s;       // default: until every robot has finished
  std::int64_t start_time_ns = 1'700'000'000'000'000'000;  // CLOCK_REALTIME of t = 0
  Vec3 room_m{10.0, 8.0, 3.0};
  std::vector<FurnitureSpec> furniture;
  std::vector<RobotSpec> robots;
};

struct ScenarioLoad {
  std::optional<Scenario> scenario;
  std::string error;  // names the file and key when scenario is empty
};

[[nodiscard]] ScenarioLoad parse_scenario(const std::string& toml_text, const std::string& source_name);
[[nodiscard]] ScenarioLoad load_scenario_file(const std::string& path);

// A built-in name ("lap2", "fig8", …) or a path. Built-in names are the installed
// share/teamscan/scenarios/NAME.toml, or sim/scenarios/NAME.toml in a build tree (find_data_file).
[[nodiscard]] ScenarioLoad resolve_scenario(const std::string& name_or_path);
[[nodiscard]] std::vector<std::string> builtin_scenario_names();

}  // namespace teamscan::sim
