// TeamSource over the mapping engineer's Kalman tracker (groundstation/mapping/tracker.hpp): the
// constant-velocity filter per robot, fed with every received pose, predicted to the publication time.
// With the registration on, each robot's poses are corrected by its map_from_odom before the tracker,
// and a new measured correction registers the track (its σ replaces the accumulated drift): teamscan/team
// carries the corrected poses and each robot's correction.
#pragma once

#include <array>

#include "groundstation/mapping/tracker.hpp"
#include "groundstation/station/team_source.hpp"

namespace teamscan::station {

class KalmanTeamSource final : public TeamSource {
 public:
  explicit KalmanTeamSource(const mapping::TrackerOptions& options, const RobotBody& default_body = {});
  void add_pose(const PoseObservation& pose) override;
  void set_lost(std::uint32_t robot_id, bool lost) override;
  void set_body(std::uint32_t robot_id, const RobotBody& body) override;
  void set_correction(std::uint32_t robot_id, double x_m, double y_m, double yaw_rad, double position_sigma_m,
                      double heading_sigma_rad, bool measurement) override;
  [[nodiscard]] std::size_t estimate(Time at, std::span<TeamMemberEstimate> out) const override;

 private:
  mapping::TeamTracker tracker_;
  std::array<bool, kMaxRobots + 1> lost_{};
  std::array<RobotBody, kMaxRobots + 1> body_{};
  std::array<Pose2, kMaxRobots + 1> map_from_odom_{};
  struct Correction {
    OdomCorrection wire;  // map_from_odom_ as teamscan/team carries it, numbered per robot
    double sigma_m = 0.0;
    double sigma_yaw_rad = 0.0;
  };
  std::array<Correction, kMaxRobots + 1> correction_{};
};

}  // namespace teamscan::station
