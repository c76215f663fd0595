// Sparse voxel map of the fused cloud (PAPER_NOTES eqs. 2–3): only occupied voxels are stored, each
// with its point count; every (x, y) column keeps its lowest occupied z for the visibility filter.
// Incremental (insert as scans arrive) and batch (insert a whole cloud) paths share one code path.
#pragma once

#include <cstddef>
#include <cstdint>
#include <optional>
#include <span>

#include "common/flat_key_map.hpp"

namespace teamscan::mapping {

// A point of the fused cloud in the map frame, metres.
struct MapPoint {
  float x = 0, y = 0, z = 0;
};

// Integer voxel index: floor(coordinate / resolution) per axis (PAPER_NOTES eq. 2), z from the grid origin.
struct VoxelKey {
  std::int32_t x = 0, y = 0, z = 0;
  friend constexpr bool operator==(VoxelKey, VoxelKey) = default;
};

// The voxel of `p` on a grid of edge 1 / inverse_resolution, z counted from origin_z_m (NaN and huge
// values land beyond the index range: VoxelMap::in_range rejects them).
[[nodiscard]] VoxelKey voxel_key(const MapPoint& p, double inverse_resolution, double origin_z_m = 0.0);

class VoxelMap {
 public:
  // Each index is packed into 21 bits, so the map spans ±2^20 voxels per axis (±52 km at 0.05 m).
  static constexpr std::int32_t kIndexLimit = 1 << 20;

  // `origin_z_m` shifts the grid vertically: voxel z index = floor((z − origin_z_m) / resolution).
  // The paper's grid starts at the map origin (0); where the floor falls relative to a voxel boundary
  // decides whether floor noise straddles two voxels (see docs/evaluation.md, visibility filter).
  explicit VoxelMap(double resolution_m, double origin_z_m = 0.0);

  [[nodiscard]] double resolution_m() const { return resolution_m_; }
  [[nodiscard]] double origin_z_m() const { return origin_z_m_; }
  [[nodiscard]] VoxelKey key_of(const MapPoint& p) const;

  // Adds one point (eq. 2: V[key] += 1). Points beyond the index range are counted and ignored.
  void insert(const MapPoint& p);
  // Batch path: reserves for the cloud first, then inserts every point.
  void insert(std::span<const MapPoint> points);

  // Count of points in the voxel, 0 for a free voxel.
  [[nodiscard]] std::uint32_t count(VoxelKey key) const;
  [[nodiscard]] std::uint32_t count_at(const MapPoint& p) const { return count(key_of(p)); }
  // Lowest occupied voxel z index of the column (x, y), if any.
  [[nodiscard]] std::optional<std::int32_t> column_lowest_z(std::int32_t x, std::int32_t y) const;

  [[nodiscard]] std::size_t occupied_voxels() const { return voxels_.size(); }
  [[nodiscard]] std::size_t occupied_columns() const { return columns_.size(); }
  [[nodiscard]] std::uint64_t points() const { return points_; }
  [[nodiscard]] std::uint64_t rejected_points() const { return rejected_; }
  // Mean μ and population standard deviation σ of the counts over occupied voxels (eq. 3).
  [[nodiscard]] double mean_count() const;
  [[nodiscard]] double stddev_count() const;
  // Heap bytes held by the voxel and column tables.
  [[nodiscard]] std::size_t memory_bytes() const { return voxels_.memory_bytes() + columns_.memory_bytes(); }

  void clear();

  template <class F>  // f(VoxelKey, count)
  void for_each_voxel(F&& f) const {
    voxels_.for_each([&](std::uint64_t packed, std::uint32_t c) { f(unpack(packed), c); });
  }

  [[nodiscard]] static std::uint64_t pack(VoxelKey k);
  [[nodiscard]] static VoxelKey unpack(std::uint64_t packed);
  // Within ±kIndexLimit on every axis (what pack() can hold).
  [[nodiscard]] static bool in_range(VoxelKey k);

 private:

  double resolution_m_;
  double origin_z_m_;
  double inverse_resolution_;
  FlatKeyMap<std::uint32_t> voxels_;   // packed (x, y, z) -> count
  FlatKeyMap<std::int32_t> columns_;   // packed (x, y, 0) -> lowest occupied z
  std::uint64_t points_ = 0;
  std::uint64_t rejected_ = 0;
  // Running sums for eq. 3 without a pass over the map: Σc and Σc² over occupied voxels.
  std::uint64_t sum_counts_ = 0;
  std::uint64_t sum_counts_sq_ = 0;
};

}  // namespace teamscan::mapping
