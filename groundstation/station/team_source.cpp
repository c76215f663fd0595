// LastPoseTeamSource: constant-velocity extrapolation of the newest pose, isotropic covariance
// sigma(age) = sigma0 + sigma_velocity * age.
#include "groundstation/station/team_source.hpp"

#include <algorithm>

namespace teamscan::station {

void LastPoseTeamSource::add_pose(const PoseObservation& pose) {
  if (pose.robot_id == 0 || pose.robot_id > kMaxRobots) return;
  Slot& s = slots_[pose.robot_id];
  // Out-of-order delivery cannot happen per writer (reliable), but a restarted robot restarts seq:
  // the newest stamp wins.
  if (s.known && pose.stamp < s.last.stamp) return;
  s.known = true;
  s.last = pose;
}

void LastPoseTeamSource::set_lost(std::uint32_t robot_id, bool lost) {
  if (robot_id == 0 || robot_id > kMaxRobots) return;
  slots_[robot_id].lost = lost;
}

void LastPoseTeamSource::set_body(std::uint32_t robot_id, const RobotBody& body) {
  if (robot_id == 0 || robot_id > kMaxRobots) return;
  slots_[robot_id].body = body;
}

std::size_t LastPoseTeamSource::estimate(Time at, std::span<TeamMemberEstimate> out) const {
  std::size_t n = 0;
  for (std::uint32_t id = 1; id <= kMaxRobots && n < out.size(); ++id) {
    const Slot& s = slots_[id];
    if (!s.known) continue;
    const double age_s = std::max(0.0, to_seconds(at - s.last.stamp));
    // A lost robot is not moving as far as we know: hold its last position, not its last velocity.
    const double dt_s = s.lost ? 0.0 : std::min(age_s, options_.max_extrapolation_s);
    const double sigma_m = options_.sigma0_m + options_.sigma_velocity_mps * age_s;
    TeamMemberEstimate& e = out[n++];
    e.robot_id = id;
    e.x_m = s.last.x_m + s.last.vx_mps * dt_s;
    e.y_m = s.last.y_m + s.last.vy_mps * dt_s;
    e.vx_mps = s.lost ? 0.0 : s.last.vx_mps;
    e.vy_mps = s.lost ? 0.0 : s.last.vy_mps;
    e.cov_xx_m2 = sigma_m * sigma_m;
    e.cov_xy_m2 = 0.0;
    e.cov_yy_m2 = sigma_m * sigma_m;
    e.body = s.body;
    e.valid = at;
    e.lost = s.lost;
  }
  return n;
}

}  // namespace teamscan::station
