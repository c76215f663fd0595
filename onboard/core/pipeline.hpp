// The robot's data path without I/O: odometry samples into the history, each LMS telegram's sweep into
// map-frame points (common/scan_points ScanPoints), flagged in place by the direction filter against the
// latest team state: that ScanPoints is the teamscan/scan message the DDS bridge publishes. Built once at start-up; after that nothing allocates (tests/unit/onboard
// allocation_test.cpp counts).
#pragma once

#include <cstdint>

#include "common/odometry_history.hpp"
#include "common/result.hpp"
#include "common/scan_points.hpp"
#include "common/time.hpp"
#include "onboard/core/config.hpp"
#include "onboard/core/direction_filter.hpp"
#include "onboard/core/messages.hpp"
#include "onboard/core/team_validation.hpp"

namespace teamscan::onboard {

struct PipelineCounters {
  std::uint64_t poses = 0;
  std::uint64_t odometry_rejected = 0;   // out-of-order SIP stamps
  std::uint64_t scans = 0;
  std::uint64_t scans_refused = 0;       // telegrams that were not one full sweep of the configured variant
  std::uint64_t scans_without_pose = 0;  // no odometry at the scan's stamp: not filtered
  std::uint64_t points = 0;
  std::uint64_t points_published = 0;
  std::uint64_t points_direction_filtered = 0;
  std::uint64_t points_team_stale = 0;
  std::uint64_t points_no_pose = 0;
  std::uint64_t teams = 0;
  std::uint64_t corrections_applied = 0;   // own corrections taken into use
  std::uint64_t corrections_rejected = 0;  // own corrections refused: an absurd step (correction_step_ok)
};

class OnboardPipeline {
 public:
  // The config has been checked by parse_onboard_config; the filter parameters are checked again here.
  [[nodiscard]] static Result<OnboardPipeline> create(const OnboardConfig& config);

  // One odometry reading (odometry frame) at `stamp` (CLOCK_REALTIME): into the history, and the
  // teamscan/pose sample in the map frame. False if refused (not newer than the last one; counted).
  bool on_odometry(Time stamp, const Pose2& odom_from_robot, double trans_vel_mm_s, double rot_vel_rad_s,
                   OnboardPose& out);

  // The newest team state (teamscan/team), received at `now` (CLOCK_REALTIME). Checked first
  // (team_validation.hpp): a refused state is counted and the filter keeps the last good one. An
  // accepted state's member for this robot brings its odometry correction: a new one (another
  // corr_seq) is taken into use for the scans that follow unless its step from the applied one is
  // absurd (counted; the applied one stays). None (corr_seq 0: the station has none, e.g. restarted)
  // goes back to the identity.
  TeamCheck on_team(const TeamSnapshot& team, Time now);

  // One sweep (lms200::ScanTelegram::sweep()) ending at `stamp`: points in the map frame corrected by the
  // applied correction (the teammates' positions in teamscan/team are corrected too), the direction
  // filter from this robot's corrected position flagging them in place, and the robot id, the next
  // sequence number and the correction it carries: the teamscan/scan sample (every point with its
  // flags, or, publish = kept, only the kept points). Null, counted in scans_refused, when the beams are
  // not one full sweep of the configured variant. The scan stays valid until the next call.
  const ScanPoints* on_scan(BeamSpans beams, Time stamp);

  // Continues the numbering after a restart: the next scan is scan_seq + 1, the next pose pose_seq + 1
  // (the newest ones the robot's ring recovered), so the station never sees a seq twice.
  void resume_after(std::uint32_t scan_seq, std::uint32_t pose_seq) {
    scan_.seq = scan_seq;
    pose_seq_ = pose_seq;
  }

  // The last scan on_scan made (the published one).
  [[nodiscard]] const ScanPoints& last_scan() const { return scan_; }
  [[nodiscard]] const DirectionFilterStats& last_filter_stats() const { return filter_stats_; }
  [[nodiscard]] const PipelineCounters& counters() const { return counters_; }
  [[nodiscard]] const TeamCheckCounters& team_checks() const { return team_checks_; }
  [[nodiscard]] const OdometryHistory<>& odometry() const { return odometry_; }
  [[nodiscard]] const OdomCorrection& applied_correction() const { return applied_; }
  [[nodiscard]] bool team_fresh(Time now) const;

 private:
  OnboardPipeline(const OnboardConfig& config, DirectionFilter filter);
  void take_own_correction(const TeamSnapshot& team);

  std::uint32_t robot_id_;
  bool filter_enabled_;
  PublishMode publish_;
  Pose2 map_from_odom_;     // the configured start pose: the odometry-map frame of teamscan/pose
  OdomCorrection applied_;  // this robot's correction in use (none: identity)
  ScanProjector projector_; // projects with applied_ · map_from_odom_
  DirectionFilter filter_;
  OdometryHistory<> odometry_;
  LaserVariant variant_;    // the configured scan variant: a sweep of another one is refused
  DirectionFilterStats filter_stats_;
  ScanPoints scan_;
  std::uint32_t pose_seq_ = 0;
  std::int64_t newest_team_valid_ns_ = 0;
  bool have_team_ = false;
  TeamCheckLimits team_limits_;
  TeamCheckCounters team_checks_;
  PipelineCounters counters_;
};

}  // namespace teamscan::onboard
