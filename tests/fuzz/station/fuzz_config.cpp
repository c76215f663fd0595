// Fuzz target of the ground-station config parser (groundstation/station/config.hpp): any bytes give a
// config or a message naming a key, never a crash. The seed corpus holds the deploy/ example and broken
// variants.
#include <cstddef>
#include <cstdint>
#include <string>

#include "groundstation/station/config.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text{reinterpret_cast<const char*>(data), size};
  teamscan::station::GroundStationConfig config;
  teamscan::station::ConfigError error;
  if (teamscan::station::parse_groundstation_config(text, "fuzz.toml", config, error)) {
    // A config that passed the checks is usable as-is: a known method, sane intervals.
    const teamscan::station::FusionOptions& f = config.fusion;
    if (f.core.method.empty() || !(f.map_resolution_m > 0.0) || f.write_interval.count() < 0) __builtin_trap();
    for (const auto& m : config.ros2.laser_mounts)
      if (m.robot_id < 1 || m.robot_id > 32) __builtin_trap();
  } else if (error.message.empty()) {
    __builtin_trap();  // a refusal always says why
  }
  return 0;
}
