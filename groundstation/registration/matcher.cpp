// Point-to-line ICP in the plane with degeneracy handling (matcher.hpp).
#include "groundstation/registration/matcher.hpp"

#include <algorithm>
#include <cmath>

#include <Eigen/Eigenvalues>
#include <nanoflann.hpp>

namespace teamscan::registration {

struct LineMap::Index {
  // nanoflann's dataset adaptor over the feature positions.
  struct Cloud {
    const std::vector<LineFeature>* f = nullptr;
    [[nodiscard]] std::size_t kdtree_get_point_count() const { return f->size(); }
    [[nodiscard]] double kdtree_get_pt(std::size_t i, std::size_t dim) const { return dim == 0 ? (*f)[i].x_m : (*f)[i].y_m; }
    template <class Box>
    bool kdtree_get_bbox(Box&) const {
      return false;
    }
  };
  using Tree = nanoflann::KDTreeSingleIndexAdaptor<nanoflann::L2_Simple_Adaptor<double, Cloud>, Cloud, 2, std::uint32_t>;
  Cloud cloud;
  Tree tree;
  explicit Index(const std::vector<LineFeature>* f) : cloud{f}, tree{2, cloud, nanoflann::KDTreeSingleIndexAdaptorParams{10}} {}
};

LineMap::LineMap() = default;
LineMap::~LineMap() = default;

void LineMap::build(std::vector<LineFeature> features) {
  index_.reset();
  features_ = std::move(features);
  if (!features_.empty()) index_ = std::make_unique<Index>(&features_);
}

std::ptrdiff_t LineMap::nearest(double x_m, double y_m, double nx, double ny, double max_distance_m, double min_dot) const {
  if (!index_) return -1;
  constexpr std::size_t kK = 4;
  std::uint32_t idx[kK];
  double d2[kK];
  const double q[2] = {x_m, y_m};
  const std::size_t found = index_->tree.knnSearch(q, kK, idx, d2);
  const double gate2 = max_distance_m * max_distance_m;
  for (std::size_t k = 0; k < found; ++k) {
    if (d2[k] > gate2) break;
    const LineFeature& f = features_[idx[k]];
    if ((nx == 0 && ny == 0) || std::abs(f.nx * nx + f.ny * ny) >= min_dot) return static_cast<std::ptrdiff_t>(idx[k]);
  }
  return -1;
}

const char* to_string(MatchStatus s) {
  switch (s) {
    case MatchStatus::accepted: return "accepted";
    case MatchStatus::too_few_features: return "too_few_features";
    case MatchStatus::no_overlap: return "no_overlap";
    case MatchStatus::poor_fit: return "poor_fit";
    case MatchStatus::step_too_large: return "step_too_large";
  }
  return "unknown";
}

Eigen::Matrix3d move_pivot(const Eigen::Matrix3d& cov, const Vec2& from, const Vec2& to) {
  // The same small motion about `to`: δt_to = δt_from + δθ · ẑ × (to − from).
  Eigen::Matrix3d j = Eigen::Matrix3d::Identity();
  j(0, 2) = -(to.y - from.y);
  j(1, 2) = to.x - from.x;
  return j * cov * j.transpose();
}

Pose2 perturb(const Pose2& t, const Vec2& pivot, double dx, double dy, double dtheta) {
  const double c = std::cos(dtheta), s = std::sin(dtheta);
  const Pose2 delta{pivot.x - (c * pivot.x - s * pivot.y) + dx, pivot.y - (s * pivot.x + c * pivot.y) + dy, dtheta};
  return delta * t;
}

Eigen::Vector3d difference(const Pose2& to, const Pose2& from, const Vec2& pivot) {
  const Pose2 delta = to * from.inverse();
  const Vec2 moved = delta.apply(pivot);
  return {moved.x - pivot.x, moved.y - pivot.y, delta.theta_rad};
}

namespace {

struct Linearised {
  Eigen::Matrix3d h = Eigen::Matrix3d::Zero();   // scaled (x, y, yaw·lever)
  Eigen::Vector3d g = Eigen::Vector3d::Zero();
  double sum_w = 0, sum_wr2 = 0;
  std::size_t pairs = 0;
  Vec2 pivot;
};

Linearised linearise(const LineMap& map, std::span<const LineFeature> source, const Pose2& t, double gate,
                     const MatchOptions& o) {
  Linearised l;
  const double c = std::cos(t.theta_rad), s = std::sin(t.theta_rad);
  for (const LineFeature& f : source) {
    const Vec2 p = t.apply({f.x_m, f.y_m});
    l.pivot.x += p.x;
    l.pivot.y += p.y;
  }
  if (!source.empty()) {
    l.pivot.x /= static_cast<double>(source.size());
    l.pivot.y /= static_cast<double>(source.size());
  }
  for (const LineFeature& f : source) {
    const Vec2 p = t.apply({f.x_m, f.y_m});
    const double snx = c * f.nx - s * f.ny, sny = s * f.nx + c * f.ny;
    const std::ptrdiff_t k = map.nearest(p.x, p.y, snx, sny, gate, o.min_normal_dot);
    if (k < 0) continue;
    const LineFeature& q = map.features()[static_cast<std::size_t>(k)];
    const double r = q.nx * (p.x - q.x_m) + q.ny * (p.y - q.y_m);
    const Eigen::Vector3d j{q.nx, q.ny, (-q.nx * (p.y - l.pivot.y) + q.ny * (p.x - l.pivot.x)) / o.lever_m};
    const double w = std::abs(r) <= o.huber_m ? 1.0 : o.huber_m / std::abs(r);
    l.h += w * j * j.transpose();
    l.g += w * j * r;
    l.sum_w += w;
    l.sum_wr2 += w * r * r;
    ++l.pairs;
  }
  return l;
}

}  // namespace

MatchResult match(const LineMap& map, std::span<const LineFeature> source, const Pose2& prior, const MatchOptions& o) {
  MatchResult out;
  out.map_from_odom = prior;
  out.source_features = source.size();
  if (source.size() < o.min_correspondences || map.size() < o.min_correspondences) {
    out.status = MatchStatus::too_few_features;
    return out;
  }
  Pose2 t = prior;
  const int n_it = std::max(1, o.iterations);
  for (int it = 0; it < n_it; ++it) {
    const double f = n_it > 1 ? static_cast<double>(it) / (n_it - 1) : 1.0;
    const double gate = o.gate_start_m + (o.gate_end_m - o.gate_start_m) * f;
    const Linearised l = linearise(map, source, t, gate, o);
    out.iterations = it + 1;
    if (l.pairs < o.min_correspondences) continue;  // nothing to solve; the end gate's assessment decides
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(l.h);
    const Eigen::Vector3d lambda = es.eigenvalues();
    const double lmax = std::max(lambda(2), 1e-12);
    Eigen::Vector3d step = Eigen::Vector3d::Zero();
    for (int i = 0; i < 3; ++i) {
      if (lambda(i) < o.degenerate_ratio * lmax) continue;  // keep the prior along it
      const Eigen::Vector3d v = es.eigenvectors().col(i);
      step -= v * (v.dot(l.g) / lambda(i));
    }
    t = perturb(t, l.pivot, step(0), step(1), step(2) / o.lever_m);
    if (step.head<2>().norm() < 1e-5 && std::abs(step(2)) < 1e-5 && gate <= o.gate_end_m + 1e-9) break;
  }

  // Final assessment at the end gate.
  const Linearised l = linearise(map, source, t, o.gate_end_m, o);
  out.pivot_m = l.pivot;
  out.correspondences = l.pairs;
  out.overlap = static_cast<double>(l.pairs) / static_cast<double>(source.size());
  out.rms_m = l.sum_w > 0 ? std::sqrt(l.sum_wr2 / l.sum_w) : 0.0;
  const Pose2 moved = t * prior.inverse();  // what the estimate does to map points, relative to the prior
  const Vec2 pivot_moved = moved.apply(l.pivot);
  out.step_m = std::hypot(pivot_moved.x - l.pivot.x, pivot_moved.y - l.pivot.y);
  out.step_rad = std::abs(normalize_angle(t.theta_rad - prior.theta_rad));

  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(l.h);
  const Eigen::Vector3d lambda = es.eigenvalues();
  const double lmax = std::max(lambda(2), 1e-12);
  out.condition = std::max(0.0, lambda(0)) / lmax;
  const double dof = std::max<double>(1.0, static_cast<double>(l.pairs) - 3.0);
  const double sigma2 = o.covariance_scale * l.sum_wr2 / dof;
  Eigen::Matrix3d cov_scaled = Eigen::Matrix3d::Zero();
  for (int i = 0; i < 3; ++i) {
    const Eigen::Vector3d v = es.eigenvectors().col(i);
    if (lambda(i) < o.degenerate_ratio * lmax) {
      cov_scaled += o.unconstrained_sigma * o.unconstrained_sigma * v * v.transpose();
      if (!out.degenerate) out.unconstrained = v;
      out.degenerate = true;
    } else {
      cov_scaled += sigma2 / lambda(i) * v * v.transpose();
    }
  }
  const Eigen::Vector3d scale{1.0, 1.0, 1.0 / o.lever_m};
  out.covariance = scale.asDiagonal() * cov_scaled * scale.asDiagonal();
  out.covariance(0, 0) += o.min_sigma_m * o.min_sigma_m;
  out.covariance(1, 1) += o.min_sigma_m * o.min_sigma_m;
  out.covariance(2, 2) += o.min_sigma_rad * o.min_sigma_rad;

  if (l.pairs < o.min_correspondences || out.overlap < o.min_overlap) {
    out.status = MatchStatus::no_overlap;
  } else if (out.rms_m > o.max_rms_m) {
    out.status = MatchStatus::poor_fit;
  } else if (out.step_m > o.max_step_m || out.step_rad > o.max_step_rad) {
    out.status = MatchStatus::step_too_large;
  } else {
    out.status = MatchStatus::accepted;
    out.map_from_odom = t;
  }
  return out;
}

}  // namespace teamscan::registration
