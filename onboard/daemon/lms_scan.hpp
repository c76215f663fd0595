// A decoded LMS telegram (drivers/lms200 ScanTelegram) as the geometry's input (common/scan_points
// ScanBeams): ranges in mm, reserved distance codes and the dazzle bit as per-beam flags. Pure and
// allocation-free; header-only so the tests use the daemon's exact adapter.
#pragma once

#include <array>
#include <cstdint>
#include <span>

#include "common/capacities.hpp"
#include "common/scan_points.hpp"
#include "drivers/lms200/scan.hpp"

namespace teamscan::onboard {

// Fills `beam_flags` and returns the beams of `t` stamped `stamp` (end of sweep). False when the
// telegram does not carry one full scan of `variant` (partial scan, another variant): the geometry
// would place its beams at wrong angles, so the daemon drops it and counts it.
[[nodiscard]] inline bool to_scan_beams(const lms200::ScanTelegram& t, Time stamp, LaserVariant variant,
                                        std::array<std::uint8_t, kMaxBeams>& beam_flags, ScanBeams& out) {
  if (t.partial || t.count != variant.beams() || t.count > kMaxBeams) return false;
  // The simulator's receiver uses the same lms200::beam_flags, so the daemon's flags equal the data set's.
  for (std::uint16_t i = 0; i < t.count; ++i) beam_flags[i] = lms200::beam_flags(t, i);
  out = ScanBeams{stamp, variant, std::span<const std::uint32_t>(t.ranges_mm.data(), t.count),
                  std::span<const std::uint8_t>(beam_flags.data(), t.count)};
  return true;
}

}  // namespace teamscan::onboard
