// RANSAC plane fit on Eigen for the floor-plane metrics (PAPER_NOTES "The metrics"): minimal
// 3-point samples, inlier count within a threshold, least-squares refit on the best inliers, inliers
// re-selected with the refit plane (as PCL SACSegmentation with optimised coefficients does).
#pragma once

#include <cstdint>
#include <limits>
#include <span>
#include <vector>

#include <Eigen/Core>

#include "groundstation/mapping/voxel_map.hpp"

namespace teamscan::mapping {

// Which plane the signed error is measured against (PAPER_NOTES: mean of ax+by+cz−d over the inliers).
// The least-squares refit passes through its inliers' centroid, so its signed mean is ~0 by
// construction; the paper's signed error only carries information against the RANSAC model itself.
enum class PlaneErrorReference : std::uint8_t { sample = 0, refit = 1 };

struct RansacOptions {
  double threshold_m = 0.02;     // inlier distance
  int iterations = 500;
  std::uint64_t seed = 1;
  // Floor constraint (≤ 0 disables): candidate normals within this angle of +z.
  double max_tilt_deg = 15.0;
  // Floor constraint (NaN/inf disables): candidate planes whose height d (z-intercept for a level
  // plane) exceeds this are skipped, so the ceiling never wins over the floor.
  double max_height_m = 0.5;
  PlaneErrorReference error_reference = PlaneErrorReference::sample;
};

// Plane a·x + b·y + c·z − d = 0 with (a, b, c) a unit normal, c ≥ 0 when not vertical.
struct Plane {
  Eigen::Vector3d normal = Eigen::Vector3d::UnitZ();
  double d = 0.0;
  [[nodiscard]] double signed_distance(const MapPoint& p) const {
    return normal.x() * p.x + normal.y() * p.y + normal.z() * p.z - d;
  }
};

struct PlaneFit {
  bool found = false;
  Plane sample_plane;                 // the best minimal-sample model
  Plane plane;                        // least-squares refit on its inliers
  std::size_t points = 0;             // cloud size
  std::size_t inliers = 0;            // of `plane`
  double inlier_share = 0.0;          // inliers / points
  double signed_mean_error_m = 0.0;   // PAPER_NOTES: mean of ax+by+cz−d over the inliers
  double mean_abs_error_m = 0.0;
  double rms_error_m = 0.0;
};

// Fits the dominant plane (under the floor constraints) to the points with mask[i] == 0 (all
// points when `removed` is empty). Deterministic for a seed.
[[nodiscard]] PlaneFit fit_plane_ransac(std::span<const MapPoint> points, const RansacOptions& options,
                                       std::span<const std::uint8_t> removed = {});

// Least-squares plane through points (smallest eigenvector of the scatter matrix).
[[nodiscard]] Plane fit_plane_least_squares(std::span<const MapPoint> points, std::span<const std::size_t> indices);

}  // namespace teamscan::mapping
