// Voxel grid of points → vertical-surface line features (surface_grid.hpp).
#include "groundstation/registration/surface_grid.hpp"

#include <algorithm>
#include <cmath>

#include <Eigen/Eigenvalues>

namespace teamscan::registration {
namespace {

constexpr std::int64_t kBias = 1 << 20;  // 21 bits per axis (FlatKeyMap keys)

std::int64_t cell(double v, double size) { return static_cast<std::int64_t>(std::floor(v / size)) + kBias; }

bool in_range(std::int64_t i) { return i >= 0 && i < 2 * kBias; }

std::uint64_t pack(std::int64_t ix, std::int64_t iy, std::int64_t iz) {
  return (static_cast<std::uint64_t>(ix) << 42) | (static_cast<std::uint64_t>(iy) << 21) | static_cast<std::uint64_t>(iz);
}

}  // namespace

bool SurfaceGrid::add(const Vec3& p) {
  if (!(p.z >= options_.floor_band_m) || !std::isfinite(p.x) || !std::isfinite(p.y)) return false;
  const std::int64_t ix = cell(p.x, options_.voxel_m), iy = cell(p.y, options_.voxel_m), iz = cell(p.z, options_.voxel_m);
  if (!in_range(ix) || !in_range(iy) || !in_range(iz)) return false;
  bool inserted = false;
  Voxel& v = voxels_.get_or_insert(pack(ix, iy, iz), Voxel{}, &inserted);
  if (v.n >= options_.voxel_cap) return false;
  const Eigen::Vector3d q{p.x, p.y, p.z};
  if (v.n == 0) v.origin = q;
  const Eigen::Vector3d d = q - v.origin;
  v.sum += d;
  v.scatter += d * d.transpose();
  ++v.n;
  v.verdict = Verdict::kStale;
  ++points_;
  return true;
}

void SurfaceGrid::clear() {
  voxels_.clear();
  points_ = 0;
}

void SurfaceGrid::features(std::vector<LineFeature>& out) const {
  out.clear();
  struct Candidate {
    std::uint64_t column;
    LineFeature f;
  };
  // A voxel too thin to be a surface on its own (one laser stripe across it) but lying along a
  // horizontal line: a tilted laser's stripe on a wall, or on the ceiling. The stripes of one column
  // are pooled; the pool of a wall spans its heights (a vertical plane), a ceiling's does not.
  struct Stripe {
    std::uint64_t column;
    double n;
    Eigen::Vector3d mean;
    Eigen::Matrix3d scatter;  // about `mean`, summed (n · covariance)
  };
  std::vector<Candidate> candidates;
  std::vector<Stripe> stripes;
  candidates.reserve(voxels_.size() / 2);
  const double min_extent2 = options_.min_extent_m * options_.min_extent_m;
  // The plane test of a scatter (covariance `cov`) whose mean is `mean`: a feature in `candidates`.
  auto vertical_surface = [&](std::uint64_t column, const Eigen::Matrix3d& cov, const Eigen::Vector3d& mean, double n) {
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es;
    es.computeDirect(cov);
    const Eigen::Vector3d ev = es.eigenvalues();  // ascending
    if (!(ev(1) >= min_extent2) || ev(0) > options_.max_flatness * ev(1)) return false;
    const Eigen::Vector3d normal = es.eigenvectors().col(0);
    if (std::abs(normal.z()) > options_.max_normal_z) return false;
    const double h = std::hypot(normal.x(), normal.y());
    candidates.push_back({column, {mean.x(), mean.y(), normal.x() / h, normal.y() / h, static_cast<float>(n)}});
    return true;
  };
  voxels_.for_each([&](std::uint64_t key, const Voxel& v) {
    if (v.n < options_.min_points) return;
    const double n = v.n;
    const Eigen::Vector3d mean_rel = v.sum / n;
    const Eigen::Matrix3d cov = v.scatter / n - mean_rel * mean_rel.transpose();
    if (!options_.planar_scans && v.verdict != Verdict::kStale) {
      // The verdict of the last call (the voxel has not changed since): no eigen-decomposition.
      const Eigen::Vector3d mean = v.origin + mean_rel;
      if (v.verdict == Verdict::kSurface)
        candidates.push_back({key >> 21, {mean.x(), mean.y(), v.surface_nx, v.surface_ny, static_cast<float>(n)}});
      else if (v.verdict == Verdict::kStripe)
        stripes.push_back({key >> 21, n, mean, cov * n});
      return;
    }
    if (options_.planar_scans) {
      Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> es2;
      es2.computeDirect(cov.topLeftCorner<2, 2>());
      const Eigen::Vector2d ev2 = es2.eigenvalues();
      if (!(ev2(1) >= min_extent2) || ev2(0) > options_.max_flatness * ev2(1)) return;
      const Eigen::Vector2d n2 = es2.eigenvectors().col(0).normalized();
      const Eigen::Vector3d mean = v.origin + mean_rel;
      candidates.push_back({key >> 21, {mean.x(), mean.y(), n2.x(), n2.y(), static_cast<float>(v.n)}});
      return;
    }
    const Eigen::Vector3d mean = v.origin + mean_rel;
    v.verdict = Verdict::kNone;
    if (vertical_surface(key >> 21, cov, mean, n)) {
      v.verdict = Verdict::kSurface;
      v.surface_nx = candidates.back().f.nx;
      v.surface_ny = candidates.back().f.ny;
      return;
    }
    if (!options_.pool_stripes) return;
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es;
    es.computeDirect(cov);
    const Eigen::Vector3d ev = es.eigenvalues();
    const Eigen::Vector3d along = es.eigenvectors().col(2);
    if (ev(1) < min_extent2 && ev(2) >= min_extent2 && std::abs(along.z()) <= options_.max_stripe_slope) {
      stripes.push_back({key >> 21, n, mean, cov * n});
      v.verdict = Verdict::kStripe;
    }
  });
  if (!stripes.empty()) {
    std::sort(stripes.begin(), stripes.end(), [](const Stripe& a, const Stripe& b) { return a.column < b.column; });
    for (std::size_t i = 0; i < stripes.size();) {
      std::size_t j = i;
      double n = 0;
      Eigen::Vector3d mean = Eigen::Vector3d::Zero();
      for (; j < stripes.size() && stripes[j].column == stripes[i].column; ++j) {
        n += stripes[j].n;
        mean += stripes[j].n * stripes[j].mean;
      }
      if (j - i >= 2) {
        mean /= n;
        Eigen::Matrix3d scatter = Eigen::Matrix3d::Zero();
        for (std::size_t k = i; k < j; ++k) {
          const Eigen::Vector3d d = stripes[k].mean - mean;
          scatter += stripes[k].scatter + stripes[k].n * d * d.transpose();
        }
        (void)vertical_surface(stripes[i].column, scatter / n, mean, n);
      }
      i = j;
    }
  }
  std::sort(candidates.begin(), candidates.end(), [](const Candidate& a, const Candidate& b) { return a.column < b.column; });
  // Merge the voxels of one column (the same wall at several heights) whose normals agree.
  for (std::size_t i = 0; i < candidates.size();) {
    std::size_t j = i;
    while (j < candidates.size() && candidates[j].column == candidates[i].column) ++j;
    const std::size_t first_out = out.size();
    for (std::size_t k = i; k < j; ++k) {
      const LineFeature& f = candidates[k].f;
      bool merged = false;
      for (std::size_t m = first_out; m < out.size() && !merged; ++m) {
        LineFeature& g = out[m];
        const double dot = f.nx * g.nx + f.ny * g.ny;
        if (std::abs(dot) < 0.8) continue;
        const double s = dot < 0 ? -1.0 : 1.0, wf = f.weight, wg = g.weight, w = wf + wg;
        g.x_m = (g.x_m * wg + f.x_m * wf) / w;
        g.y_m = (g.y_m * wg + f.y_m * wf) / w;
        const double nx = g.nx * wg + s * f.nx * wf, ny = g.ny * wg + s * f.ny * wf, nn = std::hypot(nx, ny);
        g.nx = nx / nn;
        g.ny = ny / nn;
        g.weight = static_cast<float>(w);
        merged = true;
      }
      if (!merged) out.push_back(f);
    }
    i = j;
  }
}

}  // namespace teamscan::registration
