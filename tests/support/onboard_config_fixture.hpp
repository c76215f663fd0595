// The onboard config the pipeline tests and benchmarks share: a down-laser robot (180°/0.5°, mount
// 0.16 m ahead, 0.45 m up, pitched 15° down), filter gates on or off.
#pragma once

#include <string>

namespace teamscan::test {

inline std::string pipeline_test_config_toml(int robot_id, bool gates) {
  return "[robot]\nid = " + std::to_string(robot_id) +
         "\n[arcos]\ndevice = \"/dev/a\"\n[lms]\ndevice = \"/dev/b\"\nfov_deg = 180\nresolution_deg = 0.5\n"
         "[mount]\nx_m = 0.16\ny_m = 0\nz_m = 0.45\npitch_deg = 15\n[filter]\nrange_gate = " +
         (gates ? "true" : "false") + "\nheight_gate = " + (gates ? "true" : "false") + "\n";
}

}  // namespace teamscan::test
