// `best` (issue 7, docs/beyond.md): the combination that won on the numbers. A point goes when
//   - it lies in a teammate's body box inflated by the Kalman covariance (tracked, no drift), or
//   - its voxel is void by strict free-space evidence (freespace at best_freespace: 8 passes per hit), or
//   - it lies only in the band the odometry drift adds to the box (TrackerOptions::drift_*) AND its
//     voxel was seen empty by the lenient rule (free ≥ max(min_free, drift_band_free_per_hit · hits)).
// The drift band is where a drifting teammate may really be, but also where table tops and walls
// beside its path are: there the map decides (a table top is hit far more often than crossed; a place a
// robot left is crossed by later rays). Each part sees every point of the scan, so the free-space
// evidence is built from all rays.
#pragma once

#include <memory>
#include <vector>

#include "groundstation/mapping/filter.hpp"
#include "groundstation/mapping/freespace_filter.hpp"
#include "groundstation/mapping/tracked_filter.hpp"

namespace teamscan::mapping {

// Any-part union of filters (kept for custom combinations).
class UnionFilter final : public Filter {
 public:
  UnionFilter(std::string method, std::vector<std::unique_ptr<Filter>> parts)
      : method_{std::move(method)}, parts_{std::move(parts)} {}
  [[nodiscard]] std::string method() const override { return method_; }
  [[nodiscard]] FilterParams params() const override;
  void observe(const ScanView& scan) override {
    for (auto& p : parts_) p->observe(scan);
  }
  void classify(const ScanView& scan, std::span<std::uint8_t> removed) const override;
  void reset() override {
    for (auto& p : parts_) p->reset();
  }

 private:
  std::string method_;
  std::vector<std::unique_ptr<Filter>> parts_;
};

class BestFilter final : public Filter {
 public:
  BestFilter(TrackedOptions tracked, FreespaceOptions freespace, double drift_band_free_per_hit);
  [[nodiscard]] std::string method() const override { return "best"; }
  [[nodiscard]] FilterParams params() const override;
  void observe(const ScanView& scan) override { freespace_.observe(scan); }
  void classify(const ScanView& scan, std::span<std::uint8_t> removed) const override;
  void reset() override { freespace_.reset(); }

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
