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
  for (std::uint16_t i = 0; i < t.count; ++i) {
    // The same mapping as the simulator's receiver (sim/receiver.cpp), so that the daemon's flags equal
    // the data set's: a reserved code is invalid (the dazzle code also dazzled); the dazzle bit on a
    // distance is dazzled.
    const lms200::BeamInvalid why = t.invalid[i];
    std::uint8_t f = 0;
    if (why == lms200::BeamInvalid::dazzled || lms200::dazzle(t.mode, t.flags[i])) f |= kBeamDazzled;
    if (why != lms200::BeamInvalid::none) f |= kBeamInvalid;
    beam_flags[i] = f;
  }
  out = ScanBeams{stamp, variant, std::span<const std::uint32_t>(t.ranges_mm.data(), t.count),
                  std::span<const std::uint8_t>(beam_flags.data(), t.count)};
  return true;
}

}  // namespace teamscan::onboard
