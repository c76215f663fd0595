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
  const std::uint64_t key = pack(ix, iy, iz);
  std::uint32_t& at = index_.get_or_insert(key, kNone, &inserted);
  if (inserted) {
    if ((voxels_ >> kChunkBits) == chunks_.size()) chunks_.push_back(std::make_unique<Voxel[]>(std::size_t{1} << kChunkBits));
    at = voxels_++;
    voxel(at) = Voxel{};
    voxel(at).iz = static_cast<std::uint32_t>(iz);
  }
  const std::uint32_t vi = at;
  Voxel& v = voxel(vi);
  if (v.n >= options_.voxel_cap) return false;
  const Eigen::Vector3d q{p.x, p.y, p.z};
  if (v.n == 0) v.origin = q;
  const Eigen::Vector3d d = q - v.origin;
  v.sum += d;
  v.scatter += d * d.transpose();
  ++v.n;
  v.verdict = Verdict::kStale;
  ++points_;
  // A voxel counts from min_points on (it joins its column's list then); its column is queued once
  // until take_changes() (later points into the same voxel meanwhile cost nothing more).
  if (track_columns_ && v.n >= options_.min_points && !v.queued) {
    v.queued = true;
    Column& c = columns_.get_or_insert(key >> 21, Column{});
    if (v.n == std::max<std::uint32_t>(options_.min_points, 1)) {  // the first time it counts
      // Into the column's list, bottom to top.
      std::uint32_t* link = &c.lowest;
      while (*link != kNone && voxel(*link).iz < v.iz) link = &voxel(*link).up;
      v.up = *link;
      *link = vi;
    }
    if (!c.changed) {
      c.changed = true;
      changed_.push_back(key >> 21);
    }
  }
  return true;
}

void SurfaceGrid::clear() {
  index_.clear_keep_capacity();  // a window grid is refilled per match to about the same size
  voxels_ = 0;
  columns_.clear();
  changed_.clear();
  points_ = 0;
}

void SurfaceGrid::column_features(std::span<const KeyedVoxel> voxels, std::vector<LineFeature>& out) const {
  // A voxel too thin to be a surface on its own (one laser stripe across it) but lying along a
  // horizontal line: a tilted laser's stripe on a wall, or on the ceiling. The stripes of one column
  // are pooled; the pool of a wall spans its heights (a vertical plane), a ceiling's does not.
  candidates_.clear();
  stripes_.clear();
  const double min_extent2 = options_.min_extent_m * options_.min_extent_m;
  // The plane test of a scatter (covariance `cov`) whose mean is `mean`: a feature in `candidates_`.
  auto vertical_surface = [&](const Eigen::Matrix3d& cov, const Eigen::Vector3d& mean, double n) {
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es;
    es.computeDirect(cov);
    const Eigen::Vector3d ev = es.eigenvalues();  // ascending
    if (!(ev(1) >= min_extent2) || ev(0) > options_.max_flatness * ev(1)) return false;
    const Eigen::Vector3d normal = es.eigenvectors().col(0);
    if (std::abs(normal.z()) > options_.max_normal_z) return false;
    const double h = std::hypot(normal.x(), normal.y());
    candidates_.push_back({mean.x(), mean.y(), normal.x() / h, normal.y() / h, static_cast<float>(n)});
    return true;
  };
  for (const KeyedVoxel& kv : voxels) {
    const Voxel& v = *kv.v;
    // Cached: no surface and no stripe (most of a reference's voxels once evaluated): nothing to do.
    if (!options_.planar_scans && v.verdict == Verdict::kNone) continue;
    const double n = v.n;
    const Eigen::Vector3d mean_rel = v.sum / n;
    const Eigen::Vector3d mean = v.origin + mean_rel;
    if (!options_.planar_scans && v.verdict == Verdict::kSurface) {
      // The verdict of the last call (the voxel has not changed since): no eigen-decomposition.
      candidates_.push_back({mean.x(), mean.y(), v.surface_nx, v.surface_ny, static_cast<float>(n)});
      continue;
    }
    const Eigen::Matrix3d cov = v.scatter / n - mean_rel * mean_rel.transpose();
    if (options_.planar_scans) {
      Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> es2;
      es2.computeDirect(cov.topLeftCorner<2, 2>());
      const Eigen::Vector2d ev2 = es2.eigenvalues();
      if (!(ev2(1) >= min_extent2) || ev2(0) > options_.max_flatness * ev2(1)) continue;
      const Eigen::Vector2d n2 = es2.eigenvectors().col(0).normalized();
      candidates_.push_back({mean.x(), mean.y(), n2.x(), n2.y(), static_cast<float>(v.n)});
      continue;
    }
    if (v.verdict == Verdict::kStripe) {
      stripes_.push_back({n, mean, cov * n});
      continue;
    }
    v.verdict = Verdict::kNone;
    if (vertical_surface(cov, mean, n)) {
      v.verdict = Verdict::kSurface;
      v.surface_nx = candidates_.back().nx;
      v.surface_ny = candidates_.back().ny;
      continue;
    }
    if (!options_.pool_stripes) continue;
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es;
    es.computeDirect(cov);
    const Eigen::Vector3d ev = es.eigenvalues();
    const Eigen::Vector3d along = es.eigenvectors().col(2);
    if (ev(1) < min_extent2 && ev(2) >= min_extent2 && std::abs(along.z()) <= options_.max_stripe_slope) {
      stripes_.push_back({n, mean, cov * n});
      v.verdict = Verdict::kStripe;
    }
  }
  if (stripes_.size() >= 2) {
    double n = 0;
    Eigen::Vector3d mean = Eigen::Vector3d::Zero();
    for (const Stripe& st : stripes_) {
      n += st.n;
      mean += st.n * st.mean;
    }
    mean /= n;
    Eigen::Matrix3d scatter = Eigen::Matrix3d::Zero();
    for (const Stripe& st : stripes_) {
      const Eigen::Vector3d d = st.mean - mean;
      scatter += st.scatter + st.n * d * d.transpose();
    }
    (void)vertical_surface(scatter / n, mean, n);
  }
  // Merge the voxels of the column (the same wall at several heights) whose normals agree.
  const std::size_t first_out = out.size();
  for (const LineFeature& f : candidates_) {
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
}

void SurfaceGrid::features(std::vector<LineFeature>& out) const {
  out.clear();
  keyed_.clear();
  index_.for_each([&](std::uint64_t key, std::uint32_t i) {
    const Voxel& v = voxel(i);
    if (v.n >= options_.min_points) keyed_.push_back({key, &v});
  });
  std::sort(keyed_.begin(), keyed_.end(), [](const KeyedVoxel& a, const KeyedVoxel& b) { return a.key < b.key; });
  for (std::size_t i = 0; i < keyed_.size();) {
    std::size_t j = i;
    while (j < keyed_.size() && keyed_[j].key >> 21 == keyed_[i].key >> 21) ++j;
    column_features(std::span<const KeyedVoxel>{keyed_.data() + i, j - i}, out);
    i = j;
  }
}

void SurfaceGrid::take_changes(std::vector<ColumnChange>& columns, std::vector<LineFeature>& features) {
  columns.clear();
  features.clear();
  std::sort(changed_.begin(), changed_.end());
  for (const std::uint64_t column : changed_) {
    Column* c = columns_.find(column);
    c->changed = false;
    // The column's voxels bottom to top (key order), each queued again by its next point.
    keyed_.clear();
    for (std::uint32_t i = c->lowest; i != kNone; i = voxel(i).up) {
      Voxel& v = voxel(i);
      v.queued = false;
      keyed_.push_back({(column << 21) | v.iz, &v});
    }
    const auto begin = static_cast<std::uint32_t>(features.size());
    column_features(keyed_, features);
    columns.push_back({column, begin, static_cast<std::uint32_t>(features.size())});
  }
  changed_.clear();
}

}  // namespace teamscan::registration
