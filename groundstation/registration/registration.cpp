// Team registration: windows, reference, matching policy and the correction's Kalman filter
// (registration.hpp).
#include "groundstation/registration/registration.hpp"

#include <algorithm>
#include <cmath>

#include <Eigen/LU>

namespace teamscan::registration {

RegistrationOptions planar_scan_options(RegistrationOptions o) {
  o.surface.planar_scans = true;
  o.surface.voxel_m = 0.15;
  o.surface.min_points = 3;
  o.point_source = true;
  o.window_s = 60.0;
  o.window_m = 0.01;  // the last scan (and any taken from the same spot)
  o.match_every_s = 0.0;
  o.match_delay_s = 0.0;  // the next scan's match starts from this one's
  o.update_every_s = 0.0;
  o.match.min_overlap = 0.30;
  o.drift_m2_per_m = 0.03 * 0.03;  // a real log's skids: the step may open wider
  o.drift_rad2_per_m = 0.02 * 0.02;
  o.drift_rad2_per_rad = 0.1 * 0.1;
  // Every scan is matched: no gap to extrapolate over, and one scan's short baseline makes the rates'
  // estimates noise (docs/registration.md, the Intel lab figures).
  o.estimate_rates = false;
  return o;
}

std::string prior_error(const OdometryPrior& p) {
  auto finite = [](double v) { return std::isfinite(v); };
  if (!finite(p.scale) || !finite(p.sigma_scale) || !finite(p.drift_rad_per_m) || !finite(p.sigma_drift_rad_per_m) ||
      !finite(p.turn) || !finite(p.sigma_turn))
    return "every rate and σ must be finite";
  // A distance or turn scale of ±50 % is no odometry; 0.2 rad/m (11°/m) is a base that cannot drive straight.
  if (!(std::abs(p.scale) < 0.5)) return "the scale must be within ±50 %";
  if (!(p.sigma_scale > 0.0 && p.sigma_scale <= 0.5)) return "the scale's σ must be in (0, 50 %]";
  if (!(std::abs(p.drift_rad_per_m) <= 0.2)) return "the heading drift must be within ±0.2 rad/m (11.5°/m)";
  if (!(p.sigma_drift_rad_per_m > 0.0 && p.sigma_drift_rad_per_m <= 0.2))
    return "the heading drift's σ must be in (0, 0.2 rad/m]";
  if (!(std::abs(p.turn) < 0.5)) return "the turn scale must be within ±50 %";
  if (!(p.sigma_turn > 0.0 && p.sigma_turn <= 0.5)) return "the turn scale's σ must be in (0, 50 %]";
  return {};
}

const OdometryPrior& RegistrationOptions::prior_of(std::uint8_t robot) const {
  for (const RobotPrior& rp : robot_priors)
    if (rp.robot == robot) return rp.prior;
  return prior;
}

namespace {
SurfaceOptions with_cap(SurfaceOptions o, std::uint32_t cap) {
  o.voxel_cap = cap;
  return o;
}
}  // namespace

Registration::Registration(RegistrationOptions options)
    : options_{options},
      reference_{options.surface, /*track_columns=*/true},
      window_grid_{with_cap(options.surface, options.window_voxel_cap)} {
  for (std::size_t id = 0; id < robots_.size(); ++id) robots_[id].c.robot = static_cast<std::uint8_t>(id);
  // At start-up, not at the first match: a thread that cannot start is an error of the constructor
  // (std::system_error), never of a scan.
  if (options_.match_delay_s > 0.0) worker_ = std::make_unique<MatchWorker>(options_.cpus);
}

const RobotCorrection* Registration::correction(std::uint8_t robot) const {
  if (robot == 0 || robot > kMaxRobots || !robots_[robot].started) return nullptr;
  return &robots_[robot].c;
}

const RobotCorrection& Registration::add_scan(std::uint8_t robot, std::int64_t stamp_ns, const Pose2& odom_pose,
                                              std::span<const Vec3> points, std::span<const std::uint8_t> usable) {
  if (robot == 0 || robot > kMaxRobots || (!usable.empty() && usable.size() != points.size())) {
    ++rejected_scans_;
    return robots_[0].c;  // identity, never updated
  }
  Robot& r = robots_[robot];
  if (!r.started) {
    r.started = true;
    r.last_odom = odom_pose;
    r.odom_at_match = odom_pose;
    // Phased by the robot's id (golden-ratio fractions spread any team size evenly over the period).
    const double phase = std::fmod(0.6180339887498949 * robot, 1.0);
    r.last_attempt_ns = stamp_ns - static_cast<std::int64_t>(phase * options_.match_every_s * 1e9);
    const double sm = options_.initial_sigma_m, sr = options_.initial_sigma_rad;
    r.covariance = Matrix6::Zero();
    r.covariance.diagonal().head<3>() = Eigen::Vector3d{sm * sm, sm * sm, sr * sr};
    if (options_.estimate_rates) {
      // The robot's prior: the rates' starting values and σ (its calibration, or the team's default).
      const OdometryPrior& prior = options_.prior_of(robot);
      r.c.scale = prior.scale;
      r.c.drift_rad_per_m = prior.drift_rad_per_m;
      r.c.turn = prior.turn;
      r.covariance.diagonal().tail<3>() =
          Eigen::Vector3d{prior.sigma_scale * prior.sigma_scale, prior.sigma_drift_rad_per_m * prior.sigma_drift_rad_per_m,
                          prior.sigma_turn * prior.sigma_turn};
    }
    r.c.covariance = r.covariance.topLeftCorner<3, 3>();
    r.c.rate_covariance = r.covariance.bottomRightCorner<3, 3>();
    r.c.pivot_m = r.c.map_from_odom.apply({odom_pose.x_m, odom_pose.y_m});
  } else if (!r.window.empty() && stamp_ns < r.window.back().stamp_ns) {
    ++rejected_scans_;  // out of order: the window is a time window
    return r.c;
  }
  r.c.matched = false;
  predict(r, odom_pose);
  // A match due at this scan: fused now (waiting for the worker if it is not done).
  if (r.job.pending && stamp_ns >= r.job.apply_ns) {
    if (r.job.ticket != 0) worker_->wait(r.job.ticket);
    finish(r);
  }
  WindowScan ws;
  ws.stamp_ns = stamp_ns;
  ws.path_m = r.path_m;
  ws.map_from_odom = r.c.map_from_odom;
  ws.points.reserve(points.size());
  for (std::size_t i = 0; i < points.size(); ++i)
    if (usable.empty() || usable[i]) ws.points.push_back(points[i]);
  r.window.push_back(std::move(ws));
  retire(r, stamp_ns);
  try_match(r, stamp_ns, odom_pose);
  return r.c;
}

namespace {
// The left-perturbation Jacobian that moves the pose block's pivot (move_pivot), the rates unchanged.
Eigen::Matrix<double, 6, 6> pivot_jacobian(const Vec2& from, const Vec2& to) {
  Eigen::Matrix<double, 6, 6> j = Eigen::Matrix<double, 6, 6>::Identity();
  j(0, 2) = -(to.y - from.y);
  j(1, 2) = to.x - from.x;
  return j;
}
}  // namespace

void Registration::predict(Robot& r, const Pose2& odom_pose) {
  // The odometry's increment in the robot's frame, and the true one the rates make of it.
  const Pose2 delta = r.last_odom.inverse() * odom_pose;
  const double ds = std::hypot(delta.x_m, delta.y_m);
  const double dtheta = normalize_angle(delta.theta_rad);
  const Pose2 map_pose = r.c.map_from_odom * r.last_odom;  // where the robot was
  r.last_odom = odom_pose;
  r.path_m += ds;
  // Standing still, or no rate estimated yet: the correction is held exactly (no rounding drift).
  const bool rates = r.c.scale != 0.0 || r.c.drift_rad_per_m != 0.0 || r.c.turn != 0.0;
  if (options_.estimate_rates && rates && (ds > 0.0 || dtheta != 0.0)) {
    const Pose2 moved{delta.x_m * (1.0 + r.c.scale), delta.y_m * (1.0 + r.c.scale),
                      dtheta * (1.0 + r.c.turn) + r.c.drift_rad_per_m * ds};
    r.c.map_from_odom = (map_pose * moved) * odom_pose.inverse();
  }
  const Vec2 pivot = r.c.map_from_odom.apply({odom_pose.x_m, odom_pose.y_m});
  Matrix6 f = pivot_jacobian(r.c.pivot_m, pivot);
  // How the rates move the robot over this increment (left perturbation about the new position).
  const double c = std::cos(map_pose.theta_rad), s = std::sin(map_pose.theta_rad);
  f(0, 3) = c * delta.x_m - s * delta.y_m;
  f(1, 3) = s * delta.x_m + c * delta.y_m;
  f(2, 4) = ds;
  f(2, 5) = dtheta;
  r.covariance = f * r.covariance * f.transpose();
  r.c.pivot_m = pivot;
  r.covariance(0, 0) += options_.drift_m2_per_m * ds;
  r.covariance(1, 1) += options_.drift_m2_per_m * ds;
  r.covariance(2, 2) += options_.drift_rad2_per_m * ds + options_.drift_rad2_per_rad * std::abs(dtheta);
  if (options_.estimate_rates) {
    r.covariance(3, 3) += options_.rate_walk_scale2_per_m * ds;
    r.covariance(4, 4) += options_.rate_walk_drift2_per_m * ds;
    r.covariance(5, 5) += options_.rate_walk_turn2_per_m * ds;
  }
  r.c.covariance = r.covariance.topLeftCorner<3, 3>();
  r.c.rate_covariance = r.covariance.bottomRightCorner<3, 3>();
}

void Registration::retire(Robot& r, std::int64_t now_ns) {
  const auto window_ns = static_cast<std::int64_t>(options_.window_s * 1e9);
  auto leaves = [&](const WindowScan& ws) {
    return ws.stamp_ns < now_ns - window_ns || (options_.window_m > 0 && r.path_m - ws.path_m > options_.window_m);
  };
  while (!r.window.empty() && leaves(r.window.front())) {
    // With the correction at the scan (the later matches applied): its place as well as it is known.
    WindowScan& ws = r.window.front();
    in_order([this, at_scan = ws.map_from_odom, points = std::move(ws.points)] {
      for (const Vec3& p : points) (void)reference_.add(corrected(at_scan, p));
      reference_voxels_.store(reference_.voxels(), std::memory_order_relaxed);
    });
    r.window.pop_front();
  }
}

void Registration::in_order(std::function<void()> job) {
  if (options_.match_delay_s <= 0.0) {
    job();
    return;
  }
  (void)worker_->submit(std::move(job));
}

void Registration::update_reference_if_due(std::int64_t stamp_ns) {
  if (reference_.changed_columns() > 0 &&
      (map_.size() == 0 || static_cast<double>(stamp_ns - map_built_ns_) * 1e-9 >= options_.update_every_s))
    update_reference(stamp_ns);
}

void Registration::try_match(Robot& r, std::int64_t stamp_ns, const Pose2& odom_pose) {
  if (r.job.pending) return;  // the last one is not fused yet
  if (static_cast<double>(stamp_ns - r.last_attempt_ns) * 1e-9 < options_.match_every_s) return;
  r.last_attempt_ns = stamp_ns;
  const double moved_m = std::hypot(odom_pose.x_m - r.odom_at_match.x_m, odom_pose.y_m - r.odom_at_match.y_m);
  const double turned_rad = std::abs(normalize_angle(odom_pose.theta_rad - r.odom_at_match.theta_rad));
  if (moved_m < options_.min_motion_m && turned_rad < options_.min_motion_rad) {
    ++r.c.standing_still;
    return;
  }
  in_order([this, stamp_ns] { update_reference_if_due(stamp_ns); });
  // At once: the first lap is told here; on the match thread, by the match (finish()).
  if (options_.match_delay_s <= 0.0 && map_.size() < options_.min_map_features) {
    ++r.c.first_lap;
    return;
  }
  MatchJob& j = r.job;
  // The window is matched as one rigid piece in the odometry frame of now: each scan's points moved by
  // the correction's change since it (the rates' extrapolation; none when the correction was held).
  const Pose2 now_from_map = r.c.map_from_odom.inverse();
  j.pieces.clear();
  for (const WindowScan& ws : r.window) {
    j.pieces.push_back({now_from_map * ws.map_from_odom, ws.map_from_odom == r.c.map_from_odom, ws.points});
  }
  // The bounded step opens with the prediction's uncertainty (3σ): a robot that went unmatched for a
  // while may move further, one matched a moment ago may not jump.
  j.options = options_.match;
  MatchOptions& mo = j.options;
  const double sigma_m = std::sqrt(std::max(r.c.covariance(0, 0), r.c.covariance(1, 1)));
  mo.max_step_m = std::max(mo.max_step_m, 3.0 * sigma_m);
  mo.max_step_rad = std::max(mo.max_step_rad, 3.0 * std::sqrt(r.c.covariance(2, 2)));
  mo.gate_start_m = std::max(mo.gate_start_m, mo.max_step_m + mo.gate_end_m);
  j.prior = r.c.map_from_odom;
  j.odom_pose = odom_pose;
  j.pending = true;
  if (options_.match_delay_s <= 0.0) {
    j.ticket = 0;
    compute(j);
    finish(r);
    return;
  }
  j.apply_ns = stamp_ns + static_cast<std::int64_t>(options_.match_delay_s * 1e9);
  in_order([this, &j] { compute(j); });
  j.ticket = worker_->submitted();
}

void Registration::compute(MatchJob& j) {
  j.first_lap = map_.size() < options_.min_map_features;
  if (j.first_lap) return;
  // The window as one rigid piece in the odometry frame of the match's scan.
  auto for_each_point = [&](auto&& f) {
    for (const WindowPiece& w : j.pieces)
      for (const Vec3& p : w.points) f(w.held ? p : corrected(w.now_from_scan, p));
  };
  if (options_.point_source) {
    // Each usable point is a source of its own, without a normal: it pairs with the nearest line.
    j.features.clear();
    for_each_point([&](const Vec3& p) { j.features.push_back({p.x, p.y, 0.0, 0.0, 1.0f}); });
  } else {
    window_grid_.clear();
    for_each_point([&](const Vec3& p) { (void)window_grid_.add(p); });
    window_grid_.features(j.features);
  }
  j.result = match(map_, j.features, j.prior, j.options);
}

void Registration::finish(Robot& r) {
  MatchJob& j = r.job;
  j.pending = false;
  if (j.first_lap) {
    ++r.c.first_lap;
    return;
  }
  MatchResult m = j.result;
  // Matched at its scan; the correction has since moved by the rates' extrapolation alone (no match is
  // fused in between): the measurement moves with it.
  if (r.c.map_from_odom != j.prior) {
    const Pose2 since = r.c.map_from_odom * j.prior.inverse();
    m.map_from_odom = since * m.map_from_odom;
    m.pivot_m = since.apply(m.pivot_m);
  }
  ++r.c.matches;
  r.c.last = m;
  switch (m.status) {
    case MatchStatus::accepted: break;
    case MatchStatus::too_few_features: ++r.c.too_few_features; return;
    case MatchStatus::no_overlap: ++r.c.rejected_overlap; return;
    case MatchStatus::poor_fit: ++r.c.rejected_fit; return;
    case MatchStatus::step_too_large: ++r.c.rejected_step; return;
  }
  ++r.c.accepted;
  r.c.matched = true;
  if (m.degenerate) ++r.c.degenerate;
  fuse(r, m);
  r.odom_at_match = j.odom_pose;
}

void Registration::update_reference(std::int64_t stamp_ns) {
  // Only the columns a retired scan changed since the last update: their features are recomputed and
  // replace theirs in the index.
  reference_.take_changes(changes_, changed_features_);
  const std::span<const LineFeature> all{changed_features_};
  for (const ColumnChange& c : changes_) map_.replace(c.column, all.subspan(c.begin, c.end - c.begin));
  map_built_ns_ = stamp_ns;
  reference_updates_.fetch_add(1, std::memory_order_relaxed);
  reference_columns_updated_.fetch_add(changes_.size(), std::memory_order_relaxed);
  reference_last_update_columns_.store(changes_.size(), std::memory_order_relaxed);
  reference_features_.store(map_.size(), std::memory_order_relaxed);
}

void Registration::fuse(Robot& r, const MatchResult& m) {
  // Kalman update of the correction (and, through their correlation, the rates) with the match as a
  // measurement of the correction, both about the match's pivot.
  const Matrix6 to_match = pivot_jacobian(r.c.pivot_m, m.pivot_m);
  const Matrix6 p = to_match * r.covariance * to_match.transpose();
  const Eigen::Vector3d innovation = difference(m.map_from_odom, r.c.map_from_odom, m.pivot_m);
  const Eigen::Matrix<double, 6, 3> k = p.leftCols<3>() * (p.topLeftCorner<3, 3>() + m.covariance).inverse();
  const Eigen::Matrix<double, 6, 1> step = k * innovation;
  const Pose2 before = r.c.map_from_odom;
  r.c.map_from_odom = perturb(r.c.map_from_odom, m.pivot_m, step(0), step(1), step(2));
  if (options_.estimate_rates) {
    r.c.scale += step(3);
    r.c.drift_rad_per_m += step(4);
    r.c.turn += step(5);
  }
  Matrix6 updated = p - k * p.topRows<3>();
  updated = 0.5 * (updated + updated.transpose());
  r.covariance = pivot_jacobian(m.pivot_m, r.c.pivot_m) * updated * pivot_jacobian(m.pivot_m, r.c.pivot_m).transpose();
  r.c.covariance = r.covariance.topLeftCorner<3, 3>();
  r.c.rate_covariance = r.covariance.bottomRightCorner<3, 3>();
  // The window's scans were off by the same: they move with it (their change relative to now stays
  // the rates' extrapolation).
  const Pose2 moved = r.c.map_from_odom * before.inverse();
  for (WindowScan& ws : r.window) ws.map_from_odom = moved * ws.map_from_odom;
}

}  // namespace teamscan::registration
