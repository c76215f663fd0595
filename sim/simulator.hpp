// The team-survey simulator: robots drive their tracks in the world, their LMS-200s sweep at the real
// beam timing, their Pioneers report odometry; the labelled data set is computed from what a client
// decodes (range value words, SIP odometry interpolated at each beam's time, registered at the
// robot's start pose), with the ray cast's truth (class, hit robot, true hit point) per beam.
//
// Two paths with the same world, motion and noise models:
//  - device streams (default): per robot a PioneerEmulator and an LmsEmulator (drivers/) fed by the
//    wheel model and the ray caster, talking to an ArcosClient and an LmsClient over VirtualLinks in
//    simulated time, bring-up included; both sessions are recorded as captures, and the points are
//    what RobotReceiver (receiver.hpp) makes of the client-decoded bytes;
//  - direct (SimOptions::device_streams = false): the same device fields (devices.hpp) decoded in
//    process without bytes; faster, no captures, for quick experiments.
#pragma once

#include <cstdint>
#include <functional>
#include <optional>
#include <vector>

#include "common/capacities.hpp"
#include "common/capture.hpp"
#include "common/dataset/dataset.hpp"
#include "common/laser_geometry.hpp"
#include "common/odometry_history.hpp"
#include "sim/devices.hpp"
#include "sim/scenario.hpp"
#include "sim/track.hpp"
#include "sim/world.hpp"

namespace teamscan::sim {

// Scan timing of an LMS-200 (PROTOCOLS.md §2.10): one scan per sweep (1 revolution at 1°, 2 at 0.5°,
// 4 at 0.25°), but never faster than its 0xB0 telegram can be sent at the baud: the scanner then
// sends the newest complete scan when the line is free, so the period is a whole number of sweeps.
[[nodiscard]] std::size_t lms_b0_telegram_bytes(std::uint16_t values);
[[nodiscard]] Duration lms_scan_period(const LaserVariant& variant, std::uint32_t baud);

// The world of a scenario with every robot's body and motion, for casting beams at any time.
class TeamWorld {
 public:
  explicit TeamWorld(const Scenario& scenario);

  [[nodiscard]] const World& world() const { return world_; }
  [[nodiscard]] std::size_t robot_count() const { return motions_.size(); }
  [[nodiscard]] const Motion& motion(std::size_t index) const { return motions_[index]; }
  [[nodiscard]] const RobotBody& body(std::size_t index) const { return bodies_[index]; }
  [[nodiscard]] const RobotSpec& spec(std::size_t index) const { return specs_[index]; }
  // Default duration: until the last robot has finished driving.
  [[nodiscard]] double finish_s() const;

  // True poses of every robot at time t.
  void place(double t_s, std::vector<PlacedRobot>& out) const;
  // The ray of beam `angle_rad` of robot `index` with the robot at its true pose `map_from_robot`.
  [[nodiscard]] Ray beam_ray(std::size_t index, const Pose2& map_from_robot, double angle_rad) const;
  // The same with the beam's direction already in the robot frame (mount rotation applied).
  [[nodiscard]] Ray beam_ray(std::size_t index, const Pose2& map_from_robot, const Vec3& direction_in_robot) const;

 private:
  World world_;
  std::vector<RobotSpec> specs_;
  std::vector<RobotBody> bodies_;
  std::vector<Motion> motions_;
};

struct SimOptions {
  std::optional<std::uint64_t> seed;      // overrides the scenario's
  std::optional<double> duration_s;       // overrides the scenario's
  // Called now and then with the fraction done (0..1); for progress on stderr.
  std::function<void(double)> progress;
  bool device_streams = true;
  // Direct path only (device_streams = false): false = the odometry and the truth alone, no scan and
  // no point (a long scenario's dead reckoning checked without its ray casts).
  bool scans = true;
  // Device streams: the links start this long before t = 0 so both devices are up when the robots
  // start to drive (the robots stand still until then).
  double bringup_s = 5.0;
};

// The serial sessions of one robot, as the host saw them (captures/robotN-arcos.cap, -lms200.cap).
struct RobotCaptures {
  std::uint8_t id = 0;
  Capture arcos;
  Capture lms200;
  std::int64_t start_ns = 0;      // CLOCK_REALTIME of capture time 0
  bool arcos_connected = false;   // the client reached `connected` before t = 0
  bool lms_streaming = false;     // the client reached `streaming` before t = 0
};

struct RobotStats {
  std::uint8_t id = 0;
  std::uint64_t scans = 0, beams = 0, points = 0, invalid = 0, ghosts = 0;
  std::uint64_t ghosts_by_robot[kMaxRobots + 1] = {};  // ghosts of this robot's scans on robot k
};

struct SimOutput {
  Dataset dataset;
  std::vector<RobotStats> stats;
  std::vector<RobotCaptures> captures;  // device streams only
};

[[nodiscard]] SimOutput simulate(const Scenario& scenario, const SimOptions& options);

// Odometry history of one robot: decoded SIP poses at their times, interpolated between them as the
// robot's own odometry history does (odometry_history.hpp `pose_between`), clamped at the ends. Unlike
// that ring it keeps every sample: the direct simulation places a robot's scans after all its SIPs.
class PoseHistory {
 public:
  void push(std::int64_t stamp_ns, const Pose2& pose) { samples_.push_back({Time::from_ns(stamp_ns), pose}); }
  [[nodiscard]] Pose2 at(std::int64_t stamp_ns) const;
  [[nodiscard]] bool empty() const { return samples_.empty(); }

 private:
  std::vector<OdometrySample> samples_;
};

// The 3-D point of a beam in the map frame: map_from_odom · odom pose at the beam's time · mount.
[[nodiscard]] Vec3 beam_point_in_map(const Pose2& map_from_odom, const Pose2& odom_pose, const Pose3& robot_from_laser,
                                     double angle_rad, std::uint16_t range_mm);

}  // namespace teamscan::sim
