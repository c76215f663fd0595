// Scan-to-map registration of a robot team (docs/registration.md): per robot, its recent points (a
// sliding window of scans, odometry-map frame) are matched against the reference built from every
// robot's older, corrected points; the match (matcher.hpp) is a measurement of the robot's
// correction map_from_odom, fused with the correction's own prediction in a Kalman filter whose state
// is the correction and the odometry's drift rates (slip, heading drift per metre and per radian
// turned): the prediction extrapolates the correction with them, its uncertainty grows with the
// distance driven (skid-steer drift). Scans leave the window into the reference with the correction
// at the scan (moved by every later match). Pure: no I/O, no clocks; counters.
//
// Policy for what such matchers hit in the field:
//  - standing still: no new information → no match (counted), the correction is kept;
//  - a corridor: the unconstrained direction keeps the prediction (matcher degeneracy, counted);
//  - a failed or ambiguous match: rejected by overlap, residual and a bounded step (counted);
//  - the first lap: no match until the reference has enough vertical structure where the robot is;
//  - two robots building the same walls: one reference for the team, so each robot is corrected
//    against what the others (and its own earlier passes) saw.
#pragma once

#include <array>
#include <atomic>
#include <cstdint>
#include <deque>
#include <functional>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "common/capacities.hpp"
#include "common/pose.hpp"
#include "groundstation/registration/match_worker.hpp"
#include "groundstation/registration/matcher.hpp"
#include "groundstation/registration/surface_grid.hpp"

namespace teamscan::registration {

// What a robot's odometry drift rates (RobotCorrection::scale, drift_rad_per_m, turn) start from, each
// with its σ: the filter's prior. Default: no drift known, σ wide enough for a skid-steer base
// (3 % of the distance, 0.6°/m, 3 % of the turn). A calibrated base starts from its calibration.
struct OdometryPrior {
  double scale = 0.0;
  double sigma_scale = 0.03;
  double drift_rad_per_m = 0.0;
  double sigma_drift_rad_per_m = 0.01;
  double turn = 0.0;
  double sigma_turn = 0.03;
};

// Empty when the prior can be a robot's, else why not, naming the rate: every value finite, every σ
// > 0, |scale| and |turn| below 50 % (and their σ at most 50 %), |drift| and its σ at most 0.2 rad/m.
[[nodiscard]] std::string prior_error(const OdometryPrior& prior);

// A robot's own prior (its calibration), in place of RegistrationOptions::prior.
struct RobotPrior {
  std::uint8_t robot = 0;  // 1..kMaxRobots
  OdometryPrior prior;
};

struct RegistrationOptions {
  SurfaceOptions surface;            // reference and window grids
  MatchOptions match;
  double window_s = 2.5;             // a robot's recent points matched as one rigid piece
  double window_m = 0.0;             // … and no more path than this (0: time alone): a sparse log that
                                     // covers metres in a few seconds keeps only a rigid stretch
  // The window's voxels take this many points (the reference's take surface.voxel_cap): the window is
  // one rigid piece, so every sweep across a voxel counts (a tilted laser's stripes fill it).
  std::uint32_t window_voxel_cap = 1024;
  // At most one match per robot this often. Each robot's attempts are phased by its id (the fractional
  // part of id × 0.618…, of this period): a team that starts together would otherwise match all at once,
  // every period, and the whole team's matching would fall into one stretch of the loop.
  double match_every_s = 0.4;
  // A match taken at a robot's scan stamped t is fused into its correction at its first scan stamped
  // t + match_delay_s or later, and is computed meanwhile on a thread of its own (MatchWorker, on
  // `cpus`): the station's receive loop neither builds the window's grid nor searches the reference.
  // The caller waits for the match only if it is not done when due, so every scan gets the same
  // correction whichever thread computed it and however long it took (live = `teamscan eval`). The
  // scans in between keep the prediction. 0: matched and fused at the scan, on the caller's thread.
  double match_delay_s = 0.05;
  // The match thread's CPUs (empty: the caller's). A station pinned to one core names another here.
  std::vector<int> cpus;
  // The source of a match: the window's surface features (a tilted laser's 3-D points), or its
  // points themselves, each paired with the nearest reference line (point-to-line: a sparse 2-D
  // scan has too few points per voxel for features of its own).
  bool point_source = false;
  double min_motion_m = 0.05;        // since the last match: less motion than this (and …
  double min_motion_rad = 0.017;     // … less turn) is standing still: no match
  // The reference's index (LineMap) takes the columns changed since its last update at most this
  // often (robot time: the stamp of the scan whose match asks for it). An update costs the changed
  // columns, not the map.
  double update_every_s = 1.0;
  std::size_t min_map_features = 60; // the first lap: no match before the reference has this many
  // Prediction: the correction's uncertainty grows with what the robot does (skid-steer drift):
  // σ² per metre driven for x and y and for yaw, and per radian turned for yaw. The position's growth
  // also opens the bounded step (3σ): a wider one lets a repeated, self-consistent alias through
  // on a robot that has gone metres between accepted matches.
  double drift_m2_per_m = 0.02 * 0.02;
  double drift_rad2_per_m = 0.01 * 0.01;
  double drift_rad2_per_rad = 0.03 * 0.03;
  double initial_sigma_m = 0.01;     // at the registration (the start pose is known)
  double initial_sigma_rad = 0.002;
  // The drift's systematic part, estimated with the correction (the filter's state: the correction and
  // three rates): the odometry's distance scale (wheel slip), its heading drift per metre driven and per
  // radian turned. The prediction extrapolates the correction with them between matches (a skid-steer
  // base drifts by the metre, so a constant offset falls behind), and a window's scans are matched in
  // the frame the rates put them in. Off: the correction is held between matches.
  bool estimate_rates = true;
  // What the rates start from: every robot's prior, unless it has its own (a calibrated base:
  // `teamscan calibrate`, docs/registration.md "Odometry prior and calibration").
  OdometryPrior prior;
  std::vector<RobotPrior> robot_priors;  // at most one per robot
  // The rates may change slowly (floor, load): their σ² grows per metre driven.
  double rate_walk_scale2_per_m = 1e-6;
  double rate_walk_drift2_per_m = 1e-8;
  double rate_walk_turn2_per_m = 1e-6;

  // The prior `robot` starts from: its own (robot_priors) or the team's.
  [[nodiscard]] const OdometryPrior& prior_of(std::uint8_t robot) const;
};

// The policy for horizontal 2-D lasers (every point at the mount's height: an imported CARMEN log),
// whose scans are sparse (180 beams, a wall voxel gets a point or two per scan) and may be far apart
// (the Intel lab log: 18 cm and up to 25° between scans): every scan is matched on its own (the
// window is the last scan, by path: time says nothing about such a log), its points against the
// reference's lines; the reference follows every scan; wall voxels of 15 cm from 3 points; a match
// is used with 30 % of the points on a line; the prediction's heading grows faster (a real skid's
// turns). docs/registration.md "Real data". Everything else as `base`.
[[nodiscard]] RegistrationOptions planar_scan_options(RegistrationOptions base = {});

// A robot's correction and what registration did for it.
struct RobotCorrection {
  std::uint8_t robot = 0;
  Pose2 map_from_odom;                                  // applied on top of the odometry-map frame
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero(); // (x, y, yaw) about the robot's position
  Vec2 pivot_m;                                         // the robot's position (map frame)
  // The estimated drift rates (RegistrationOptions::estimate_rates): the robot's true motion between two
  // odometry poses is the odometry's increment (dx, dy, dθ) made (dx, dy)·(1 + scale),
  // dθ·(1 + turn) + drift_rad_per_m·√(dx² + dy²).
  double scale = 0, drift_rad_per_m = 0, turn = 0;
  Eigen::Matrix3d rate_covariance = Eigen::Matrix3d::Zero();  // (scale, drift, turn)
  bool matched = false;                                 // this scan's match was accepted (a measurement)
  std::uint64_t matches = 0, accepted = 0, degenerate = 0, standing_still = 0, first_lap = 0;
  std::uint64_t rejected_overlap = 0, rejected_fit = 0, rejected_step = 0, too_few_features = 0;
  MatchResult last;                                     // the last match tried
};

class Registration {
 public:
  // Starts the match thread when options.match_delay_s > 0 (std::system_error if it cannot).
  explicit Registration(RegistrationOptions options = {});

  // One scan of `robot` (1..kMaxRobots) at `stamp_ns` (non-decreasing per robot): its odometry pose
  // and points in the odometry-map frame (registration · odometry, no correction), `usable[i] = 0`
  // for points that must not pull the match nor enter the reference (ghost-flagged, inside a
  // teammate's tracked body). Returns the robot's correction to apply to this scan.
  const RobotCorrection& add_scan(std::uint8_t robot, std::int64_t stamp_ns, const Pose2& odom_pose,
                                  std::span<const Vec3> points, std::span<const std::uint8_t> usable);

  [[nodiscard]] const RobotCorrection* correction(std::uint8_t robot) const;
  // The reference's figures as of the latest update and retired scan the match thread has applied
  // (with match_delay_s > 0 the reference is the match thread's: these are copies it publishes).
  [[nodiscard]] std::size_t reference_features() const { return reference_features_.load(std::memory_order_relaxed); }
  [[nodiscard]] std::size_t reference_voxels() const { return reference_voxels_.load(std::memory_order_relaxed); }
  // The reference's updates so far and the columns they recomputed (their cost: one column each).
  [[nodiscard]] std::uint64_t reference_updates() const { return reference_updates_.load(std::memory_order_relaxed); }
  [[nodiscard]] std::uint64_t reference_columns_updated() const {
    return reference_columns_updated_.load(std::memory_order_relaxed);
  }
  // The columns recomputed by the latest update.
  [[nodiscard]] std::size_t reference_last_update_columns() const {
    return reference_last_update_columns_.load(std::memory_order_relaxed);
  }
  // The reference itself (its features, for tests that compare it with a build from scratch).
  // Waits for the match thread first (valid until the next add_scan).
  [[nodiscard]] const LineMap& reference_map() const {
    wait_idle();
    return map_;
  }
  [[nodiscard]] const SurfaceGrid& reference_grid() const {
    wait_idle();
    return reference_;
  }
  [[nodiscard]] std::uint64_t rejected_scans() const { return rejected_scans_; }
  // The match thread (started by the constructor when match_delay_s > 0, else nullptr).
  [[nodiscard]] const MatchWorker* worker() const { return worker_.get(); }
  [[nodiscard]] const RegistrationOptions& options() const { return options_; }

 private:
  struct WindowScan {
    std::int64_t stamp_ns = 0;
    double path_m = 0;         // the robot's path length at this scan
    std::vector<Vec3> points;  // usable points only, odometry-map frame
    Pose2 map_from_odom;       // the correction at the scan (moved with every later match)
  };
  using Matrix6 = Eigen::Matrix<double, 6, 6>;
  // A match in flight: its input (the window's scans with what moves each into the odometry frame of
  // its scan, the prior), its answer, and when it is fused. The pieces point into the window scans'
  // point buffers: a scan that leaves the window meanwhile hands its buffer to a job queued after
  // this one, so the buffer outlives the match.
  struct WindowPiece {
    Pose2 now_from_scan;
    bool held = false;  // the correction unchanged since the scan: its points as they are
    std::span<const Vec3> points;
  };
  struct MatchJob {
    bool pending = false;
    std::uint64_t ticket = 0;     // MatchWorker's (0: computed on the caller's thread)
    std::int64_t apply_ns = 0;    // fused at the robot's first scan stamped this or later
    Pose2 prior;                  // the correction it started from
    Pose2 odom_pose;              // the robot's odometry at its scan
    MatchOptions options;
    bool first_lap = false;       // the reference was too small to match against
    std::vector<WindowPiece> pieces;
    std::vector<LineFeature> features;
    MatchResult result;
  };
  struct Robot {
    bool started = false;
    RobotCorrection c;
    Matrix6 covariance = Matrix6::Zero();  // (x, y, yaw about c.pivot_m, scale, drift, turn)
    Pose2 last_odom;
    double path_m = 0;  // driven so far (odometry)
    Pose2 odom_at_match;
    std::int64_t last_attempt_ns = 0;
    std::deque<WindowScan> window;
    MatchJob job;
  };

  void predict(Robot& r, const Pose2& odom_pose);
  void retire(Robot& r, std::int64_t now_ns);
  void try_match(Robot& r, std::int64_t stamp_ns, const Pose2& odom_pose);
  // With match_delay_s > 0 the reference (reference_, map_) belongs to the match thread: everything
  // that reads or changes it (a retired scan's points, an update, a match) runs there, in the order the
  // scans asked for it, so the result is the order's, not the threads'. At 0: here, at once.
  void in_order(std::function<void()> job);
  void wait_idle() const {
    if (worker_) worker_->wait_idle();
  }
  void update_reference_if_due(std::int64_t stamp_ns);
  // The match itself (the worker's part): window grid, features, search. Reads map_ and window_grid_.
  void compute(MatchJob& j);
  // Its answer into the robot's counters and correction (the caller's part).
  void finish(Robot& r);
  void fuse(Robot& r, const MatchResult& m);

  RegistrationOptions options_;
  void update_reference(std::int64_t stamp_ns);

  SurfaceGrid reference_;  // tracks its changed columns
  LineMap map_;            // the reference's features, one group per column
  std::int64_t map_built_ns_ = 0;
  std::vector<ColumnChange> changes_;           // update_reference's scratch
  std::vector<LineFeature> changed_features_;
  std::atomic<std::uint64_t> reference_updates_{0}, reference_columns_updated_{0};
  std::atomic<std::size_t> reference_last_update_columns_{0}, reference_features_{0}, reference_voxels_{0};
  std::array<Robot, kMaxRobots + 1> robots_{};
  SurfaceGrid window_grid_;  // compute()'s (one match at a time)
  std::uint64_t rejected_scans_ = 0;
  // Last: destroyed first, its queued matches still reading the members above.
  std::unique_ptr<MatchWorker> worker_;
};

// Applies a correction to a point of the odometry-map frame.
[[nodiscard]] inline Vec3 corrected(const Pose2& map_from_odom, const Vec3& p) {
  const Vec2 q = map_from_odom.apply({p.x, p.y});
  return {q.x, q.y, p.z};
}

}  // namespace teamscan::registration
