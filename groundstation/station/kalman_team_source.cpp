// KalmanTeamSource: adapter from PoseObservation / TeamMemberEstimate to mapping::TeamTracker.
#include "groundstation/station/kalman_team_source.hpp"

#include <algorithm>
#include <cmath>

namespace teamscan::station {

KalmanTeamSource::KalmanTeamSource(const mapping::TrackerOptions& options, const RobotBody& default_body)
    : tracker_{options} {
  body_.fill(default_body);
}

void KalmanTeamSource::add_pose(const PoseObservation& p) {
  if (p.robot_id == 0 || p.robot_id > kMaxRobots) return;
  // The wire carries the map-frame velocity; the tracker takes the forward speed.
  const double v_mps = forward_speed_mps(p.vx_mps, p.vy_mps, p.yaw_rad);
  tracker_.add_pose(static_cast<std::uint8_t>(p.robot_id), p.stamp.ns(), map_from_odom_[p.robot_id] * Pose2{p.x_m, p.y_m, p.yaw_rad},
                    v_mps);
}

void KalmanTeamSource::set_correction(std::uint32_t robot_id, double x_m, double y_m, double yaw_rad, double position_sigma_m,
                                      double heading_sigma_rad, bool measurement) {
  if (robot_id == 0 || robot_id > kMaxRobots || !std::isfinite(x_m) || !std::isfinite(y_m) || !std::isfinite(yaw_rad)) return;
  map_from_odom_[robot_id] = Pose2{x_m, y_m, yaw_rad};
  Correction& c = correction_[robot_id];
  // Numbered 1, 2, ... (0 is "none"; a wrap skips it).
  std::uint32_t seq = c.wire.seq + 1;
  if (seq == 0) seq = 1;
  c.wire = OdomCorrection::from_pose(map_from_odom_[robot_id], seq);
  c.sigma_m = position_sigma_m;
  c.sigma_yaw_rad = heading_sigma_rad;
  if (measurement) tracker_.registered(static_cast<std::uint8_t>(robot_id), position_sigma_m, heading_sigma_rad);
}

void KalmanTeamSource::set_lost(std::uint32_t robot_id, bool lost) {
  if (robot_id >= 1 && robot_id <= kMaxRobots) lost_[robot_id] = lost;
}

void KalmanTeamSource::set_body(std::uint32_t robot_id, const RobotBody& body) {
  if (robot_id >= 1 && robot_id <= kMaxRobots) body_[robot_id] = body;
}

std::size_t KalmanTeamSource::estimate(Time at, std::span<TeamMemberEstimate> out) const {
  mapping::TeamState team = tracker_.predict(at.ns());
  std::sort(team.robots.begin(), team.robots.end(),
            [](const mapping::RobotEstimate& a, const mapping::RobotEstimate& b) { return a.robot < b.robot; });
  std::size_t n = 0;
  for (const mapping::RobotEstimate& r : team.robots) {
    if (n >= out.size()) break;
    if (r.robot == 0 || r.robot > kMaxRobots) continue;
    TeamMemberEstimate& e = out[n++];
    e.robot_id = r.robot;
    e.x_m = r.position_m.x;
    e.y_m = r.position_m.y;
    e.vx_mps = r.velocity_mps.x;
    e.vy_mps = r.velocity_mps.y;
    e.cov_xx_m2 = r.position_cov_m2(0, 0);
    e.cov_xy_m2 = r.position_cov_m2(0, 1);
    e.cov_yy_m2 = r.position_cov_m2(1, 1);
    e.body = body_[r.robot];
    e.valid = Time::from_ns(r.stamp_ns);
    // Lost by liveliness (the station) or by the tracker's own age limit (no pose for lost_after_s).
    e.lost = lost_[r.robot] || r.lost;
    e.correction = correction_[r.robot].wire;
    e.correction_sigma_m = correction_[r.robot].sigma_m;
    e.correction_sigma_yaw_rad = correction_[r.robot].sigma_yaw_rad;
  }
  return n;
}

}  // namespace teamscan::station
