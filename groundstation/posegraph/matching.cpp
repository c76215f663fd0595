// Scan-to-submap matching (matching.hpp).
#include "groundstation/posegraph/matching.hpp"

#include <ceres/ceres.h>

#include <algorithm>
#include <cmath>
#include <limits>

namespace teamscan::posegraph {
namespace {

// The cubic Hermite (Catmull-Rom) spline through p[0..3] at x ∈ [0, 1] between p[1] and p[2], and its
// derivative (as ceres::CubicHermiteSpline).
inline void hermite(const double p[4], double x, double* f, double* dfdx) {
  const double a = 0.5 * (-p[0] + 3.0 * p[1] - 3.0 * p[2] + p[3]);
  const double b = 0.5 * (2.0 * p[0] - 5.0 * p[1] + 4.0 * p[2] - p[3]);
  const double c = 0.5 * (-p[0] + p[2]);
  *f = p[1] + x * (c + x * (b + x * a));
  if (dfdx != nullptr) *dfdx = c + x * (2.0 * b + 3.0 * a * x);
}

// Bicubic interpolation of the grid at continuous cell coordinates (row = y, column = x), cells beyond
// the box taking the nearest border cell's value: ceres::BiCubicInterpolator over ceres::Grid2D, with
// the 4 × 4 neighbourhood read directly where it lies inside the box.
class Interpolator {
 public:
  explicit Interpolator(const Grid& grid) : values_(grid.values().data()), box_(grid.box()) {}
  void Evaluate(double r, double c, double* f, double* dfdr = nullptr, double* dfdc = nullptr) const {
    const int row = static_cast<int>(std::floor(r)), col = static_cast<int>(std::floor(c));
    double p[4][4];
    const int y = row - 1 - box_.y0, x = col - 1 - box_.x0;
    if (y >= 0 && x >= 0 && y + 3 < box_.height && x + 3 < box_.width) {
      const float* at = values_ + static_cast<std::ptrdiff_t>(y) * box_.width + x;
      for (int i = 0; i < 4; ++i, at += box_.width)
        for (int j = 0; j < 4; ++j) p[i][j] = static_cast<double>(at[j]);
    } else {
      for (int i = 0; i < 4; ++i) {
        const int yi = std::clamp(y + i, 0, box_.height - 1);
        for (int j = 0; j < 4; ++j)
          p[i][j] = static_cast<double>(values_[static_cast<std::ptrdiff_t>(yi) * box_.width + std::clamp(x + j, 0, box_.width - 1)]);
      }
    }
    double rows[4], drows_dc[4];
    for (int i = 0; i < 4; ++i) hermite(p[i], c - col, &rows[i], &drows_dc[i]);
    hermite(rows, r - row, f, dfdr);
    if (dfdc != nullptr) hermite(drows_dc, r - row, dfdc, nullptr);
  }

 private:
  const float* values_;
  CellBox box_;
};

// 1 − the interpolated grid value at each point moved by the pose: zero on a return. The Jacobian is
// the interpolator's gradient chained through the rigid motion (what automatic differentiation would
// compute, without carrying dual numbers through every spline).
class OccupiedCost final : public ceres::CostFunction {
 public:
  OccupiedCost(const Interpolator& interpolator, const std::vector<Vec2>& points, double weight, double inv_resolution)
      : interpolator_(interpolator), points_(points), weight_(weight), inv_resolution_(inv_resolution) {
    set_num_residuals(static_cast<int>(points.size()));
    mutable_parameter_block_sizes()->push_back(3);
  }
  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override {
    const double* pose = parameters[0];
    const double c = std::cos(pose[2]), s = std::sin(pose[2]);
    double* jacobian = jacobians != nullptr ? jacobians[0] : nullptr;
    for (std::size_t i = 0; i < points_.size(); ++i) {
      const double rx = c * points_[i].x - s * points_[i].y, ry = s * points_[i].x + c * points_[i].y;
      const double x = pose[0] + rx, y = pose[1] + ry;
      double v = 0, dv_drow = 0, dv_dcol = 0;
      interpolator_.Evaluate(y * inv_resolution_, x * inv_resolution_, &v, &dv_drow, &dv_dcol);
      residuals[i] = weight_ * (1.0 - v);
      if (jacobian != nullptr) {
        const double gx = -weight_ * inv_resolution_ * dv_dcol, gy = -weight_ * inv_resolution_ * dv_drow;
        double* row = jacobian + 3 * i;
        row[0] = gx;
        row[1] = gy;
        row[2] = gx * -ry + gy * rx;  // d(x, y)/dθ = (−ry, rx)
      }
    }
    return true;
  }

 private:
  const Interpolator& interpolator_;
  const std::vector<Vec2>& points_;
  double weight_, inv_resolution_;
};

struct PriorCost {
  PriorCost(const Pose2& guess, double tw, double rw) : guess_(guess), tw_(tw), rw_(rw) {}
  template <typename T>
  bool operator()(const T* const pose, T* residual) const {
    residual[0] = tw_ * (pose[0] - guess_.x_m);
    residual[1] = tw_ * (pose[1] - guess_.y_m);
    residual[2] = rw_ * (pose[2] - guess_.theta_rad);
    return true;
  }
  Pose2 guess_;
  double tw_, rw_;
};

}  // namespace

Pose2 refine_pose(const Grid& grid, const std::vector<Vec2>& points, const Pose2& guess, const RefineOptions& options) {
  if (grid.empty() || points.empty()) return guess;
  const Interpolator interpolator(grid);
  double pose[3] = {guess.x_m, guess.y_m, guess.theta_rad};
  ceres::Problem::Options po;
  po.cost_function_ownership = ceres::TAKE_OWNERSHIP;
  ceres::Problem problem(po);
  const double w = options.occupied_weight / std::sqrt(static_cast<double>(points.size()));
  problem.AddResidualBlock(new OccupiedCost(interpolator, points, w, 1.0 / grid.resolution_m()), nullptr, pose);
  problem.AddResidualBlock(new ceres::AutoDiffCostFunction<PriorCost, 3, 3>(
                               new PriorCost(guess, options.translation_weight, options.rotation_weight)),
                           nullptr, pose);
  ceres::Solver::Options so;
  so.linear_solver_type = ceres::DENSE_QR;
  so.max_num_iterations = options.max_iterations;
  so.num_threads = 1;
  so.logging_type = ceres::SILENT;
  ceres::Solver::Summary summary;
  ceres::Solve(so, &problem, &summary);
  return {pose[0], pose[1], normalize_angle(pose[2])};
}

MatchInformation match_information(const Grid& grid, const std::vector<Vec2>& points, const Pose2& pose) {
  MatchInformation info;
  if (grid.empty() || points.empty()) return info;
  const Interpolator interpolator(grid);
  const double inv = 1.0 / grid.resolution_m();
  // At the match the points sit on the grid's ridges, where its gradient vanishes: the information is
  // taken from the gradients a small displacement (one cell, either way in x and in y) would meet,
  // so a wall gives information across it and none along it. A rotation about the node moves a point
  // at q by (−(q.y − y), q.x − x) per radian: the gradient along that is the rotation's row.
  const double h = grid.resolution_m();
  double xx = 0, xy = 0, yy = 0, xt = 0, yt = 0, tt = 0;
  for (const Vec2& p : points) {
    const Vec2 q = pose.apply(p);
    const double turn_x = -(q.y - pose.y_m), turn_y = q.x - pose.x_m;
    for (const Vec2 d : {Vec2{h, 0}, Vec2{-h, 0}, Vec2{0, h}, Vec2{0, -h}}) {
      double v = 0, dv_drow = 0, dv_dcol = 0;
      interpolator.Evaluate((q.y + d.y) * inv, (q.x + d.x) * inv, &v, &dv_drow, &dv_dcol);
      const double gx = dv_dcol * inv, gy = dv_drow * inv, gt = gx * turn_x + gy * turn_y;
      xx += gx * gx;
      xy += gx * gy;
      yy += gy * gy;
      xt += gx * gt;
      yt += gy * gt;
      tt += gt * gt;
    }
  }
  // Eigen decomposition of the symmetric 2 × 2 [[xx, xy], [xy, yy]].
  const double mean = 0.5 * (xx + yy), half_diff = 0.5 * (xx - yy);
  const double radius = std::hypot(half_diff, xy);
  const double strong = mean + radius, weak = std::max(0.0, mean - radius);
  info.strong_axis_rad = 0.5 * std::atan2(2.0 * xy, xx - yy);
  info.weak_ratio = strong > 0.0 ? weak / strong : 1.0;
  // The rotation's information with the translation free (the Schur complement; the translation's
  // block regularised so that a single wall, with none along it, still inverts).
  const double reg = 1e-6 * (xx + yy), a = xx + reg, c = yy + reg, det = a * c - xy * xy;
  const double rotation = det > 0.0 ? tt - (xt * (c * xt - xy * yt) + yt * (a * yt - xy * xt)) / det : tt;
  info.rotation_lever_m = strong > 0.0 ? std::sqrt(std::max(0.0, rotation) / strong) : 0.0;
  return info;
}

double pose_score(const Grid& grid, const std::vector<Vec2>& points, const Pose2& pose) {
  if (points.empty()) return 0.0;
  const double inv = 1.0 / grid.resolution_m();
  double sum = 0;
  for (const Vec2& p : points) {
    const Vec2 q = pose.apply(p);
    sum += grid.at(static_cast<int>(std::lround(q.x * inv)), static_cast<int>(std::lround(q.y * inv)));
  }
  return sum / static_cast<double>(points.size());
}

// ---- the correlative search ----------------------------------------------------------------------

struct CorrelativeMatcher::Candidate {
  int scan = 0;        // index of the rotated scan
  int dx = 0, dy = 0;  // cell offset of the block's corner
  float score = 0;
};

CorrelativeMatcher::CorrelativeMatcher(const Grid& grid, int depth, int pool) : resolution_m_(grid.resolution_m() * pool) {
  const CellBox& g = grid.box();
  // Search cell (X, Y) holds grid cells [X·pool, X·pool + pool) × [Y·pool, Y·pool + pool).
  auto floor_div = [pool](int v) { return v >= 0 ? v / pool : -((-v + pool - 1) / pool); };
  box_.x0 = floor_div(g.x0);
  box_.y0 = floor_div(g.y0);
  box_.width = floor_div(g.x0 + g.width - 1) - box_.x0 + 1;
  box_.height = floor_div(g.y0 + g.height - 1) - box_.y0 + 1;
  const int pad = (1 << depth) - 1;
  Level base;
  base.pad = pad;
  base.width = box_.width + pad;
  base.height = box_.height + pad;
  base.values.assign(static_cast<std::size_t>(base.width) * static_cast<std::size_t>(base.height), 0);
  for (int y = g.y0; y < g.y0 + g.height; ++y)
    for (int x = g.x0; x < g.x0 + g.width; ++x) {
      const auto v = static_cast<std::uint8_t>(std::lround(255.0f * std::clamp(grid.at(x, y), 0.0f, 1.0f)));
      std::uint8_t& cell = base.values[static_cast<std::size_t>(floor_div(y) - box_.y0 + pad) * static_cast<std::size_t>(base.width) +
                                       static_cast<std::size_t>(floor_div(x) - box_.x0 + pad)];
      cell = std::max(cell, v);
    }
  levels_.push_back(std::move(base));
  // Level d at (x, y): the maximum over [x, x + 2^d) × [y, y + 2^d), from four cells of level d − 1.
  for (int d = 1; d <= depth; ++d) {
    const Level& prev = levels_.back();
    const int h = 1 << (d - 1);
    Level next = prev;
    for (int y = 0; y < next.height; ++y)
      for (int x = 0; x < next.width; ++x)
        next.values[static_cast<std::size_t>(y) * static_cast<std::size_t>(next.width) + static_cast<std::size_t>(x)] =
            std::max({prev.at(x, y), prev.at(x + h, y), prev.at(x, y + h), prev.at(x + h, y + h)});
    levels_.push_back(std::move(next));
  }
}

float CorrelativeMatcher::score(const Level& level, const RotatedScan& scan, int dx, int dy) const {
  if (scan.cells.empty()) return 0.0f;
  int sum = 0;
  if (scan.x_min + dx >= 0 && scan.y_min + dy >= 0 && scan.x_max + dx < level.width && scan.y_max + dy < level.height) {
    const std::uint8_t* at = level.values.data() + static_cast<std::ptrdiff_t>(dy) * level.width + dx;
    for (const std::ptrdiff_t i : scan.index) sum += at[i];
  } else {
    for (const auto& c : scan.cells) sum += level.at(c[0] + dx, c[1] + dy);
  }
  return static_cast<float>(sum) / (255.0f * static_cast<float>(scan.cells.size()));
}

void CorrelativeMatcher::branch(const std::vector<RotatedScan>& scans, std::vector<Candidate>& candidates, int depth, int max_x, int max_y,
                                float min_score, float tolerance, float& best_score, std::vector<Candidate>& leaves) const {
  std::stable_sort(candidates.begin(), candidates.end(), [](const Candidate& a, const Candidate& b) { return a.score > b.score; });
  for (const Candidate& c : candidates) {
    // Sorted: no later candidate's block holds a leaf at min_score and within the tolerance of the best.
    if (c.score < std::max(best_score - tolerance, min_score)) break;
    if (depth == 0) {
      best_score = std::max(best_score, c.score);
      leaves.push_back(c);
      continue;
    }
    const int h = 1 << (depth - 1);
    std::vector<Candidate> children;
    children.reserve(4);
    for (int ox : {0, h})
      for (int oy : {0, h}) {
        const int dx = c.dx + ox, dy = c.dy + oy;
        if (dx > max_x || dy > max_y) continue;
        children.push_back({c.scan, dx, dy, score(levels_[static_cast<std::size_t>(depth - 1)], scans[static_cast<std::size_t>(c.scan)], dx, dy)});
      }
    branch(scans, children, depth - 1, max_x, max_y, min_score, tolerance, best_score, leaves);
  }
}

SearchResult CorrelativeMatcher::search(const std::vector<Vec2>& points, const Pose2& guess, const SearchWindow& window,
                                        double min_score) const {
  SearchResult result;
  if (points.empty() || levels_.empty()) return result;
  double max_range = 0;
  for (const Vec2& p : points) max_range = std::max(max_range, p.norm());
  double step = window.angular_step_rad;
  if (step <= 0.0) {
    // The farthest point moves by one cell (Hess et al. 2016, eq. 7).
    const double r = resolution_m_, d = std::max(max_range, r);
    step = std::acos(std::clamp(1.0 - r * r / (2.0 * d * d), -1.0, 1.0));
  }
  const int n_angles = static_cast<int>(std::ceil(window.angular_rad / step));
  const int linear = static_cast<int>(std::ceil(window.linear_m / resolution_m_));
  const Level& base = levels_.front();
  const double inv = 1.0 / resolution_m_;
  // Each rotation's points as level cells with the guess's translation and the window's low corner.
  std::vector<RotatedScan> scans;
  std::vector<double> angles;
  for (int k = -n_angles; k <= n_angles; ++k) {
    const double a = guess.theta_rad + k * step;
    const Pose2 pose{guess.x_m, guess.y_m, a};
    RotatedScan scan;
    scan.cells.reserve(points.size());
    scan.index.reserve(points.size());
    scan.x_min = scan.y_min = std::numeric_limits<int>::max();
    scan.x_max = scan.y_max = std::numeric_limits<int>::min();
    for (const Vec2& p : points) {
      const Vec2 q = pose.apply(p);
      const int x = static_cast<int>(std::lround(q.x * inv)) - box_.x0 + base.pad - linear;
      const int y = static_cast<int>(std::lround(q.y * inv)) - box_.y0 + base.pad - linear;
      scan.cells.push_back({x, y});
      scan.index.push_back(static_cast<std::ptrdiff_t>(y) * base.width + x);
      scan.x_min = std::min(scan.x_min, x);
      scan.y_min = std::min(scan.y_min, y);
      scan.x_max = std::max(scan.x_max, x);
      scan.y_max = std::max(scan.y_max, y);
    }
    scans.push_back(std::move(scan));
    angles.push_back(a);
  }
  const int depth = static_cast<int>(levels_.size()) - 1;
  const int top_step = 1 << depth;
  const int max_offset = 2 * linear;
  std::vector<Candidate> top;
  for (std::size_t s = 0; s < scans.size(); ++s)
    for (int dx = 0; dx <= max_offset; dx += top_step)
      for (int dy = 0; dy <= max_offset; dy += top_step)
        top.push_back({static_cast<int>(s), dx, dy, score(levels_.back(), scans[s], dx, dy)});
  const auto tolerance = static_cast<float>(window.plateau_score);
  float best_score = 0.0f;
  std::vector<Candidate> leaves;
  branch(scans, top, depth, max_offset, max_offset, static_cast<float>(min_score), tolerance, best_score, leaves);
  // Of the leaves within the tolerance of the best score (a plateau: along a corridor the score only
  // ripples), the nearest to the guess, in search cells and angular steps (a step moves the farthest
  // point by about a cell); then the higher score. Taking the first the search visits would put every
  // such match at the window's low corner along the plateau, all with the same bias.
  Candidate best;
  best.scan = -1;
  long best_d2 = 0;
  for (const Candidate& c : leaves) {
    if (c.score < best_score - tolerance) continue;
    const long ex = c.dx - linear, ey = c.dy - linear, ea = c.scan - n_angles;
    const long d2 = ex * ex + ey * ey + ea * ea;
    if (best.scan < 0 || d2 < best_d2 || (d2 == best_d2 && c.score > best.score)) {
      best = c;
      best_d2 = d2;
    }
  }
  if (best.scan < 0) return result;
  best_score = best.score;
  result.found = true;
  result.score = best_score;
  result.pose = {guess.x_m + (best.dx - linear) * resolution_m_, guess.y_m + (best.dy - linear) * resolution_m_,
                 normalize_angle(angles[static_cast<std::size_t>(best.scan)])};
  return result;
}

}  // namespace teamscan::posegraph
