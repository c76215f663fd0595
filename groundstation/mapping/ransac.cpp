// RANSAC floor-plane fit (PAPER_NOTES "The metrics"); see ransac.hpp.
#include "groundstation/mapping/ransac.hpp"

#include <cmath>
#include <random>

#include <Eigen/Dense>

#include "common/units.hpp"

namespace teamscan::mapping {
namespace {

Eigen::Vector3d to_eigen(const MapPoint& p) { return {p.x, p.y, p.z}; }

// Orientation convention: normal up (c > 0); for a vertical plane, the first non-zero of (a, b) > 0.
Plane oriented(Eigen::Vector3d n, double d) {
  bool flip = n.z() < 0.0;
  if (n.z() == 0.0) flip = n.x() < 0.0 || (n.x() == 0.0 && n.y() < 0.0);
  if (flip) {
    n = -n;
    d = -d;
  }
  return {n, d};
}

bool acceptable(const Plane& plane, const RansacOptions& options) {
  if (options.max_tilt_deg > 0.0 && plane.normal.z() < std::cos(deg_to_rad(options.max_tilt_deg))) return false;
  if (std::isfinite(options.max_height_m) && plane.normal.z() > 0.0 && plane.d / plane.normal.z() > options.max_height_m)
    return false;
  return true;
}

}  // namespace

Plane fit_plane_least_squares(std::span<const MapPoint> points, std::span<const std::size_t> indices) {
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
  for (std::size_t i : indices) centroid += to_eigen(points[i]);
  centroid /= static_cast<double>(indices.size());
  Eigen::Matrix3d scatter = Eigen::Matrix3d::Zero();
  for (std::size_t i : indices) {
    const Eigen::Vector3d q = to_eigen(points[i]) - centroid;
    scatter += q * q.transpose();
  }
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> solver(scatter);
  const Eigen::Vector3d n = solver.eigenvectors().col(0).normalized();  // smallest eigenvalue first
  return oriented(n, n.dot(centroid));
}

PlaneFit fit_plane_ransac(std::span<const MapPoint> points, const RansacOptions& options,
                          std::span<const std::uint8_t> removed) {
  PlaneFit fit;
  std::vector<std::size_t> active;
  active.reserve(points.size());
  for (std::size_t i = 0; i < points.size(); ++i)
    if (removed.empty() || !removed[i]) active.push_back(i);
  fit.points = active.size();
  if (active.size() < 3) return fit;

  std::mt19937_64 rng(options.seed);
  std::uniform_int_distribution<std::size_t> pick(0, active.size() - 1);
  std::size_t best_count = 0;
  Plane best;
  for (int it = 0; it < options.iterations; ++it) {
    const Eigen::Vector3d a = to_eigen(points[active[pick(rng)]]);
    const Eigen::Vector3d b = to_eigen(points[active[pick(rng)]]);
    const Eigen::Vector3d c = to_eigen(points[active[pick(rng)]]);
    Eigen::Vector3d n = (b - a).cross(c - a);
    const double norm = n.norm();
    if (norm < 1e-12) continue;  // degenerate (collinear or repeated) sample
    n /= norm;
    const Plane candidate = oriented(n, n.dot(a));
    if (!acceptable(candidate, options)) continue;
    std::size_t count = 0;
    for (std::size_t i : active)
      if (std::abs(candidate.signed_distance(points[i])) <= options.threshold_m) ++count;
    if (count > best_count) {
      best_count = count;
      best = candidate;
    }
  }
  if (best_count < 3) return fit;

  std::vector<std::size_t> inliers;
  auto select = [&](const Plane& plane) {
    inliers.clear();
    for (std::size_t i : active)
      if (std::abs(plane.signed_distance(points[i])) <= options.threshold_m) inliers.push_back(i);
  };
  select(best);
  fit.found = true;
  fit.sample_plane = best;
  fit.plane = fit_plane_least_squares(points, inliers);
  select(fit.plane);
  if (inliers.size() < 3) {  // refit drifted away (cannot happen for a sane threshold): keep the sample
    fit.plane = best;
    select(best);
  }
  fit.inliers = inliers.size();
  fit.inlier_share = static_cast<double>(fit.inliers) / static_cast<double>(fit.points);

  // PAPER_NOTES: error = mean of a·x + b·y + c·z − d over the RANSAC inliers (signed), plus the
  // mean absolute and RMS value, against the plane the options name.
  const Plane& reference = options.error_reference == PlaneErrorReference::sample ? fit.sample_plane : fit.plane;
  select(reference);
  double sum = 0, sum_abs = 0, sum_sq = 0;
  for (std::size_t i : inliers) {
    const double e = reference.signed_distance(points[i]);
    sum += e;
    sum_abs += std::abs(e);
    sum_sq += e * e;
  }
  const double n_in = static_cast<double>(inliers.size());
  fit.signed_mean_error_m = sum / n_in;
  fit.mean_abs_error_m = sum_abs / n_in;
  fit.rms_error_m = std::sqrt(sum_sq / n_in);
  return fit;
}

}  // namespace teamscan::mapping
