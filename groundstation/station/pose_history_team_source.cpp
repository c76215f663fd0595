// PoseHistoryTeamSource: teamscan/team members from the pose history's newest tracks (pose_history_team_source.hpp).
#include "groundstation/station/pose_history_team_source.hpp"

#include <cmath>

#include "groundstation/station/fusion.hpp"

namespace teamscan::station {

PoseHistoryTeamSource::PoseHistoryTeamSource(const fusion::PoseHistory& history, const RobotBody& default_body)
    : history_{history} {
  body_.fill(default_body);
}

PoseHistoryTeamSource::PoseHistoryTeamSource(const fusion::PoseHistoryOptions& options, const RobotBody& default_body)
    : owned_{std::make_unique<fusion::PoseHistory>(options)}, history_{*owned_} {
  body_.fill(default_body);
}

void PoseHistoryTeamSource::add_pose(const PoseObservation& p) {
  if (owned_ == nullptr || p.robot_id == 0 || p.robot_id > kMaxRobots) return;
  (void)owned_->add(pose_input(p));  // the fusion stage's conversion: the same input the core gets
}

void PoseHistoryTeamSource::set_correction(std::uint32_t robot_id, double x_m, double y_m, double yaw_rad,
                                           double position_sigma_m, double heading_sigma_rad, bool measurement) {
  if (robot_id == 0 || robot_id > kMaxRobots || !std::isfinite(x_m) || !std::isfinite(y_m) || !std::isfinite(yaw_rad)) return;
  const Pose2 map_from_odom{x_m, y_m, yaw_rad};
  Correction& c = correction_[robot_id];
  // Numbered 1, 2, ... (0 is "none"; a wrap skips it).
  std::uint32_t seq = c.wire.seq + 1;
  if (seq == 0) seq = 1;
  c.wire = OdomCorrection::from_pose(map_from_odom, seq);
  c.sigma_m = position_sigma_m;
  c.sigma_yaw_rad = heading_sigma_rad;
  if (owned_ != nullptr && owned_->known(static_cast<std::uint8_t>(robot_id))) {
    const auto id = static_cast<std::uint8_t>(robot_id);
    owned_->set_map_from_odom(id, owned_->newest_stamp(id) + 1, map_from_odom, position_sigma_m, heading_sigma_rad,
                              measurement);
  }
}

void PoseHistoryTeamSource::set_lost(std::uint32_t robot_id, bool lost) {
  if (robot_id >= 1 && robot_id <= kMaxRobots) lost_[robot_id] = lost;
}

void PoseHistoryTeamSource::set_body(std::uint32_t robot_id, const RobotBody& body) {
  if (robot_id >= 1 && robot_id <= kMaxRobots) body_[robot_id] = body;
}

std::size_t PoseHistoryTeamSource::estimate(Time at, std::span<TeamMemberEstimate> out) const {
  const mapping::TeamState team = history_.newest_tracks_at(at.ns());  // by robot id
  std::size_t n = 0;
  for (const mapping::RobotEstimate& r : team.robots) {
    if (n >= out.size()) break;
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
    // Lost by liveliness (the station) or by the track's own age limit (no pose for lost_after_s).
    e.lost = lost_[r.robot] || r.lost;
    e.correction = correction_[r.robot].wire;
    e.correction_sigma_m = correction_[r.robot].sigma_m;
    e.correction_sigma_yaw_rad = correction_[r.robot].sigma_yaw_rad;
  }
  return n;
}

}  // namespace teamscan::station
