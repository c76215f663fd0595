// Where teamscan/team comes from: the ground station feeds every received pose into a TeamSource and
// publishes its estimates at a fixed rate (DESIGN.md "DDS topics"). The station's
// one Kalman tracker, the fusion core's pose history, implements it (pose_history_team_source.hpp);
// LastPoseTeamSource is the simple stand-in (last pose, extrapolated, with a covariance that grows
// with the pose's age).
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>

#include "common/capacities.hpp"
#include "common/odom_correction.hpp"
#include "common/time.hpp"

namespace teamscan::station {

// A robot's body as the direction and position filters see it (paper: Pioneer 3-AT with laser mast).
struct RobotBody {
  double length_m = 0.508;  // Pioneer 3-AT: 508 x 497 mm footprint
  double width_m = 0.497;
  double height_m = 0.80;   // top of the laser mount above the floor
};

// One odometry pose as received (map frame, SI units inside the ground station).
struct PoseObservation {
  std::uint32_t robot_id = 0;
  std::uint32_t seq = 0;
  Time stamp;               // robot's CLOCK_REALTIME at the odometry reading
  Time received;            // ground station's CLOCK_REALTIME at take
  double x_m = 0.0;
  double y_m = 0.0;
  double yaw_rad = 0.0;
  double vx_mps = 0.0;      // map-frame velocity
  double vy_mps = 0.0;
  double yaw_rate_radps = 0.0;
};

// A tracked robot predicted to a time.
struct TeamMemberEstimate {
  std::uint32_t robot_id = 0;
  double x_m = 0.0;
  double y_m = 0.0;
  double vx_mps = 0.0;
  double vy_mps = 0.0;
  double cov_xx_m2 = 0.0;   // 2x2 position covariance
  double cov_xy_m2 = 0.0;
  double cov_yy_m2 = 0.0;
  RobotBody body;
  Time valid;               // CLOCK_REALTIME the estimate is predicted to
  bool lost = false;
  // The robot's current odometry correction (set_correction) in its wire form, numbered per robot
  // (1, 2, ...; none: 0), with its σ: teamscan/team hands it to the robot (TeamMember.corr_*).
  OdomCorrection correction;
  double correction_sigma_m = 0.0;
  double correction_sigma_yaw_rad = 0.0;
};

class TeamSource {
 public:
  virtual ~TeamSource() = default;
  virtual void add_pose(const PoseObservation& pose) = 0;
  // Liveliness: a lost robot stays in the estimates (last known place, flagged) until it comes back.
  virtual void set_lost(std::uint32_t robot_id, bool lost) = 0;
  virtual void set_body(std::uint32_t robot_id, const RobotBody& body) = 0;
  // The registration's correction of a robot's odometry (map_from_odom: x, y, yaw) with its position
  // and heading σ, from the fusion core (docs/registration.md): the poses that follow are corrected by
  // it, and the estimates carry it to the robot. `measurement`: an accepted match since the last one set
  // (the track is registered with the σ); else the drift rates' extrapolation, a change of frame only.
  // A source without a model of it ignores it (the last-pose stand-in: its estimates carry none).
  virtual void set_correction(std::uint32_t robot_id, double x_m, double y_m, double yaw_rad, double position_sigma_m,
                              double heading_sigma_rad, bool measurement) {
    (void)robot_id, (void)x_m, (void)y_m, (void)yaw_rad, (void)position_sigma_m, (void)heading_sigma_rad, (void)measurement;
  }
  // Writes every known robot predicted to `at` into `out` (ordered by robot id); returns the count.
  [[nodiscard]] virtual std::size_t estimate(Time at, std::span<TeamMemberEstimate> out) const = 0;
};

struct LastPoseOptions {
  double sigma0_m = 0.05;              // std-dev of a fresh odometry pose in the map frame
  double sigma_velocity_mps = 0.30;    // growth of the std-dev per second of pose age
  double max_extrapolation_s = 0.5;    // predict with the last velocity at most this far
  RobotBody default_body;
};

class LastPoseTeamSource final : public TeamSource {
 public:
  explicit LastPoseTeamSource(LastPoseOptions options = {}) : options_{options} {
    for (Slot& s : slots_) s.body = options_.default_body;
  }
  void add_pose(const PoseObservation& pose) override;
  void set_lost(std::uint32_t robot_id, bool lost) override;
  void set_body(std::uint32_t robot_id, const RobotBody& body) override;
  [[nodiscard]] std::size_t estimate(Time at, std::span<TeamMemberEstimate> out) const override;

 private:
  struct Slot {
    bool known = false;
    bool lost = false;
    PoseObservation last;
    RobotBody body;
  };
  LastPoseOptions options_;
  std::array<Slot, kMaxRobots + 1> slots_{};  // index = robot id (1..32)
};

}  // namespace teamscan::station
