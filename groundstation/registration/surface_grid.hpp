// Vertical surfaces for scan-to-map registration: 3-D points go into a voxel grid (count, mean,
// scatter per voxel); voxels whose points lie on a near-vertical plane (walls, furniture sides) become
// 2-D line features in the floor plane (position + unit normal). The floor, the ceiling and table tops
// are horizontal and say nothing about x, y, yaw: they never become features. Used for the reference
// (the fused map's points) and for a robot's recent points alike.
#pragma once

#include <cstdint>
#include <vector>

#include <Eigen/Core>

#include "common/pose.hpp"
#include "groundstation/mapping/flat_key_map.hpp"

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

class SurfaceGrid {
 public:
  explicit SurfaceGrid(SurfaceOptions options = {}) : options_{options} {}

  // Adds one point (metres). Returns false if it was not taken (floor band, full voxel).
  bool add(const Vec3& p);
  void clear();
  // The line features: one per vertical-surface voxel column (voxels of one column whose normals
  // agree are merged; a corner column may give two).
  // Each voxel's verdict is kept for the next call (Voxel::verdict, a cache: not thread-safe).
  void features(std::vector<LineFeature>& out) const;
  [[nodiscard]] std::size_t voxels() const { return voxels_.size(); }
  [[nodiscard]] std::uint64_t points() const { return points_; }
  [[nodiscard]] const SurfaceOptions& options() const { return options_; }

 private:
  // What features() made of a voxel the last time, kept until a point is added to it: a voxel's
  // verdict needs an eigen-decomposition, and between two rebuilds of a team's reference only the
  // voxels the retired scans touched change (a full one, voxel_cap points, never changes again).
  enum class Verdict : std::uint8_t { kStale, kNone, kSurface, kStripe };
  struct Voxel {
    std::uint32_t n = 0;
    mutable Verdict verdict = Verdict::kStale;
    mutable double surface_nx = 0, surface_ny = 0;  // kSurface: the unit normal in the floor plane
    Eigen::Vector3d origin = Eigen::Vector3d::Zero();  // first point: sums are taken relative to it
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    Eigen::Matrix3d scatter = Eigen::Matrix3d::Zero();
  };
  SurfaceOptions options_;
  mapping::FlatKeyMap<Voxel> voxels_;
  std::uint64_t points_ = 0;
};

}  // namespace teamscan::registration
