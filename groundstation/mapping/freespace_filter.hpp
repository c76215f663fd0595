// `freespace` (issue 7, docs/beyond.md): free-space ray casting through a sparse voxel grid with the
// Amanatides–Woo traversal. Each voxel counts the points that hit it and the rays that passed through
// it; a point is transient when its voxel was seen empty (DUFOMap's void evidence, ANCHORS.md §2) often
// enough. observe() is the same code live and offline; classify() only reads.
#pragma once

#include <cstdint>
#include <span>

#include "groundstation/mapping/beyond_options.hpp"
#include "groundstation/mapping/filter.hpp"
#include "groundstation/mapping/flat_key_map.hpp"

namespace teamscan::mapping {

// One voxel's evidence: points that fell in it, rays that crossed it (both saturate).
struct FreeCell {
  std::uint32_t hits = 0;
  std::uint32_t free = 0;
};

class FreespaceGrid {
 public:
  explicit FreespaceGrid(const FreespaceOptions& options);
  [[nodiscard]] VoxelKey key_of(double x, double y, double z) const;
  // Folds one scan in: every point's voxel +1 hit, every ray's traversed voxels +1 free.
  void insert_scan(const Vec3& origin_m, std::span<const MapPoint> points);
  // Marks the voxels of one ray (origin → hit, shortened as the options say) as passed.
  void cast_ray(const Vec3& origin_m, const MapPoint& hit);
  [[nodiscard]] FreeCell cell(VoxelKey key) const;
  [[nodiscard]] bool transient(const MapPoint& p) const;
  [[nodiscard]] std::size_t voxels() const { return cells_.size(); }
  [[nodiscard]] std::uint64_t traversed() const { return traversed_; }
  [[nodiscard]] std::size_t memory_bytes() const { return cells_.memory_bytes(); }
  void clear();

 private:
  FreespaceOptions options_;
  double inverse_resolution_;
  FlatKeyMap<FreeCell> cells_;
  std::uint64_t traversed_ = 0;
};

class FreespaceFilter final : public Filter {
 public:
  explicit FreespaceFilter(FreespaceOptions options) : options_{options}, grid_{options} {}
  [[nodiscard]] std::string method() const override { return "freespace"; }
  [[nodiscard]] FilterParams params() const override;
  void observe(const ScanView& scan) override { grid_.insert_scan(scan.origin_m, scan.points); }
  void classify(const ScanView& scan, std::span<std::uint8_t> removed) const override;
  void reset() override { grid_.clear(); }
  [[nodiscard]] const FreespaceGrid& grid() const { return grid_; }

 private:
  FreespaceOptions options_;
  FreespaceGrid grid_;
};

}  // namespace teamscan::mapping
