// The configs `teamscan demo` writes for its processes: one teamscan-onboard config per simulated robot
// (its pty devices, mount, variant and registration from the scenario) and the ground station's.
#pragma once

#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "common/pose.hpp"
#include "sim/scenario.hpp"

namespace teamscan::demo {

struct OnboardConfigInput {
  std::string arcos_device, lms_device;   // the pty symlinks of the robot's emulated devices
  Pose2 registration;                      // map_from_odom: where the robot starts in the map frame
  int domain = 0;                          // DDS domain
  std::optional<double> max_hold_s;        // [odometry] max_hold_s (unset: the daemon's default)
  std::string ring_path;                   // [ring] path (empty: no store and forward)
  double ring_capacity_s = 1800.0;         // [ring] capacity_s
};
[[nodiscard]] std::string onboard_config(const sim::RobotSpec& spec, const OnboardConfigInput& in);

struct StationConfigInput {
  std::string session_root;
  int domain = 0;
  std::string method = "best";             // [fusion] method
  std::vector<std::string> compare_methods;  // [fusion] compare_methods: decided beside it, each its own model
  double write_interval_s = 0.0;           // [fusion] write_interval_s (0: once, at shutdown)
  bool ros2 = true;                        // [ros2] enabled (docs/ros2.md)
  std::optional<int> view_port;            // [view] listen on 127.0.0.1:PORT (unset: no view)
  bool registration = false;               // a [registration] section: scan-to-map registration, its defaults
  bool pose_graph = true;                  // [pose_graph] enabled: the pose graph as the fusion core's back end
  // A calibration (`teamscan calibrate`'s [[registration.robot]] tables), appended as it is (checked by the
  // caller: station::load_registration_priors); empty: none.
  std::string calibration_toml;
  std::vector<sim::RobotSpec> robots;  // [[ros2.laser_mount]] per robot: its mount, for /tf_static
};
[[nodiscard]] std::string station_config(const StationConfigInput& in);

// `s` as a TOML basic string with its quotes (toml++ formats it: quotes, backslashes and control
// characters escaped), for the paths and names the configs carry.
[[nodiscard]] std::string toml_string(std::string_view s);

}  // namespace teamscan::demo
