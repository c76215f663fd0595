// PoseHistory: per-robot poses with their tracks, the scan pose and the team at a time (pose_history.hpp).
#include "groundstation/fusion/pose_history.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace teamscan::fusion {

PoseHistory::PoseHistory(PoseHistoryOptions options)
    : options_{options}, lag_ns_{static_cast<std::int64_t>(options.tracker.team_lag_s * 1e9)} {}

void PoseHistory::clear() {
  for (Robot& r : robots_) {
    r.entries.clear();
    r.corrections.clear();
  }
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

const PoseHistory::Correction* PoseHistory::in_force(const Robot& r, std::int64_t stamp_ns) {
  auto after = std::upper_bound(r.corrections.begin(), r.corrections.end(), stamp_ns,
                                [](std::int64_t t, const Correction& c) { return t < c.from_stamp_ns; });
  if (after == r.corrections.begin()) return nullptr;
  return &*std::prev(after);
}

Pose2 PoseHistory::correction_at(const Robot& r, std::int64_t stamp_ns) {
  const Correction* c = in_force(r, stamp_ns);
  return c != nullptr ? c->map_from_odom : Pose2{};
}

const PoseHistory::Correction* PoseHistory::correction_at(std::uint8_t robot, std::int64_t stamp_ns) const {
  if (robot == 0 || robot > kMaxRobots) return nullptr;
  return in_force(robots_[robot], stamp_ns);
}

Pose2 PoseHistory::map_from_odom(std::uint8_t robot, std::int64_t stamp_ns) const {
  if (robot == 0 || robot > kMaxRobots) return Pose2{};
  return correction_at(robots_[robot], stamp_ns);
}

void PoseHistory::set_map_from_odom(std::uint8_t robot, std::int64_t from_stamp_ns, const Pose2& map_from_odom,
                                    double position_sigma_m, double heading_sigma_rad, bool measurement) {
  if (robot == 0 || robot > kMaxRobots || !std::isfinite(map_from_odom.x_m) || !std::isfinite(map_from_odom.y_m) ||
      !std::isfinite(map_from_odom.theta_rad)) {
    return;
  }
  Robot& r = robots_[robot];
  auto at = std::lower_bound(r.corrections.begin(), r.corrections.end(), from_stamp_ns,
                             [](const Correction& c, std::int64_t t) { return c.from_stamp_ns < t; });
  const Correction c{from_stamp_ns, map_from_odom, std::isfinite(position_sigma_m) ? std::max(0.0, position_sigma_m) : 0.0,
                     std::isfinite(heading_sigma_rad) ? std::max(0.0, heading_sigma_rad) : 0.0, measurement};
  if (at != r.corrections.end() && at->from_stamp_ns == from_stamp_ns) {
    *at = c;
  } else {
    r.corrections.insert(at, c);
  }
  // The poses stamped at or after it: corrected again, their tracks folded again.
  auto first = std::lower_bound(r.entries.begin(), r.entries.end(), from_stamp_ns,
                                [](const Entry& e, std::int64_t t) { return e.pose.stamp_ns < t; });
  refold(r, static_cast<std::size_t>(first - r.entries.begin()), robot);
}

mapping::RobotTrack PoseHistory::fold(const Robot& r, std::size_t k, std::uint8_t robot) const {
  const Entry& e = r.entries[k];
  if (k == 0) {
    mapping::RobotTrack t(robot, options_.tracker);
    t.update(e.pose.stamp_ns, e.map_pose, e.pose.v_mps);
    return t;
  }
  mapping::RobotTrack t = r.entries[k - 1].track;
  const std::int64_t previous = r.entries[k - 1].pose.stamp_ns;
  // The registrations between the two poses (normally none; the newest one counts).
  auto after = std::upper_bound(r.corrections.begin(), r.corrections.end(), previous,
                                [](std::int64_t t0, const Correction& c) { return t0 < c.from_stamp_ns; });
  const Correction* registration = nullptr;
  for (; after != r.corrections.end() && after->from_stamp_ns <= e.pose.stamp_ns; ++after)
    if (after->measurement) registration = &*after;
  if (registration != nullptr) t.registered(registration->position_sigma_m, registration->heading_sigma_rad);
  t.update(e.pose.stamp_ns, e.map_pose, e.pose.v_mps);
  return t;
}

void PoseHistory::refold(Robot& r, std::size_t from, std::uint8_t robot) const {
  for (std::size_t k = from; k < r.entries.size(); ++k) {
    r.entries[k].map_pose = correction_at(r, r.entries[k].pose.stamp_ns) * r.entries[k].pose.odom;
    r.entries[k].track = fold(r, k, robot);
  }
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
  const Pose2 map_pose = correction_at(r, p.stamp_ns) * p.odom;
  // The track after this pose: the previous entry's track updated with it (a new track for the first).
  std::size_t i = static_cast<std::size_t>(at - r.entries.begin());
  r.entries.insert(at, Entry{p, map_pose, mapping::RobotTrack(p.robot, options_.tracker)});
  r.entries[i].track = fold(r, i, p.robot);
  // A pose older than the newest (a replayed history): the tracks after it are folded again.
  for (std::size_t k = i + 1; k < r.entries.size(); ++k) r.entries[k].track = fold(r, k, p.robot);
  // Bounded: drop what lies more than keep_s behind the newest, in batches (amortised O(1) per pose).
  const std::int64_t keep_ns = static_cast<std::int64_t>(options_.keep_s * 1e9);
  const std::int64_t newest = r.entries.back().pose.stamp_ns;
  if (r.entries.size() > 2 && r.entries.front().pose.stamp_ns < newest - 2 * keep_ns) {
    auto keep_from = std::lower_bound(r.entries.begin(), r.entries.end(), newest - keep_ns,
                                      [](const Entry& e, std::int64_t t) { return e.pose.stamp_ns < t; });
    r.entries.erase(r.entries.begin(), keep_from);
    // Corrections: those before the oldest kept pose go, but the one in force at it.
    const std::int64_t oldest = r.entries.front().pose.stamp_ns;
    auto in_force = std::upper_bound(r.corrections.begin(), r.corrections.end(), oldest,
                                     [](std::int64_t t, const Correction& c) { return t < c.from_stamp_ns; });
    if (in_force != r.corrections.begin()) r.corrections.erase(r.corrections.begin(), std::prev(in_force));
  }
  return true;
}

const PoseHistory::Entry* PoseHistory::at_or_before(const Robot& r, std::int64_t stamp_ns) const {
  auto after = std::upper_bound(r.entries.begin(), r.entries.end(), stamp_ns,
                                [](std::int64_t t, const Entry& e) { return t < e.pose.stamp_ns; });
  if (after == r.entries.begin()) return nullptr;
  return &*std::prev(after);
}

const PoseHistory::Entry* PoseHistory::at_or_after(const Robot& r, std::int64_t stamp_ns) const {
  auto at = std::lower_bound(r.entries.begin(), r.entries.end(), stamp_ns,
                             [](const Entry& e, std::int64_t t) { return e.pose.stamp_ns < t; });
  return at == r.entries.end() ? nullptr : &*at;
}

// The odometry at `stamp_ns` between two consecutive poses a and b (a.stamp < stamp < b.stamp): a
// parabola in time through the pose before a, a and b (x, y and heading), which follows a turn's
// changing rate where the straight line from a to b cuts the corner (corridor2's U-turns at 10 Hz
// poses: heading p99 1.07° linear, 0.47° so, against the truth); linear when there is no pose before a
// or its spacing is not comparable to a–b's (a gap in the poses).
Pose2 PoseHistory::between(const Robot& r, const Entry* a, const Entry* b, std::int64_t stamp_ns) {
  const double span = static_cast<double>(b->pose.stamp_ns - a->pose.stamp_ns);
  const double u = static_cast<double>(stamp_ns - a->pose.stamp_ns) / span;  // 0 at a, 1 at b
  const Pose2& pa = a->pose.odom;
  const Pose2& pb = b->pose.odom;
  const double dtheta_ab = normalize_angle(pb.theta_rad - pa.theta_rad);
  const Entry* m = a == r.entries.data() ? nullptr : a - 1;
  const double um = m == nullptr ? 0.0 : static_cast<double>(m->pose.stamp_ns - a->pose.stamp_ns) / span;
  if (m == nullptr || um < -2.0 || um > -0.5) {
    return Pose2{pa.x_m + u * (pb.x_m - pa.x_m), pa.y_m + u * (pb.y_m - pa.y_m), pa.theta_rad + u * dtheta_ab};
  }
  // Lagrange weights at u of the nodes um (< 0), 0 and 1; relative to a, so a's weight drops out.
  const double wm = u * (u - 1.0) / (um * (um - 1.0));
  const double wb = u * (u - um) / (1.0 - um);
  const Pose2& pm = m->pose.odom;
  return Pose2{pa.x_m + wm * (pm.x_m - pa.x_m) + wb * (pb.x_m - pa.x_m), pa.y_m + wm * (pm.y_m - pa.y_m) + wb * (pb.y_m - pa.y_m),
               pa.theta_rad + wm * normalize_angle(pm.theta_rad - pa.theta_rad) + wb * dtheta_ab};
}

PoseHistory::ScanPose PoseHistory::scan_pose(std::uint8_t robot, std::int64_t stamp_ns) const {
  ScanPose out;
  if (robot == 0 || robot > kMaxRobots || robots_[robot].entries.empty()) return out;
  const Robot& r = robots_[robot];
  out.found = true;
  // The pose that releases the scan: the robot's first at or after the cutoff. The poses up to it are
  // all there once it is (a robot's poses arrive in order), so they may decide the scan's pose.
  const Entry* releasing = at_or_after(r, cutoff(stamp_ns));
  const Entry* before = at_or_before(r, stamp_ns);
  const Entry* after = at_or_after(r, stamp_ns);
  if (releasing != nullptr && releasing->pose.stamp_ns >= stamp_ns && before != nullptr && after != nullptr &&
      after->pose.stamp_ns - before->pose.stamp_ns <= kMaxInterpolationGapNs) {
    out.odom = after == before ? before->pose.odom : between(r, before, after, stamp_ns);
  } else {
    // No next pose within reach (a decision lag shorter than the pose spacing, a gap in the odometry, a
    // scan after the newest pose or before the first): the newest pose at or before the cutoff (else the
    // oldest kept), moved on with its speed and yaw rate.
    const Entry* e = at_or_before(r, cutoff(stamp_ns));
    if (e == nullptr) e = &r.entries.front();
    const double dt_s = static_cast<double>(stamp_ns - e->pose.stamp_ns) * 1e-9;
    const Pose2& o = e->pose.odom;
    out.odom = Pose2{o.x_m + e->pose.v_mps * std::cos(o.theta_rad) * dt_s, o.y_m + e->pose.v_mps * std::sin(o.theta_rad) * dt_s,
                     o.theta_rad + e->pose.w_radps * dt_s};
  }
  // The correction in force at the scan's stamp (the one its points get), on the odometry.
  out.map_from_robot = correction_at(r, stamp_ns) * out.odom;
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

mapping::TeamState PoseHistory::newest_tracks_at(std::int64_t stamp_ns) const {
  mapping::TeamState team;
  team.stamp_ns = stamp_ns;
  for (std::size_t id = 1; id <= kMaxRobots; ++id) {
    const Robot& r = robots_[id];
    if (!r.entries.empty()) team.robots.push_back(r.entries.back().track.predict(stamp_ns));
  }
  return team;
}

}  // namespace teamscan::fusion
