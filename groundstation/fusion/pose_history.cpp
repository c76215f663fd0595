// PoseHistory: per-robot poses with their tracks, the scan pose and the team at a time (pose_history.hpp).
#include "groundstation/fusion/pose_history.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace teamscan::fusion {

PoseHistory::PoseHistory(PoseHistoryOptions options)
    : options_{options}, lag_ns_{static_cast<std::int64_t>(options.tracker.team_lag_s * 1e9)} {}

void PoseHistory::clear() {
  for (Robot& r : robots_) r.entries.clear();
  duplicates_ = 0;
}

std::size_t PoseHistory::poses_held() const {
  std::size_t n = 0;
  for (const Robot& r : robots_) n += r.entries.size();
  return n;
}

std::int64_t PoseHistory::newest_stamp(std::uint8_t robot) const {
  if (robot > kMaxRobots || robots_[robot].entries.empty()) return std::numeric_limits<std::int64_t>::min();
  return robots_[robot].entries.back().pose.stamp_ns;
}

void PoseHistory::set_map_from_odom(std::uint8_t robot, const Pose2& map_from_odom) {
  if (robot >= 1 && robot <= kMaxRobots) robots_[robot].map_from_odom = map_from_odom;
}

bool PoseHistory::add(const PoseInput& p) {
  if (p.robot == 0 || p.robot > kMaxRobots || !std::isfinite(p.odom.x_m) || !std::isfinite(p.odom.y_m) ||
      !std::isfinite(p.odom.theta_rad) || !std::isfinite(p.v_mps)) {
    return false;
  }
  Robot& r = robots_[p.robot];
  auto at = std::upper_bound(r.entries.begin(), r.entries.end(), p.stamp_ns,
                             [](std::int64_t t, const Entry& e) { return t < e.pose.stamp_ns; });
  if (at != r.entries.begin() && std::prev(at)->pose.stamp_ns == p.stamp_ns) {
    ++duplicates_;
    return false;
  }
  const Pose2 map_pose = r.map_from_odom * p.odom;
  // The track after this pose: the previous entry's track updated with it (a new track for the first).
  std::size_t i = static_cast<std::size_t>(at - r.entries.begin());
  mapping::RobotTrack track = i == 0 ? mapping::RobotTrack(p.robot, options_.tracker) : r.entries[i - 1].track;
  track.update(p.stamp_ns, map_pose, p.v_mps);
  r.entries.insert(at, Entry{p, map_pose, track});
  // A pose older than the newest (a replayed history): the tracks after it are folded again.
  for (std::size_t k = i + 1; k < r.entries.size(); ++k) {
    mapping::RobotTrack t = r.entries[k - 1].track;
    t.update(r.entries[k].pose.stamp_ns, r.entries[k].map_pose, r.entries[k].pose.v_mps);
    r.entries[k].track = t;
  }
  // Bounded: drop what lies more than keep_s behind the newest, in batches (amortised O(1) per pose).
  const std::int64_t keep_ns = static_cast<std::int64_t>(options_.keep_s * 1e9);
  const std::int64_t newest = r.entries.back().pose.stamp_ns;
  if (r.entries.size() > 2 && r.entries.front().pose.stamp_ns < newest - 2 * keep_ns) {
    auto keep_from = std::lower_bound(r.entries.begin(), r.entries.end(), newest - keep_ns,
                                      [](const Entry& e, std::int64_t t) { return e.pose.stamp_ns < t; });
    r.entries.erase(r.entries.begin(), keep_from);
  }
  return true;
}

const PoseHistory::Entry* PoseHistory::at_or_before(const Robot& r, std::int64_t stamp_ns) const {
  auto after = std::upper_bound(r.entries.begin(), r.entries.end(), stamp_ns,
                                [](std::int64_t t, const Entry& e) { return t < e.pose.stamp_ns; });
  if (after == r.entries.begin()) return nullptr;
  return &*std::prev(after);
}

PoseHistory::ScanPose PoseHistory::scan_pose(std::uint8_t robot, std::int64_t stamp_ns) const {
  ScanPose out;
  if (robot == 0 || robot > kMaxRobots || robots_[robot].entries.empty()) return out;
  const Robot& r = robots_[robot];
  const Entry* e = at_or_before(r, cutoff(stamp_ns));
  if (e == nullptr) e = &r.entries.front();
  const double dt_s = static_cast<double>(stamp_ns - e->pose.stamp_ns) * 1e-9;
  const Pose2& m = e->map_pose;
  out.found = true;
  out.map_from_robot = Pose2{m.x_m + e->pose.v_mps * std::cos(m.theta_rad) * dt_s,
                             m.y_m + e->pose.v_mps * std::sin(m.theta_rad) * dt_s, m.theta_rad + e->pose.w_radps * dt_s};
  return out;
}

mapping::TeamState PoseHistory::team_at(std::int64_t stamp_ns) const {
  mapping::TeamState team;
  team.stamp_ns = stamp_ns;
  for (std::size_t id = 1; id <= kMaxRobots; ++id) {
    const Robot& r = robots_[id];
    if (r.entries.empty()) continue;
    const Entry* e = at_or_before(r, cutoff(stamp_ns));
    if (e == nullptr) continue;  // not tracked yet at that time
    team.robots.push_back(e->track.predict(stamp_ns));
  }
  return team;
}

}  // namespace teamscan::fusion
