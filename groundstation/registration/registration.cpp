// Team registration: windows, reference, matching policy and the correction's Kalman filter
// (registration.hpp).
#include "groundstation/registration/registration.hpp"

#include <algorithm>
#include <cmath>

#include <Eigen/LU>

namespace teamscan::registration {

namespace {
SurfaceOptions with_cap(SurfaceOptions o, std::uint32_t cap) {
  o.voxel_cap = cap;
  return o;
}
}  // namespace

Registration::Registration(RegistrationOptions options)
    : options_{options}, reference_{options.surface}, window_grid_{with_cap(options.surface, options.window_voxel_cap)} {
  for (std::size_t id = 0; id < robots_.size(); ++id) robots_[id].c.robot = static_cast<std::uint8_t>(id);
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
    r.last_attempt_ns = stamp_ns;
    r.c.covariance = Eigen::Vector3d{options_.initial_sigma_m * options_.initial_sigma_m,
                                     options_.initial_sigma_m * options_.initial_sigma_m,
                                     options_.initial_sigma_rad * options_.initial_sigma_rad}
                         .asDiagonal();
    r.c.pivot_m = r.c.map_from_odom.apply({odom_pose.x_m, odom_pose.y_m});
  } else if (!r.window.empty() && stamp_ns < r.window.back().stamp_ns) {
    ++rejected_scans_;  // out of order: the window is a time window
    return r.c;
  }
  predict(r, odom_pose);
  WindowScan ws;
  ws.stamp_ns = stamp_ns;
  ws.points.reserve(points.size());
  for (std::size_t i = 0; i < points.size(); ++i)
    if (usable.empty() || usable[i]) ws.points.push_back(points[i]);
  r.window.push_back(std::move(ws));
  retire(r, stamp_ns);
  try_match(r, stamp_ns, odom_pose);
  return r.c;
}

void Registration::predict(Robot& r, const Pose2& odom_pose) {
  const double ds = std::hypot(odom_pose.x_m - r.last_odom.x_m, odom_pose.y_m - r.last_odom.y_m);
  const double dtheta = std::abs(normalize_angle(odom_pose.theta_rad - r.last_odom.theta_rad));
  r.last_odom = odom_pose;
  const Vec2 pivot = r.c.map_from_odom.apply({odom_pose.x_m, odom_pose.y_m});
  r.c.covariance = move_pivot(r.c.covariance, r.c.pivot_m, pivot);
  r.c.pivot_m = pivot;
  r.c.covariance(0, 0) += options_.drift_m2_per_m * ds;
  r.c.covariance(1, 1) += options_.drift_m2_per_m * ds;
  r.c.covariance(2, 2) += options_.drift_rad2_per_m * ds + options_.drift_rad2_per_rad * dtheta;
}

void Registration::retire(Robot& r, std::int64_t now_ns) {
  const auto window_ns = static_cast<std::int64_t>(options_.window_s * 1e9);
  while (!r.window.empty() && r.window.front().stamp_ns < now_ns - window_ns) {
    for (const Vec3& p : r.window.front().points)
      if (reference_.add(corrected(r.c.map_from_odom, p))) map_dirty_ = true;
    r.window.pop_front();
  }
}

void Registration::try_match(Robot& r, std::int64_t stamp_ns, const Pose2& odom_pose) {
  if (static_cast<double>(stamp_ns - r.last_attempt_ns) * 1e-9 < options_.match_every_s) return;
  r.last_attempt_ns = stamp_ns;
  const double moved_m = std::hypot(odom_pose.x_m - r.odom_at_match.x_m, odom_pose.y_m - r.odom_at_match.y_m);
  const double turned_rad = std::abs(normalize_angle(odom_pose.theta_rad - r.odom_at_match.theta_rad));
  if (moved_m < options_.min_motion_m && turned_rad < options_.min_motion_rad) {
    ++r.c.standing_still;
    return;
  }
  if (map_dirty_ && (map_.size() == 0 || static_cast<double>(stamp_ns - map_built_ns_) * 1e-9 >= options_.rebuild_every_s)) {
    std::vector<LineFeature> features;
    reference_.features(features);
    map_.build(std::move(features));
    map_built_ns_ = stamp_ns;
    map_dirty_ = false;
  }
  if (map_.size() < options_.min_map_features) {
    ++r.c.first_lap;
    return;
  }
  window_grid_.clear();
  for (const WindowScan& ws : r.window)
    for (const Vec3& p : ws.points) (void)window_grid_.add(p);
  window_grid_.features(scratch_);
  // The bounded step opens with the prediction's uncertainty (3σ): a robot that went unmatched for a
  // while may move further, one matched a moment ago may not jump.
  MatchOptions mo = options_.match;
  const double sigma_m = std::sqrt(std::max(r.c.covariance(0, 0), r.c.covariance(1, 1)));
  mo.max_step_m = std::max(mo.max_step_m, 3.0 * sigma_m);
  mo.max_step_rad = std::max(mo.max_step_rad, 3.0 * std::sqrt(r.c.covariance(2, 2)));
  mo.gate_start_m = std::max(mo.gate_start_m, mo.max_step_m + mo.gate_end_m);
  const MatchResult m = match(map_, scratch_, r.c.map_from_odom, mo);
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
  if (m.degenerate) ++r.c.degenerate;
  fuse(r, m);
  r.odom_at_match = odom_pose;
}

void Registration::fuse(Robot& r, const MatchResult& m) {
  // Kalman update of the correction with the match as a measurement, both about the match's pivot.
  const Eigen::Matrix3d p = move_pivot(r.c.covariance, r.c.pivot_m, m.pivot_m);
  const Eigen::Vector3d innovation = difference(m.map_from_odom, r.c.map_from_odom, m.pivot_m);
  const Eigen::Matrix3d k = p * (p + m.covariance).inverse();
  const Eigen::Vector3d step = k * innovation;
  r.c.map_from_odom = perturb(r.c.map_from_odom, m.pivot_m, step(0), step(1), step(2));
  Eigen::Matrix3d updated = (Eigen::Matrix3d::Identity() - k) * p;
  updated = 0.5 * (updated + updated.transpose());
  r.c.covariance = move_pivot(updated, m.pivot_m, r.c.pivot_m);
}

}  // namespace teamscan::registration
