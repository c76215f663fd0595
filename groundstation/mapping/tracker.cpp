// Constant-velocity Kalman filter per robot (see tracker.hpp for the choice of model).
#include "groundstation/mapping/tracker.hpp"

#include <algorithm>
#include <cmath>

#include <Eigen/Dense>

namespace teamscan::mapping {

void RobotTrack::propagate(double dt_s, State& x, Covariance& p) const {
  Covariance f = Covariance::Identity();
  f(0, 2) = dt_s;
  f(1, 3) = dt_s;
  // Discrete white-noise acceleration: Q = q·[[dt³/3, dt²/2], [dt²/2, dt]] per axis, q = σ_a².
  // A backward prediction uses |dt|: uncertainty grows in both directions of time.
  const double t = std::abs(dt_s);
  const double q = options_.accel_noise_mps2 * options_.accel_noise_mps2;
  Covariance qm = Covariance::Zero();
  for (int axis = 0; axis < 2; ++axis) {
    qm(axis, axis) = q * t * t * t / 3.0;
    qm(axis, axis + 2) = qm(axis + 2, axis) = q * t * t / 2.0;
    qm(axis + 2, axis + 2) = q * t;
  }
  x = f * x;
  p = f * p * f.transpose() + qm;
}

void RobotTrack::follow_last_command(double dt_s, State& x, Covariance& p) const {
  // Position moves by ∫₀ᵗ R(ω s) v ds = A·v, velocity turns by R(ω t): linear in the state, so the
  // covariance is carried exactly (F P Fᵀ) and nothing is added to it.
  const double w = yaw_rate_radps_, a = w * dt_s;
  const double c = std::cos(a), s = std::sin(a);
  // A = [[S, -C], [C, S]] with S = sin(ωt)/ω, C = (1 − cos(ωt))/ω (→ t and ω t²/2 as ω → 0).
  const double big_s = std::abs(a) < 1e-9 ? dt_s : s / w;
  const double big_c = std::abs(a) < 1e-9 ? 0.5 * w * dt_s * dt_s : (1.0 - c) / w;
  Covariance f = Covariance::Identity();
  f(0, 2) = big_s;
  f(0, 3) = -big_c;
  f(1, 2) = big_c;
  f(1, 3) = big_s;
  f(2, 2) = c;
  f(2, 3) = -s;
  f(3, 2) = s;
  f(3, 3) = c;
  x = f * x;
  p = f * p * f.transpose();
}

double RobotTrack::command_horizon_s() const {
  // With the decision lag a robot that reports on time is predicted up to lag + one interval ahead.
  const double overdue_s = pose_interval_s_ > 0.0 ? std::min(options_.lost_after_s, 2.0 * pose_interval_s_) : options_.lost_after_s;
  return options_.team_lag_s + overdue_s;
}

void RobotTrack::update(std::int64_t stamp_ns, const Pose2& pose, double v_mps) {
  const double vx = v_mps * std::cos(pose.theta_rad), vy = v_mps * std::sin(pose.theta_rad);
  const double previous_heading = heading_rad_;
  heading_rad_ = pose.theta_rad;
  if (!initialised_) {
    x_ << pose.x_m, pose.y_m, options_.use_velocity ? vx : 0.0, options_.use_velocity ? vy : 0.0;
    p_.setZero();
    const double sp = options_.position_noise_m * options_.position_noise_m;
    const double sv = options_.use_velocity ? options_.velocity_noise_mps * options_.velocity_noise_mps
                                            : options_.initial_velocity_sigma_mps * options_.initial_velocity_sigma_mps;
    p_.diagonal() << sp, sp, sv, sv;
    stamp_ns_ = stamp_ns;
    start_ = pose;
    initialised_ = true;
    return;
  }
  const double dt_s = static_cast<double>(stamp_ns - stamp_ns_) * 1e-9;
  const double turned_rad = std::remainder(pose.theta_rad - previous_heading, 2.0 * 3.14159265358979323846);
  if (dt_s > 0.0) {
    pose_interval_s_ = dt_s;
    yaw_rate_radps_ = turned_rad / dt_s;
  }
  // Dead-reckoning drift (TrackerOptions::drift_*): linear growth with distance and turn.
  const double ds = std::abs(v_mps) * std::max(0.0, dt_s);
  const double dtheta = std::abs(turned_rad);
  drift_heading_sigma_rad_ += options_.drift_heading_rad_per_m * ds + options_.drift_heading_rad_per_rad * dtheta;
  distance_m_ += ds;
  // A heading error δθ accumulated so far turns the dead-reckoned path about where the robot started:
  // the position is off by δθ times the distance from the registration point (exact for a constant
  // δθ; bounded for a robot that loops in a room, unlike δθ·distance driven).
  slip_sigma_m_ += options_.drift_m_per_m * ds;
  const double from_start_m = std::hypot(pose.x_m - start_.x_m, pose.y_m - start_.y_m);
  drift_position_sigma_m_ = slip_sigma_m_ + drift_heading_sigma_rad_ * from_start_m;
  propagate(dt_s, x_, p_);
  stamp_ns_ = stamp_ns;
  const double rp = options_.position_noise_m * options_.position_noise_m;
  if (options_.use_velocity) {
    // Measurement z = H x + v with H = I (position and velocity measured).
    const Eigen::Vector4d z(pose.x_m, pose.y_m, vx, vy);
    const double rv = options_.velocity_noise_mps * options_.velocity_noise_mps;
    Eigen::Matrix4d r = Eigen::Matrix4d::Zero();
    r.diagonal() << rp, rp, rv, rv;
    const Eigen::Matrix4d s = p_ + r;
    const Eigen::Matrix4d k = p_ * s.inverse();
    x_ += k * (z - x_);
    // Joseph form keeps P symmetric and positive definite.
    const Eigen::Matrix4d i_kh = Eigen::Matrix4d::Identity() - k;
    p_ = i_kh * p_ * i_kh.transpose() + k * r * k.transpose();
  } else {
    Eigen::Matrix<double, 2, 4> h = Eigen::Matrix<double, 2, 4>::Zero();
    h(0, 0) = h(1, 1) = 1.0;
    const Eigen::Vector2d z(pose.x_m, pose.y_m);
    const Eigen::Matrix2d r = Eigen::Matrix2d::Identity() * rp;
    const Eigen::Matrix2d s = h * p_ * h.transpose() + r;
    const Eigen::Matrix<double, 4, 2> k = p_ * h.transpose() * s.inverse();
    x_ += k * (z - h * x_);
    const Eigen::Matrix4d i_kh = Eigen::Matrix4d::Identity() - k * h;
    p_ = i_kh * p_ * i_kh.transpose() + k * r * k.transpose();
  }
}

void RobotTrack::registered(double position_sigma_m, double heading_sigma_rad) {
  if (!initialised_ || !std::isfinite(position_sigma_m) || !std::isfinite(heading_sigma_rad)) return;
  start_ = Pose2{x_(0), x_(1), heading_rad_};
  slip_sigma_m_ = std::max(0.0, position_sigma_m);
  drift_heading_sigma_rad_ = std::max(0.0, heading_sigma_rad);
  drift_position_sigma_m_ = slip_sigma_m_;
}

RobotEstimate RobotTrack::predict(std::int64_t stamp_ns) const {
  RobotEstimate e;
  e.robot = robot_;
  e.stamp_ns = stamp_ns;
  e.last_update_ns = stamp_ns_;
  if (!initialised_) return e;
  State x = x_;
  Covariance p = p_;
  const double dt_s = static_cast<double>(stamp_ns - stamp_ns_) * 1e-9;
  // Forwards: at most coast_s (a silent robot stops, TrackerOptions::coast_s), with the process noise
  // up to the command horizon and on the last command's arc after it; backwards as asked.
  const double forward_s = std::min(dt_s, options_.coast_s);
  const double noisy_s = std::min(forward_s, command_horizon_s());
  propagate(noisy_s, x, p);
  const double silent_s = std::max(0.0, forward_s - noisy_s);
  if (silent_s > 0.0) follow_last_command(silent_s, x, p);
  e.lost = std::abs(dt_s) > options_.lost_after_s;
  e.valid = dt_s >= -options_.lost_after_s;
  if (dt_s > options_.coast_s) x.tail<2>().setZero();  // stopped
  e.position_m = {x(0), x(1)};
  e.velocity_mps = {x(2), x(3)};
  e.drift_cov_m2 = Eigen::Matrix2d::Identity() * (drift_position_sigma_m_ * drift_position_sigma_m_);
  e.position_cov_m2 = p.topLeftCorner<2, 2>() + e.drift_cov_m2;
  e.heading_rad = heading_rad_ + yaw_rate_radps_ * silent_s;
  e.heading_sigma_rad = drift_heading_sigma_rad_;
  e.distance_m = distance_m_;
  return e;
}

void TeamTracker::add_pose(std::uint8_t robot, std::int64_t stamp_ns, const Pose2& pose, double v_mps) {
  if (robot == 0 || robot > kMaxRobots || !std::isfinite(pose.x_m) || !std::isfinite(pose.y_m)) {
    ++rejected_;
    return;
  }
  for (RobotTrack& t : tracks_) {
    if (t.robot() == robot) {
      t.update(stamp_ns, pose, v_mps);
      return;
    }
  }
  tracks_.emplace_back(robot, options_);
  tracks_.back().update(stamp_ns, pose, v_mps);
}

void TeamTracker::registered(std::uint8_t robot, double position_sigma_m, double heading_sigma_rad) {
  for (RobotTrack& t : tracks_)
    if (t.robot() == robot) t.registered(position_sigma_m, heading_sigma_rad);
}

TeamState TeamTracker::predict(std::int64_t stamp_ns) const {
  TeamState team;
  team.stamp_ns = stamp_ns;
  team.robots.reserve(tracks_.size());
  for (const RobotTrack& t : tracks_) team.robots.push_back(t.predict(stamp_ns));
  return team;
}

const RobotTrack* TeamTracker::track(std::uint8_t robot) const {
  for (const RobotTrack& t : tracks_)
    if (t.robot() == robot) return &t;
  return nullptr;
}

}  // namespace teamscan::mapping
