// `best` (docs/beyond.md): the combination that won on the numbers. A point goes when
//   - it lies in a teammate's body box inflated by the Kalman covariance (tracked, no drift), or
//   - its voxel is void by strict free-space evidence (freespace at best_freespace: 8 passes per hit,
//     every third ray of a scan cast), or
//   - it lies only in the band the odometry drift adds to the box (TrackerOptions::drift_*) AND its
//     voxel was seen empty by the lenient rule (free ≥ max(min_free, drift_band_free_per_hit · hits)).
// The drift band is where a drifting teammate may really be, but also where table tops and walls
// beside its path are: there the map decides (a table top is hit far more often than crossed; a place a
// robot left is crossed by later rays). Each part sees every point of the scan: every point counts its
// hit, every third ray is walked (FreespaceOptions::ray_stride).
#pragma once

#include <memory>
#include <vector>

#include "groundstation/mapping/filter.hpp"
#include "groundstation/mapping/freespace_filter.hpp"
#include "groundstation/mapping/tracked_filter.hpp"

namespace teamscan::mapping {

class BestFilter final : public Filter {
 public:
  BestFilter(TrackedOptions tracked, FreespaceOptions freespace, double drift_band_free_per_hit);
  [[nodiscard]] std::string method() const override { return "best"; }
  [[nodiscard]] FilterParams params() const override;
  // Bits: kCore (in the box without the drift band), kBand (only in the band the drift adds).
  static constexpr std::uint8_t kCore = 1, kBand = 2;
  void point_bits(const ScanView& scan, std::span<std::uint8_t> bits) const override;
  void insert(const ScanView& scan, std::span<const std::uint8_t> bits) override { freespace_.insert(scan, bits); }
  void decide(std::span<const MapPoint> points, std::span<const std::uint8_t> bits,
              std::span<std::uint8_t> removed) const override;
  void reset() override { freespace_.reset(); }
  [[nodiscard]] std::size_t memory_bytes() const override { return freespace_.memory_bytes(); }
  [[nodiscard]] const FreespaceGrid& grid() const { return freespace_.grid(); }

 private:
  TrackedFilter core_;   // box without the drift band
  TrackedFilter outer_;  // box with it
  FreespaceFilter freespace_;
  double drift_band_free_per_hit_;
  std::uint32_t min_free_;
};

// The default `best` with the options in `options` (see docs/beyond.md).
[[nodiscard]] std::unique_ptr<Filter> make_best(const MethodOptions& options);

}  // namespace teamscan::mapping
