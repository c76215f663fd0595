// The one place that decides a scan's pose and the team's state at a time (DESIGN.md "groundstation/
// fusion"): every robot's odometry poses in stamp order, each with the Kalman track as it stood right
// after that pose. A scan's own pose is its robot's newest pose at or before the scan's stamp less the
// decision lag (TrackerOptions::team_lag_s, 0 by default), moved on with the pose's velocity; the team at
// a time t is every robot's track after its newest pose at or before t − lag, predicted to t. Both are
// functions of the poses stamped ≤ t − lag only, so they come out the same whether the poses arrived
// before or after the scan (live, arrival order) or in time order (offline).
//
// Each robot's odometry is corrected into the map frame by its `map_from_odom` (x, y, yaw): identity
// until the registration sets it. The corrected poses feed the tracker and the filters.
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include "common/capacities.hpp"
#include "common/pose.hpp"
#include "groundstation/mapping/tracker.hpp"

namespace teamscan::fusion {

// One odometry pose as the core takes it (map frame before map_from_odom; SI units).
struct PoseInput {
  std::uint8_t robot = 0;
  std::int64_t stamp_ns = 0;    // the robot's clock at the odometry reading
  std::int64_t arrival_ns = 0;  // when the station received it (offline: the stamp)
  Pose2 odom;
  double v_mps = 0.0;           // forward speed (common/pose.hpp forward_speed_mps)
  double w_radps = 0.0;         // yaw rate
};

struct PoseHistoryOptions {
  mapping::TrackerOptions tracker;
  // Poses (and their tracks) kept per robot: this far behind the robot's newest pose. A scan older
  // than that is decided against the oldest kept pose (late by more than any DDS history).
  double keep_s = 30.0;
};

class PoseHistory {
 public:
  explicit PoseHistory(PoseHistoryOptions options);

  // Adds a pose (any order; a pose with a robot's existing stamp is a duplicate and ignored).
  // false: ignored (duplicate, robot id out of range, non-finite).
  bool add(const PoseInput& pose);

  // The robot's map pose at `stamp_ns`: newest pose at or before (else the oldest kept), moved on
  // with its speed and yaw rate, corrected by map_from_odom. No pose: nullopt-like `found = false`.
  struct ScanPose {
    bool found = false;
    Pose2 map_from_robot;
  };
  [[nodiscard]] ScanPose scan_pose(std::uint8_t robot, std::int64_t stamp_ns) const;
  // Every robot with a pose at or before `stamp_ns`, its track predicted to `stamp_ns`, by robot id.
  [[nodiscard]] mapping::TeamState team_at(std::int64_t stamp_ns) const;

  // The registration's correction of a robot's odometry (identity until set). Applies to poses
  // added after the call.
  void set_map_from_odom(std::uint8_t robot, const Pose2& map_from_odom);
  [[nodiscard]] const Pose2& map_from_odom(std::uint8_t robot) const { return robots_[robot].map_from_odom; }

  // The newest pose stamp that decides a scan stamped `stamp_ns`: stamp − tracker.team_lag_s. A scan's
  // pose and team are final once every robot has a pose stamped at or after it.
  [[nodiscard]] std::int64_t cutoff(std::int64_t stamp_ns) const { return stamp_ns - lag_ns_; }
  // Newest pose stamp of a robot (INT64_MIN: none) and whether it has any.
  [[nodiscard]] std::int64_t newest_stamp(std::uint8_t robot) const;
  [[nodiscard]] bool known(std::uint8_t robot) const { return robot <= kMaxRobots && !robots_[robot].entries.empty(); }
  [[nodiscard]] std::size_t poses_held() const;
  [[nodiscard]] std::uint64_t duplicates() const { return duplicates_; }
  [[nodiscard]] const PoseHistoryOptions& options() const { return options_; }
  void clear();

 private:
  struct Entry {
    PoseInput pose;          // as received
    Pose2 map_pose;          // corrected into the map frame
    mapping::RobotTrack track;  // after this pose
  };
  struct Robot {
    std::vector<Entry> entries;  // stamp order
    Pose2 map_from_odom;
  };
  [[nodiscard]] const Entry* at_or_before(const Robot& r, std::int64_t stamp_ns) const;

  PoseHistoryOptions options_;
  std::int64_t lag_ns_ = 0;  // options_.tracker.team_lag_s
  std::array<Robot, kMaxRobots + 1> robots_{};
  std::uint64_t duplicates_ = 0;
};

}  // namespace teamscan::fusion
