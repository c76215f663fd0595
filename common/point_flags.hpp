// The one point-flag vocabulary: per-beam flags from the scan decoder, per-point flags on the wire
// (teamscan/scan, idl/teamscan.idl POINT_*) and per-point flags in the data set (PCD field `flags`,
// docs/formats.md), and the one mapping between wire and data-set flags. Header-only, firmware-clean.
#pragma once

#include <cstdint>

namespace teamscan {

// Per-beam status from the scan decoder (input to the geometry). The LMS reserved distance codes
// (PROTOCOLS.md 2.7: 0x1FFF not valid, 0x1FFD overflow, 0x1FFB S/N too small, ...) map to kBeamInvalid;
// 0x1FFE and the dazzle bit 15 (measuring mode 0x00) map to kBeamDazzled (drivers/lms200 beam_flags).
inline constexpr std::uint8_t kBeamInvalid = 1u << 0;
inline constexpr std::uint8_t kBeamDazzled = 1u << 1;

// Per-point flags on the wire (the same bits as idl/teamscan.idl POINT_*). kPointInvalid, kPointDazzled
// and kPointNoPose mean the point has no trustworthy position.
inline constexpr std::uint16_t kPointDirectionFiltered = 1u << 0;  // direction filter (paper eq. 7): a teammate
inline constexpr std::uint16_t kPointInvalid = 1u << 1;      // no echo / reserved distance code / range 0
inline constexpr std::uint16_t kPointDazzled = 1u << 2;      // the scanner reported dazzling
inline constexpr std::uint16_t kPointPositionFiltered = 1u << 3;  // position filter (paper eq. 6), ground station
inline constexpr std::uint16_t kPointOutOfRange = 1u << 4;   // range > max_range_mm (position still computed)
inline constexpr std::uint16_t kPointNoPose = 1u << 5;       // odometry could not place the beam's time
inline constexpr std::uint16_t kPointTeamStale = 1u << 6;    // direction filter ran widened on, or skipped for, a stale team state
inline constexpr std::uint16_t kPointUnplaced = kPointInvalid | kPointDazzled | kPointNoPose;

// Per-point flags in the data set (PCD field `flags`). Other bit positions than the wire's: data sets
// already written keep their meaning.
namespace point_flags {
inline constexpr std::uint16_t kInvalid = 1u << 0;             // reserved/no-return code, no 3-D point
inline constexpr std::uint16_t kDazzled = 1u << 1;             // LMS dazzle code or dazzle bit
inline constexpr std::uint16_t kOutOfRange = 1u << 2;          // beyond the configured or sensor max range
inline constexpr std::uint16_t kDirectionFiltered = 1u << 3;   // removed by the onboard direction filter
inline constexpr std::uint16_t kFieldA = 1u << 4;              // LMS field A bit (informational)
inline constexpr std::uint16_t kFieldB = 1u << 5;              // LMS field B bit (informational)
inline constexpr std::uint16_t kTeamStale = 1u << 6;           // the direction filter ran on a stale team state
}  // namespace point_flags

// Wire flag -> data-set flag, one row per wire flag. Not carried into the data set:
// kPointPositionFiltered (a ground-station decision, recomputed by whoever reads the data set).
// kPointNoPose becomes kInvalid: like an invalid beam, the point has no 3-D position.
struct PointFlagPair {
  std::uint16_t wire;
  std::uint16_t dataset;
};
inline constexpr PointFlagPair kPointFlagPairs[] = {
    {kPointDirectionFiltered, point_flags::kDirectionFiltered},
    {kPointInvalid, point_flags::kInvalid},
    {kPointDazzled, point_flags::kDazzled},
    {kPointPositionFiltered, 0},
    {kPointOutOfRange, point_flags::kOutOfRange},
    {kPointNoPose, point_flags::kInvalid},
    {kPointTeamStale, point_flags::kTeamStale},
};

// The data set's flags of a point received with wire flags `wire` (unknown wire bits are dropped).
[[nodiscard]] constexpr std::uint16_t dataset_flags_from_wire(std::uint16_t wire) {
  std::uint16_t f = 0;
  for (const PointFlagPair& p : kPointFlagPairs) {
    if ((wire & p.wire) != 0) f = static_cast<std::uint16_t>(f | p.dataset);
  }
  return f;
}

}  // namespace teamscan
