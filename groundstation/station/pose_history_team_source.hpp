// teamscan/team from the station's one tracker: the fusion core's pose history
// (groundstation/fusion/pose_history.hpp), which also decides every scan's pose and the team state the
// filters use. The published members are each robot's Kalman track after its newest pose, predicted to
// the publication time (PoseHistory::newest_tracks_at), corrected by the robot's map_from_odom as the
// core set it (by stamp); this adds what only teamscan/team carries: liveliness (`lost`), the robots'
// bodies and each robot's newest accepted correction in wire form, numbered per robot.
//
// With the fusion stage on, the source views the primary core's history and add_pose does nothing (the
// stage's pose hook feeds the core). Without it (fusion.enabled = false, tests) it owns a history of
// its own, fed by add_pose, so the station still has exactly one tracker.
#pragma once

#include <array>
#include <memory>

#include "groundstation/fusion/pose_history.hpp"
#include "groundstation/station/team_source.hpp"

namespace teamscan::station {

class PoseHistoryTeamSource final : public TeamSource {
 public:
  // Views `history` (the fusion core's; it must outlive this source). add_pose is a no-op.
  explicit PoseHistoryTeamSource(const fusion::PoseHistory& history, const RobotBody& default_body = {});
  // Owns a history with these options, fed by add_pose.
  explicit PoseHistoryTeamSource(const fusion::PoseHistoryOptions& options, const RobotBody& default_body = {});

  void add_pose(const PoseObservation& pose) override;
  void set_lost(std::uint32_t robot_id, bool lost) override;
  void set_body(std::uint32_t robot_id, const RobotBody& body) override;
  // Keeps the correction's wire form and σ for the members (numbered 1, 2, ... per robot). A viewed
  // history already holds it (the core set it from its scan's stamp on); an owned one takes it from the
  // robot's next pose on (set_map_from_odom just after its newest pose; a `measurement` registers the
  // track, an extrapolation is a change of frame).
  void set_correction(std::uint32_t robot_id, double x_m, double y_m, double yaw_rad, double position_sigma_m,
                      double heading_sigma_rad, bool measurement) override;
  [[nodiscard]] std::size_t estimate(Time at, std::span<TeamMemberEstimate> out) const override;

  [[nodiscard]] const fusion::PoseHistory& history() const { return history_; }

 private:
  std::unique_ptr<fusion::PoseHistory> owned_;  // null: viewing the core's
  const fusion::PoseHistory& history_;
  std::array<bool, kMaxRobots + 1> lost_{};
  std::array<RobotBody, kMaxRobots + 1> body_{};
  struct Correction {
    OdomCorrection wire;  // the correction as teamscan/team carries it, numbered per robot
    double sigma_m = 0.0;
    double sigma_yaw_rad = 0.0;
  };
  std::array<Correction, kMaxRobots + 1> correction_{};
};

}  // namespace teamscan::station
