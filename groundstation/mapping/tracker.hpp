// Per-robot Kalman tracker of the team: constant-velocity state (x, y, vx, vy)
// in the map frame, fed with the odometry poses the robots publish, predicted to any time.
//
// Why constant velocity and not (x, y, θ, v, ω): the filters only need a teammate's horizontal
// position and its covariance at a scan's time, which lies within one pose period (100 ms at the SIP
// rate) of a measurement. The CV model is linear, so the Kalman filter is exact (no Jacobians, no
// angle wrapping in the state), and over ≤ 100 ms the turn a CTRV model would add is below
// v·ω·dt²/2 ≈ 1 mm at Pioneer speeds. Heading and speed are still used: they give the velocity
// measurement (v·cos θ, v·sin θ).
#pragma once

#include <cstdint>
#include <vector>

#include <Eigen/Core>

#include "common/capacities.hpp"
#include "common/pose.hpp"

namespace teamscan::mapping {

struct TrackerOptions {
  // Process noise: white acceleration with this standard deviation per axis (m/s²).
  double accel_noise_mps2 = 0.5;
  // Measurement noise of an odometry position (m, per axis) and velocity (m/s, per axis).
  double position_noise_m = 0.02;
  double velocity_noise_mps = 0.05;
  // Use (v cos θ, v sin θ) from the pose message as a velocity measurement.
  bool use_velocity = true;
  // Decision lag (fusion core, fusion/pose_history.hpp): the team and a scan's own pose at time t are
  // predicted to t from the poses stamped at or before t − team_lag_s. 0: from the newest pose at or
  // before t, exact, but a scan then waits for every robot's next pose (up to one pose period, 100 ms
  // at the Pioneer's SIP rate). A lag of one pose period plus the network's delay (0.15 s) lets a scan
  // be decided on arrival, with teammates predicted up to lag + one period ahead. Live and offline alike.
  double team_lag_s = 0.0;
  // Initial velocity uncertainty when the first pose of a robot arrives (m/s).
  double initial_velocity_sigma_mps = 1.0;
  // A track older than this (no measurement) is reported lost on teamscan/team (DDS liveliness does the
  // same live); the filters keep using it (`coast_s`).
  double lost_after_s = 1.0;
  // A robot that goes silent (daemon killed, link down) is still there: its Pioneer drives on for at
  // most the firmware's watchdog time (2 s, PROTOCOLS.md §1.6) and then stops. The prediction runs at
  // most this far past the last pose and then holds the robot there with the uncertainty it has
  // reached; it stays valid for the filters, so teammates' hits on it are removed.
  // While it coasts, the firmware executes the last command: speed and yaw rate stay what the last
  // poses showed. The process noise above stands for a live client changing its commands; it applies
  // until the robot's next pose is overdue (two pose intervals after the last pose: the next one was
  // due after one, and a whole further interval has passed without it; at most lost_after_s; plus
  // team_lag_s, by which decisions look back), and not after: a silent client changes nothing. From then on the estimate follows the last command's arc
  // (constant speed and yaw rate), the velocity uncertainty reached still spreading the position.
  double coast_s = 2.0;
  // Odometry drift (docs/beyond.md "Drift"). The Kalman filter smooths the poses a robot
  // reports, but those poses are dead reckoning from the robot's registration: their error against the
  // map grows with what the robot did since, and nothing in the pose stream shows it. Dead-reckoning
  // errors are dominated by systematic ones (wheel diameter, wheelbase, skid-steer slip in turns:
  // Borenstein & Feng's UMBmark), so σ grows linearly, as a worst-case sum over the robot's motion:
  //   σ_θ += drift_heading_rad_per_m · ds + drift_heading_rad_per_rad · |dθ|
  //   σ_p  = drift_m_per_m · distance + σ_θ · |p − p_registration|
  // (a heading error turns the dead-reckoned path about its start), with ds = |v|·dt from the reported
  // speed and dθ the reported heading change. σ_p is added to the
  // position covariance (isotropic), σ_θ is reported for the box's heading inflation. 0 = off.
  // Default: 0.5 % of the distance driven, the order of a calibrated odometry's error (UMBmark:
  // a few cm over a 16 m square after calibration, decimetres before); heading terms off by default
  // (their lever arm costs far more static points than they recover ghosts, docs/beyond.md "Drift").
  double drift_m_per_m = 0.005;
  double drift_heading_rad_per_m = 0.0;
  double drift_heading_rad_per_rad = 0.0;
};

// One robot's estimate at a time: what the filters consume (DESIGN.md teamscan/team).
struct RobotEstimate {
  std::uint8_t robot = 0;
  bool valid = false;                 // tracked (a pose at or before stamp_ns): the filters use it
  bool lost = false;                  // no pose for more than lost_after_s (teamscan/team's flag)
  std::int64_t stamp_ns = 0;          // time the estimate is for
  std::int64_t last_update_ns = 0;    // time of the last measurement folded in
  Vec2 position_m;
  Vec2 velocity_mps;
  Eigen::Matrix2d position_cov_m2 = Eigen::Matrix2d::Identity();
  double heading_rad = 0;             // last measured heading (not part of the state)
  // Odometry drift since the registration (TrackerOptions::drift_*): heading σ, and the position
  // covariance part it adds (already included in position_cov_m2).
  double heading_sigma_rad = 0;
  Eigen::Matrix2d drift_cov_m2 = Eigen::Matrix2d::Zero();
  double distance_m = 0;              // driven since the first pose (|v|·dt summed)
};

// The team's state at one time: every tracked robot predicted to `stamp_ns`.
struct TeamState {
  std::int64_t stamp_ns = 0;
  std::vector<RobotEstimate> robots;
  [[nodiscard]] const RobotEstimate* find(std::uint8_t robot) const {
    for (const RobotEstimate& r : robots)
      if (r.robot == robot) return &r;
    return nullptr;
  }
};

class RobotTrack {
 public:
  using State = Eigen::Vector4d;
  using Covariance = Eigen::Matrix4d;

  RobotTrack(std::uint8_t robot, const TrackerOptions& options) : robot_{robot}, options_{options} {}

  // Folds in one odometry pose (map frame) with its speed; predicts to `stamp_ns` first.
  void update(std::int64_t stamp_ns, const Pose2& pose, double v_mps);
  // The estimate predicted to any time (also before the last update: the model is run backwards).
  [[nodiscard]] RobotEstimate predict(std::int64_t stamp_ns) const;
  // A registration (a scan-to-map match, groundstation/registration): the robot's map position is
  // known again to `position_sigma_m` and its heading to `heading_sigma_rad` (the correction's
  // covariance). The dead-reckoning drift restarts from the last pose with these as its base, instead
  // of growing since the first pose; the poses that follow arrive corrected (map_from_odom), and the
  // filter takes them as before.
  void registered(double position_sigma_m, double heading_sigma_rad);

  [[nodiscard]] bool initialised() const { return initialised_; }
  // Yaw rate between the last two poses (rad/s; 0 after the first pose).
  [[nodiscard]] double yaw_rate_radps() const { return yaw_rate_radps_; }
  // How long after the last pose the process noise applies (TrackerOptions::coast_s).
  [[nodiscard]] double command_horizon_s() const;
  [[nodiscard]] const State& state() const { return x_; }
  [[nodiscard]] const Covariance& covariance() const { return p_; }
  [[nodiscard]] std::int64_t stamp_ns() const { return stamp_ns_; }
  [[nodiscard]] std::uint8_t robot() const { return robot_; }
  [[nodiscard]] double drift_position_sigma_m() const { return drift_position_sigma_m_; }
  [[nodiscard]] double drift_heading_sigma_rad() const { return drift_heading_sigma_rad_; }

 private:
  void propagate(double dt_s, State& x, Covariance& p) const;
  // The firmware's last command for dt_s: the velocity turns at the yaw rate, no process noise.
  void follow_last_command(double dt_s, State& x, Covariance& p) const;

  std::uint8_t robot_;
  TrackerOptions options_;
  bool initialised_ = false;
  std::int64_t stamp_ns_ = 0;
  double pose_interval_s_ = 0;  // between the last two poses (0 after the first)
  double heading_rad_ = 0;
  double yaw_rate_radps_ = 0;
  // Dead-reckoning drift accumulated since the first pose (TrackerOptions::drift_*).
  double distance_m_ = 0;
  Pose2 start_;
  double slip_sigma_m_ = 0;
  double drift_heading_sigma_rad_ = 0;
  double drift_position_sigma_m_ = 0;
  State x_ = State::Zero();
  Covariance p_ = Covariance::Identity();
};

class TeamTracker {
 public:
  explicit TeamTracker(TrackerOptions options = {}) : options_{options} {}

  // Odometry pose of robot `robot` (1..kMaxRobots); poses of other ids are ignored and counted.
  void add_pose(std::uint8_t robot, std::int64_t stamp_ns, const Pose2& pose, double v_mps);
  // RobotTrack::registered for one robot (no track yet: ignored).
  void registered(std::uint8_t robot, double position_sigma_m, double heading_sigma_rad);
  // Every tracked robot predicted to `stamp_ns`; a robot is valid while its last pose is recent.
  [[nodiscard]] TeamState predict(std::int64_t stamp_ns) const;
  [[nodiscard]] const RobotTrack* track(std::uint8_t robot) const;
  [[nodiscard]] std::uint64_t rejected_poses() const { return rejected_; }
  [[nodiscard]] const TrackerOptions& options() const { return options_; }

 private:
  TrackerOptions options_;
  std::vector<RobotTrack> tracks_;
  std::uint64_t rejected_ = 0;
};

}  // namespace teamscan::mapping
