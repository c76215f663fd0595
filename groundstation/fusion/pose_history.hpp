// The one place that decides a scan's pose and the team's state at a time (DESIGN.md "groundstation/
// fusion"): every robot's odometry poses in stamp order, each with the Kalman track as it stood right
// after that pose. A scan's own pose lies between its robot's poses around the scan's stamp (a parabola
// through them and the pose before) when the later one is the pose that releases the scan or older
// (the robot's first pose at or after the stamp less the decision lag, TrackerOptions::team_lag_s, 0 by
// default) and within 0.25 s of the earlier; otherwise it is the newest pose at or before the stamp less
// the lag, moved on with the pose's velocity. The team at a time t is every robot's track after its
// newest pose at or before t − lag, predicted to t. Both are functions of the poses stamped up to the
// releasing pose, so they come out the same whether the poses arrived before or after the scan (live,
// arrival order) or in time order (offline).
//
// Each robot's odometry is corrected into the map frame by its `map_from_odom` (x, y, yaw): identity
// until the registration sets it. A correction holds from a stamp on (the stamp of the scan whose match
// produced it), so a pose's correction is a function of its stamp, not of when it arrived: setting one
// re-folds the poses stamped at or after it. The corrected poses feed the tracker and the filters.
//
// It is the station's one tracker: teamscan/team is published from these tracks (newest_tracks_at,
// station/pose_history_team_source.hpp), so the team the robots receive and the team the filters use
// come from the same poses, corrections and Kalman state.
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

  // The robot's map pose at `stamp_ns` (between the poses around it, else moved on from the newest at or
  // before the cutoff, else from the oldest kept: see the top), corrected by map_from_odom. No pose:
  // `found = false`.
  struct ScanPose {
    bool found = false;
    Pose2 map_from_robot;
    Pose2 odom;  // the same pose before map_from_odom (what the registration matches from)
  };
  [[nodiscard]] ScanPose scan_pose(std::uint8_t robot, std::int64_t stamp_ns) const;
  // Every robot with a pose at or before `stamp_ns`, its track predicted to `stamp_ns`, by robot id.
  [[nodiscard]] mapping::TeamState team_at(std::int64_t stamp_ns) const;
  // Every robot's track after its newest pose (whatever its stamp, no decision lag), predicted to
  // `stamp_ns`, by robot id: the team as the station publishes it now (teamscan/team), from the same
  // tracks the decisions read.
  [[nodiscard]] mapping::TeamState newest_tracks_at(std::int64_t stamp_ns) const;

  // A robot's correction from a stamp on, as set_map_from_odom set it.
  struct Correction {
    std::int64_t from_stamp_ns = 0;
    Pose2 map_from_odom;
    double position_sigma_m = 0.0;   // its σ about the robot's position
    double heading_sigma_rad = 0.0;
    bool measurement = false;        // a match: registers the Kalman track; else a change of frame only
  };
  // The registration's correction of a robot's odometry (identity until set), from `from_stamp_ns` on:
  // the poses stamped at or after it (held or still to come) are corrected by it and their tracks
  // folded again. A correction set again at the same stamp replaces the earlier one. A `measurement`
  // (an accepted match) also registers the Kalman track (RobotTrack::registered, with its σ) before the
  // first pose stamped at or after it; otherwise (the drift rates' extrapolation between matches) it is
  // a change of frame, whose σ is only carried (correction_at).
  void set_map_from_odom(std::uint8_t robot, std::int64_t from_stamp_ns, const Pose2& map_from_odom,
                         double position_sigma_m = 0.0, double heading_sigma_rad = 0.0, bool measurement = false);
  // The correction in force at `stamp_ns` (identity before the first).
  [[nodiscard]] Pose2 map_from_odom(std::uint8_t robot, std::int64_t stamp_ns) const;
  // The same with its stamp and σ: what the core applies to the poses and scans stamped `stamp_ns`, and
  // what teamscan/team hands the robot at a publication time (station CorrectionShare). nullptr: none.
  [[nodiscard]] const Correction* correction_at(std::uint8_t robot, std::int64_t stamp_ns) const;
  // Whether a robot has ever been corrected (identity is exact without one).
  [[nodiscard]] bool corrected(std::uint8_t robot) const { return robot <= kMaxRobots && !robots_[robot].corrections.empty(); }

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
    std::vector<Correction> corrections;  // from_stamp order
  };
  [[nodiscard]] const Entry* at_or_before(const Robot& r, std::int64_t stamp_ns) const;
  [[nodiscard]] static const Correction* in_force(const Robot& r, std::int64_t stamp_ns);
  [[nodiscard]] const Entry* at_or_after(const Robot& r, std::int64_t stamp_ns) const;
  // A scan between two poses further apart than this (a gap in the odometry, not the next 10 Hz SIP) is
  // placed from the pose before it, as past the newest pose.
  static constexpr std::int64_t kMaxInterpolationGapNs = 250'000'000;
  [[nodiscard]] static Pose2 between(const Robot& r, const Entry* a, const Entry* b, std::int64_t stamp_ns);
  [[nodiscard]] static Pose2 correction_at(const Robot& r, std::int64_t stamp_ns);
  // Recomputes the map poses and tracks of the entries from index `from` on.
  void refold(Robot& r, std::size_t from, std::uint8_t robot) const;
  // The track after entry k: entry k-1's (a new one for k = 0), registered by the corrections stamped
  // in (stamp of k-1, stamp of k], updated with entry k's map pose.
  [[nodiscard]] mapping::RobotTrack fold(const Robot& r, std::size_t k, std::uint8_t robot) const;

  PoseHistoryOptions options_;
  std::int64_t lag_ns_ = 0;  // options_.tracker.team_lag_s
  std::array<Robot, kMaxRobots + 1> robots_{};
  std::uint64_t duplicates_ = 0;
};

}  // namespace teamscan::fusion
