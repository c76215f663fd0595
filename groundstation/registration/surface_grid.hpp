// Vertical surfaces for scan-to-map registration: 3-D points go into a voxel grid (count, mean,
// scatter per voxel); voxels whose points lie on a near-vertical plane (walls, furniture sides) become
// 2-D line features in the floor plane (position + unit normal). The floor, the ceiling and table tops
// are horizontal and say nothing about x, y, yaw: they never become features. Used for the reference
// (the fused map's points) and for a robot's recent points alike.
#pragma once

#include <cstdint>
#include <memory>
#include <span>
#include <vector>

#include <Eigen/Core>

#include "common/pose.hpp"
#include "common/flat_key_map.hpp"

namespace teamscan::registration {

struct SurfaceOptions {
  double voxel_m = 0.10;            // voxel edge
  std::uint32_t voxel_cap = 48;     // a voxel takes no more points after this many: the first
                                    // observations stay, later passes cannot smear or drag them
  std::uint32_t min_points = 8;     // a voxel with fewer points gives no feature
  double max_normal_z = 0.35;       // |n_z| of a vertical surface (≤ 20° from vertical)
  double max_flatness = 0.12;       // λ_min / λ_mid of the voxel's scatter: a plane, not a blob
  double min_extent_m = 0.02;       // √λ_mid: the points span a surface, not one laser stripe (a line
                                    // whose normal could point anywhere round it)
  double floor_band_m = 0.06;       // points below this height are floor and never enter
  // A tilted laser draws stripes: a voxel crossed by one stripe is a line, too thin for a normal.
  // The stripes of one voxel column (lines within max_stripe_slope of horizontal) are pooled; a pool
  // that passes the surface test (the stripes at several heights of a wall) is a feature.
  bool pool_stripes = true;
  double max_stripe_slope = 0.5;    // |z| of a stripe's unit direction
  // Horizontal 2-D lasers (every point at the mount's height): a voxel's surface is a line in the
  // floor plane; its normal comes from the points' spread in x, y alone.
  bool planar_scans = false;
};

// One feature: a piece of vertical surface seen from above, in the map (or odometry-map) frame.
struct LineFeature {
  double x_m = 0, y_m = 0;          // a point on the line (voxel mean)
  double nx = 0, ny = 0;            // unit normal in the floor plane
  float weight = 1;                 // points behind it (capped)
};

// One reference column whose features changed (SurfaceGrid::take_changes): its features are
// features[begin, end) of the call's output (none: the column gives no feature any more).
struct ColumnChange {
  std::uint64_t column = 0;  // (ix << 21) | iy of the voxel grid
  std::uint32_t begin = 0, end = 0;
};

class SurfaceGrid {
 public:
  // `track_columns`: remember which voxel columns changed since the last take_changes() (the team's
  // reference, updated in proportion to what changed; a window grid, rebuilt per match, does not).
  explicit SurfaceGrid(SurfaceOptions options = {}, bool track_columns = false)
      : options_{options}, track_columns_{track_columns} {}

  // Adds one point (metres). Returns false if it was not taken (floor band, full voxel).
  bool add(const Vec3& p);
  void clear();
  // The line features: one per vertical-surface voxel column (voxels of one column whose normals
  // agree are merged; a corner column may give two). Columns in key order, the voxels of a column
  // merged bottom to top, the column's pooled stripes last: the same features, in the same order, as
  // take_changes() gives column by column.
  // Each voxel's verdict is kept for the next call (Voxel::verdict, a cache: not thread-safe).
  void features(std::vector<LineFeature>& out) const;
  // With track_columns: the features of every column a voxel of which reached min_points or took a
  // point since the last call (columns in key order; a column's features exactly as features() gives
  // them), and forgets them. Cost in proportion to the changed columns, not to the grid.
  void take_changes(std::vector<ColumnChange>& columns, std::vector<LineFeature>& features);
  [[nodiscard]] std::size_t voxels() const { return voxels_; }
  [[nodiscard]] std::size_t columns() const { return columns_.size(); }
  [[nodiscard]] std::size_t changed_columns() const { return changed_.size(); }
  [[nodiscard]] std::uint64_t points() const { return points_; }
  [[nodiscard]] const SurfaceOptions& options() const { return options_; }

 private:
  // What features() made of a voxel the last time, kept until a point is added to it: a voxel's
  // verdict needs an eigen-decomposition, and between two updates of a team's reference only the
  // voxels the retired scans touched change (a full one, voxel_cap points, never changes again).
  enum class Verdict : std::uint8_t { kStale, kNone, kSurface, kStripe };
  struct Voxel {
    std::uint32_t n = 0;
    mutable Verdict verdict = Verdict::kStale;
    bool queued = false;  // track_columns: its column is in changed_ since it last changed
    std::uint32_t iz = 0;
    std::uint32_t up = kNone;  // track_columns: the next voxel up its column with ≥ min_points, or kNone
    mutable double surface_nx = 0, surface_ny = 0;  // kSurface: the unit normal in the floor plane
    Eigen::Vector3d origin = Eigen::Vector3d::Zero();  // first point: sums are taken relative to it
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    Eigen::Matrix3d scatter = Eigen::Matrix3d::Zero();
  };
  // track_columns: a column's lowest voxel with ≥ min_points (its voxels are linked upwards: Voxel::up),
  // and whether it is in changed_.
  struct Column {
    std::uint32_t lowest = kNone;
    bool changed = false;
  };
  struct KeyedVoxel {
    std::uint64_t key;
    const Voxel* v;
  };
  struct Stripe {
    double n;
    Eigen::Vector3d mean;
    Eigen::Matrix3d scatter;  // about `mean`, summed (n · covariance)
  };
  static constexpr std::uint32_t kNone = ~std::uint32_t{0};
  // Voxels live in chunks that never move: the hash map holds 4-byte indices, so its growth copies 12
  // bytes per voxel, not the voxel: with the voxels in the map, a doubling of a team's reference stalls
  // the loop for as long as copying every voxel takes.
  static constexpr std::uint32_t kChunkBits = 10;
  [[nodiscard]] Voxel& voxel(std::uint32_t i) { return chunks_[i >> kChunkBits][i & ((1u << kChunkBits) - 1)]; }
  [[nodiscard]] const Voxel& voxel(std::uint32_t i) const { return chunks_[i >> kChunkBits][i & ((1u << kChunkBits) - 1)]; }
  // The features of one column from its voxels (at least min_points each, in key order), appended.
  void column_features(std::span<const KeyedVoxel> voxels, std::vector<LineFeature>& out) const;

  SurfaceOptions options_;
  bool track_columns_ = false;
  FlatKeyMap<std::uint32_t> index_;  // voxel key → voxel index
  std::vector<std::unique_ptr<Voxel[]>> chunks_;  // kept by clear(): a window grid refills them
  std::uint32_t voxels_ = 0;
  FlatKeyMap<Column> columns_;
  std::vector<std::uint64_t> changed_;
  std::uint64_t points_ = 0;
  // Scratch of features() and take_changes() (kept: no allocation per call once grown).
  mutable std::vector<KeyedVoxel> keyed_;
  mutable std::vector<LineFeature> candidates_;
  mutable std::vector<Stripe> stripes_;
};

}  // namespace teamscan::registration
