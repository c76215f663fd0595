// The robot's data path without I/O (pipeline.hpp).
#include "onboard/core/pipeline.hpp"

#include <algorithm>
#include <cmath>

#include "common/units.hpp"

namespace teamscan::onboard {

namespace {
constexpr std::uint16_t kNotKept =
    kPointDirectionFiltered | kPointInvalid | kPointDazzled | kPointNoPose | kPointOutOfRange;
}  // namespace

Result<OnboardPipeline> OnboardPipeline::create(const OnboardConfig& config) {
  Result<DirectionFilter> filter = DirectionFilter::create(config.filter, config.robot_id);
  if (!filter.ok()) return filter.error();
  return OnboardPipeline{config, filter.value()};
}

OnboardPipeline::OnboardPipeline(const OnboardConfig& config, DirectionFilter filter)
    : robot_id_{config.robot_id},
      filter_enabled_{config.filter_enabled},
      publish_{config.publish},
      map_from_odom_{config.map_from_odom()},
      projector_{config.mount.robot_from_laser(), config.map_from_odom(),
                 ScanPointsOptions{config.max_range_mm(), config.odometry_max_extrapolation}},
      filter_{filter},
      variant_{config.lms_variant} {}

bool OnboardPipeline::on_odometry(Time stamp, const Pose2& odom_from_robot, double trans_vel_mm_s,
                                  double rot_vel_rad_s, OnboardPose& out) {
  if (!odometry_.push(stamp, odom_from_robot)) {
    ++counters_.odometry_rejected;
    return false;
  }
  ++counters_.poses;
  const Pose2 map_from_robot = map_from_odom_ * odom_from_robot;
  out.robot_id = robot_id_;
  out.seq = ++pose_seq_;
  out.stamp_ns = stamp.ns();
  out.x_mm = to_mm(map_from_robot.x_m);
  out.y_mm = to_mm(map_from_robot.y_m);
  out.yaw_urad = static_cast<std::int32_t>(std::lround(map_from_robot.theta_rad * 1e6));
  out.vx_mmps = static_cast<std::int32_t>(std::lround(trans_vel_mm_s * std::cos(map_from_robot.theta_rad)));
  out.vy_mmps = static_cast<std::int32_t>(std::lround(trans_vel_mm_s * std::sin(map_from_robot.theta_rad)));
  out.yaw_rate_mradps = round_saturated<std::int32_t>(rot_vel_rad_s * 1e3);
  return true;
}

TeamCheck OnboardPipeline::on_team(const TeamSnapshot& team, Time now) {
  const TeamCheck check = check_team(team, now, team_limits_);
  if (!check.ok()) {
    ++team_checks_.rejected;
    ++team_checks_.by_reason[static_cast<std::size_t>(check.reason)];
    team_checks_.last_reject = check.reason;
    return check;  // the filter keeps the last good state
  }
  ++team_checks_.accepted;
  take_own_correction(team);
  filter_.set_team(team);
  ++counters_.teams;
  have_team_ = true;
  newest_team_valid_ns_ = 0;
  const std::uint32_t n = std::min<std::uint32_t>(team.count, static_cast<std::uint32_t>(kMaxRobots));
  for (std::uint32_t i = 0; i < n; ++i) newest_team_valid_ns_ = std::max(newest_team_valid_ns_, team.members[i].valid_ns);
  return check;
}

void OnboardPipeline::take_own_correction(const TeamSnapshot& team) {
  const std::uint32_t n = std::min<std::uint32_t>(team.count, static_cast<std::uint32_t>(kMaxRobots));
  for (std::uint32_t i = 0; i < n; ++i) {
    const TeamMemberState& m = team.members[i];
    if (m.robot_id != robot_id_) continue;
    const OdomCorrection& next = m.correction;
    // The one in use (or still none). Compared whole: a restarted station numbers from 1 again.
    if (next.seq == applied_.seq && next.x_mm == applied_.x_mm && next.y_mm == applied_.y_mm &&
        next.yaw_urad == applied_.yaw_urad)
      return;
    if (!next.none() && !correction_step_ok(applied_, next, team_limits_)) {
      ++counters_.corrections_rejected;
      return;
    }
    applied_ = next;
    ++counters_.corrections_applied;
    projector_.set_map_from_odom(applied_.map_from_odom() * map_from_odom_);
    return;
  }
}

bool OnboardPipeline::team_fresh(Time now) const {
  return have_team_ && filter_.fresh(Time::from_ns(newest_team_valid_ns_), now);
}

const ScanPoints* OnboardPipeline::on_scan(BeamSpans beams, Time stamp) {
  if (!projector_.project(beams, stamp, variant_, odometry_, scan_)) {
    ++counters_.scans_refused;
    return nullptr;
  }
  ++counters_.scans;
  counters_.points += scan_.count;
  counters_.points_no_pose += scan_.unplaced;
  filter_stats_ = DirectionFilterStats{};
  if (filter_enabled_) {
    if (scan_.pose_ok) {
      // R1 of eq. 7 is this robot's own position at the scan's stamp, corrected like its teammates'.
      filter_stats_ = filter_.apply(to_mm(scan_.map_from_robot.x_m), to_mm(scan_.map_from_robot.y_m),
                                    scan_.stamp, scan_.points.data(), scan_.count);
    } else {
      ++counters_.scans_without_pose;
    }
  }
  counters_.points_direction_filtered += filter_stats_.filtered;
  counters_.points_team_stale += filter_stats_.stale_points;

  scan_.robot_id = robot_id_;
  ++scan_.seq;  // the projector leaves robot_id, seq and applied alone
  scan_.applied = applied_;
  if (publish_ == PublishMode::kept) {
    // Only the kept points, moved forward in place (beam order kept; each point carries its beam).
    std::uint16_t n = 0;
    for (std::uint16_t i = 0; i < scan_.count; ++i) {
      if ((scan_.points[i].flags & kNotKept) == 0) scan_.points[n++] = scan_.points[i];
    }
    scan_.count = n;
  }
  counters_.points_published += scan_.count;
  return &scan_;
}

}  // namespace teamscan::onboard
