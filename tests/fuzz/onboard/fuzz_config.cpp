// Fuzz target of the onboard config parser (onboard/core/config.hpp): any bytes give a config or a
// message naming a key, never a crash. The seed corpus holds the deploy/ examples and broken variants.
#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>

#include "onboard/core/config.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  std::string message;
  const std::string_view text{reinterpret_cast<const char*>(data), size};
  const auto config = teamscan::onboard::parse_onboard_config(text, message);
  if (config.ok()) {
    // A config that passed the checks must be usable as-is.
    (void)teamscan::onboard::describe(config.value());
    (void)config->mount.robot_from_laser();
    if (config->robot_id < 1 || config->robot_id > 32 || config->lms_variant.beams() > teamscan::kMaxBeams) __builtin_trap();
  } else if (message.empty()) {
    __builtin_trap();  // a refusal always says why
  }
  return 0;
}
