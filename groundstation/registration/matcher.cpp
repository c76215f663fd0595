// Point-to-line ICP in the plane with degeneracy handling (matcher.hpp).
#include "groundstation/registration/matcher.hpp"

#include <algorithm>
#include <cmath>

#include <Eigen/Eigenvalues>

namespace teamscan::registration {

LineMap::LineMap(double cell_m) : cell_m_{cell_m} {}

std::uint64_t LineMap::tile_key(std::int64_t tx, std::int64_t ty) {
  constexpr std::int64_t kBias = std::int64_t{1} << 30;
  return (static_cast<std::uint64_t>(tx + kBias) << 31) | static_cast<std::uint64_t>(ty + kBias);
}

const std::vector<LineMap::Entry>* LineMap::cell(std::int64_t cx, std::int64_t cy) const {
  const std::uint32_t* tile = tiles_.find(tile_key(cx >> kTileBits, cy >> kTileBits));
  if (tile == nullptr) return nullptr;
  constexpr std::int64_t kMask = (1 << kTileBits) - 1;
  const std::uint32_t c = tile_cells_[*tile][static_cast<std::size_t>(((cy & kMask) << kTileBits) | (cx & kMask))];
  return c == kNone ? nullptr : &cells_[c];
}

std::vector<LineMap::Entry>& LineMap::cell_for_insert(std::int64_t cx, std::int64_t cy) {
  bool inserted = false;
  std::uint32_t& tile = tiles_.get_or_insert(tile_key(cx >> kTileBits, cy >> kTileBits), kNone, &inserted);
  if (inserted) {
    tile = static_cast<std::uint32_t>(tile_cells_.size());
    tile_cells_.emplace_back();
    tile_cells_.back().fill(kNone);
  }
  constexpr std::int64_t kMask = (1 << kTileBits) - 1;
  std::uint32_t& c = tile_cells_[tile][static_cast<std::size_t>(((cy & kMask) << kTileBits) | (cx & kMask))];
  if (c == kNone) {
    c = static_cast<std::uint32_t>(cells_.size());
    cells_.emplace_back();
    if (cx_lo_ > cx_hi_) {
      cx_lo_ = cx_hi_ = cx;
      cy_lo_ = cy_hi_ = cy;
    }
    cx_lo_ = std::min(cx_lo_, cx);
    cx_hi_ = std::max(cx_hi_, cx);
    cy_lo_ = std::min(cy_lo_, cy);
    cy_hi_ = std::max(cy_hi_, cy);
  }
  return cells_[c];
}

void LineMap::insert(std::uint32_t slot) {
  const LineFeature& f = slots_[slot].f;
  cell_for_insert(cell_of(f.x_m), cell_of(f.y_m)).push_back({f.x_m, f.y_m, f.nx, f.ny, slot});
}

void LineMap::erase(std::uint32_t slot) {
  const LineFeature& f = slots_[slot].f;
  std::vector<Entry>& c = cell_for_insert(cell_of(f.x_m), cell_of(f.y_m));
  for (std::size_t i = 0; i < c.size(); ++i)
    if (c[i].slot == slot) {
      c[i] = c.back();  // the order within a cell does not matter: nearest() orders by (d², group, place)
      c.pop_back();
      break;
    }
  slots_[slot].live = false;
  free_.push_back(slot);
}

void LineMap::clear() {
  slots_.clear();
  free_.clear();
  groups_.clear();
  tiles_.clear();
  tile_cells_.clear();
  cells_.clear();
  cx_lo_ = cy_lo_ = 0;
  cx_hi_ = cy_hi_ = -1;
  size_ = 0;
}

void LineMap::build(std::span<const LineFeature> features) {
  clear();
  for (std::size_t i = 0; i < features.size(); ++i) replace(i, features.subspan(i, 1));
}

void LineMap::replace(std::uint64_t group, std::span<const LineFeature> features) {
  if (features.empty() && groups_.find(group) == nullptr) return;
  Group& g = groups_.get_or_insert(group, Group{});
  ++groups_replaced_;
  for (std::uint32_t i = 0; i < g.count; ++i) erase(g.slots[i]);
  features_removed_ += g.count;
  size_ -= g.count;
  g.count = 0;
  for (const LineFeature& f : features) {
    if (g.count == kMaxPerGroup) {
      ++dropped_;
      continue;
    }
    std::uint32_t slot;
    if (!free_.empty()) {
      slot = free_.back();
      free_.pop_back();
    } else {
      slot = static_cast<std::uint32_t>(slots_.size());
      slots_.emplace_back();
    }
    slots_[slot] = Slot{f, group, g.count, true};
    insert(slot);
    g.slots[g.count++] = slot;
    ++features_added_;
    ++size_;
  }
}

bool LineMap::before(double d2a, std::uint32_t a, double d2b, std::uint32_t b) const {
  if (d2a != d2b) return d2a < d2b;
  const Slot& sa = slots_[a];
  const Slot& sb = slots_[b];
  return sa.group != sb.group ? sa.group < sb.group : sa.place < sb.place;
}

std::ptrdiff_t LineMap::nearest(double x_m, double y_m, double nx, double ny, double max_distance_m, double min_dot) const {
  if (size_ == 0 || !(max_distance_m >= 0)) return -1;
  constexpr int kK = 4;
  std::uint32_t idx[kK];
  double d2[kK];
  int found = 0;
  const double gate2 = max_distance_m * max_distance_m;
  const std::int64_t qx = cell_of(x_m), qy = cell_of(y_m);
  // The query's distance to its cell's border: ring r (the cells at Chebyshev distance r) lies at
  // least (r − 1)·cell + border away.
  const double fx = x_m - static_cast<double>(qx) * cell_m_, fy = y_m - static_cast<double>(qy) * cell_m_;
  const double border = std::max(0.0, std::min(std::min(fx, cell_m_ - fx), std::min(fy, cell_m_ - fy)) - 1e-9);
  auto visit = [&](std::int64_t cx, std::int64_t cy) {
    const std::vector<Entry>* c = cell(cx, cy);
    if (c == nullptr) return;
    for (const Entry& e : *c) {
      const double dx = e.x_m - x_m, dy = e.y_m - y_m, e2 = dx * dx + dy * dy;
      if (e2 > gate2) continue;
      if (found == kK && !before(e2, e.slot, d2[kK - 1], idx[kK - 1])) continue;
      int at = found < kK ? found : kK - 1;
      while (at > 0 && before(e2, e.slot, d2[at - 1], idx[at - 1])) {
        d2[at] = d2[at - 1];
        idx[at] = idx[at - 1];
        --at;
      }
      d2[at] = e2;
      idx[at] = e.slot;
      if (found < kK) ++found;
    }
  };
  auto agrees = [&](std::uint32_t slot) {
    const LineFeature& f = slots_[slot].f;
    return (nx == 0 && ny == 0) || std::abs(f.nx * nx + f.ny * ny) >= min_dot;
  };
  for (std::int64_t r = 0;; ++r) {
    if (r > 0) {
      const double lb = static_cast<double>(r - 1) * cell_m_ + border;
      if (lb > max_distance_m || (found == kK && lb * lb > d2[kK - 1])) break;
      // The first agreeing one of the 4 nearest so far is the answer once nothing unvisited can come
      // before it: every feature nearer than it has been seen, so its rank is final.
      int first = 0;
      while (first < found && !agrees(idx[first])) ++first;
      if (first < found && d2[first] < lb * lb) break;
      // The block of rings < r covered every cell ever used: nothing further out.
      if (qx - (r - 1) <= cx_lo_ && qx + (r - 1) >= cx_hi_ && qy - (r - 1) <= cy_lo_ && qy + (r - 1) >= cy_hi_) break;
    }
    if (r == 0) {
      visit(qx, qy);
      continue;
    }
    for (std::int64_t cx = qx - r; cx <= qx + r; ++cx) {
      visit(cx, qy - r);
      visit(cx, qy + r);
    }
    for (std::int64_t cy = qy - r + 1; cy <= qy + r - 1; ++cy) {
      visit(qx - r, cy);
      visit(qx + r, cy);
    }
  }
  for (int k = 0; k < found; ++k)
    if (agrees(idx[k])) return static_cast<std::ptrdiff_t>(idx[k]);
  return -1;
}

void LineMap::collect(std::vector<std::pair<std::uint64_t, LineFeature>>& out) const {
  out.clear();
  std::vector<std::pair<std::pair<std::uint64_t, std::uint32_t>, std::uint32_t>> order;
  order.reserve(size_);
  for (std::size_t i = 0; i < slots_.size(); ++i)
    if (slots_[i].live) order.push_back({{slots_[i].group, slots_[i].place}, static_cast<std::uint32_t>(i)});
  std::sort(order.begin(), order.end());
  out.reserve(order.size());
  for (const auto& o : order) out.emplace_back(o.first.first, slots_[o.second].f);
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
    const LineFeature& q = map.feature(static_cast<std::size_t>(k));
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
