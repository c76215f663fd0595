// The pose graph of the team (Hess et al. 2016, section V; the sparse pose adjustment of Konolige et
// al. 2010): nodes (one per scan) and submaps with global poses, constraints between a submap and a
// node (the node's pose in the submap's frame: from scan-to-submap matching as the scan was inserted,
// or a loop closure) and between consecutive nodes of a robot (odometry). Solved with Ceres as a sparse
// problem; loop closures under a Huber loss, so a false closure is outvoted rather than obeyed.
#pragma once

#include <array>
#include <cstdint>
#include <map>
#include <set>
#include <vector>

#include "common/pose.hpp"

namespace teamscan::posegraph {

struct GraphOptions {
  // Residual weights (per metre, per radian), as Cartographer's 2-D defaults but the odometry's and
  // local SLAM's: local SLAM's motion between consecutive nodes is held ten times less stiffly, so the
  // closures of a node (many, after the second search) can correct it.
  double matcher_translation_weight = 5e2, matcher_rotation_weight = 1.6e3;       // inserted scans
  double closure_translation_weight = 1.1e4, closure_rotation_weight = 1e5;      // loop closures
  double odometry_translation_weight = 1e2, odometry_rotation_weight = 1e3;       // consecutive nodes
  // Wheels slip in a turn: the odometry's rotation between consecutive nodes is held the less stiffly
  // the more it turned, its σ (1 / weight, rad) growing by this much per radian turned. 0: one weight.
  double odometry_turn_sigma_rad_per_rad = 0;
  double local_translation_weight = 1e4, local_rotation_weight = 1e4;             // consecutive local SLAM poses
  // Wheels that did not turn between two nodes (the odometry moved less than `rest_translation_m` and
  // `rest_rotation_rad`) mean a robot at rest, whatever they slip in motion: that link's odometry
  // weights are multiplied by `rest_weight_factor`, so a parked robot's nodes move together as one,
  // rather than each giving a little to the pull of its closures and inserted scans until the robot
  // has turned while it stood. 1: as any link.
  // Only where local SLAM saw the robot stand as well (its motion less than `rest_local_translation_m`
  // and `rest_local_rotation_rad`): odometry that stalls (the same pose for several scans while the robot
  // drives on, then one jump) is not a robot at rest, and held stiffly it would bend local SLAM's turn.
  double rest_translation_m = 0.001, rest_rotation_rad = 0.001;
  double rest_local_translation_m = 0.01, rest_local_rotation_rad = 0.0087;
  double rest_weight_factor = 10;
  double closure_huber_scale = 1e1;
  // Each robot's odometry calibrated in the graph (Kümmerle et al. 2011, "Simultaneous calibration,
  // localization, and mapping"): three parameters per robot (OdometryCalibration) correct the measured
  // motion of its odometry links, found with the poses and held near "no error" by a weak prior (σ of
  // the two scales and of the drift per metre below). A skid-steered robot's systematic errors (its
  // wheels slip, they skid in turns, unequal tyres turn it on every metre) then cost the graph three
  // numbers rather than a bend at every node, and the loop closures need only find them.
  // `calibrate_local_links`: local SLAM's links corrected as well, for a local SLAM held to the
  // odometry (tilted lasers'), whose motion carries the odometry's errors.
  bool calibrate_odometry = false;
  bool calibrate_local_links = false;
  // A robot's calibration held at none (its parameters constant) until free_calibration(robot): before
  // a loop closure measures it, a calibration only lets the graph follow local SLAM's own drift.
  bool calibrate_after_loop = false;
  double calibration_scale_prior_sigma = 0.05, calibration_drift_prior_sigma_rad_per_m = 0.01;
  int max_iterations = 20;
  int final_max_iterations = 20;  // the last optimisation, over the whole log
};

struct Constraint {
  enum class Kind : std::uint8_t { inserted, closure };
  std::size_t submap = 0, node = 0;
  Pose2 submap_from_node;
  Kind kind = Kind::inserted;
  // The translation weight along the axis at `strong_axis_rad` + 90° (submap frame) is scaled by
  // `weak_axis_factor` (1: isotropic): a match along a corridor says little about where along it.
  double strong_axis_rad = 0, weak_axis_factor = 1;
  // The rotation weight is scaled by `rotation_factor` (1: as configured): a match on a short piece of
  // wall says little about the heading.
  double rotation_factor = 1;
};

struct NodeLink {  // between consecutive nodes of one robot
  std::size_t from = 0, to = 0;
  std::uint8_t robot = 0;
  Pose2 from_to_odometry;  // odometry's motion
  Pose2 from_to_local;     // local SLAM's motion
};

// How a robot's odometry departs from its true motion, as the graph estimates it (GraphOptions::
// calibrate_odometry): true distance = distance_scale · reported; true turn = turn_scale · (reported
// turn − heading_drift_rad_per_m · reported distance). No error: 1, 1, 0.
struct OdometryCalibration {
  double distance_scale = 1.0, turn_scale = 1.0, heading_drift_rad_per_m = 0.0;
};

class PoseGraph {
 public:
  explicit PoseGraph(GraphOptions options = {}) : options_(options) {}

  std::size_t add_node(const Pose2& global, bool anchor);
  std::size_t add_submap(const Pose2& global);
  void add_constraint(const Constraint& c) { constraints_.push_back(c); }
  void add_link(const NodeLink& l) { links_.push_back(l); }
  // With GraphOptions::calibrate_after_loop: the robot's calibration is found from the next
  // optimisation on.
  void free_calibration(std::uint8_t robot) { calibration_free_.insert(robot); }

  // Least squares over every pose (the anchors held). Deterministic: one thread, a fixed order.
  // `final`: the last one, with final_max_iterations.
  void optimize(bool final = false);

  [[nodiscard]] const std::vector<Pose2>& nodes() const { return nodes_; }
  [[nodiscard]] const std::vector<Pose2>& submaps() const { return submaps_; }
  [[nodiscard]] const std::vector<Constraint>& constraints() const { return constraints_; }
  [[nodiscard]] const Constraint& last_constraint() const { return constraints_.back(); }
  [[nodiscard]] std::size_t closures() const;
  [[nodiscard]] std::size_t optimizations() const { return optimizations_; }
  // The robot's odometry calibration as the last optimisation found it (no error before one, or
  // without GraphOptions::calibrate_odometry or calibrate_local_links).
  [[nodiscard]] OdometryCalibration calibration(std::uint8_t robot) const;

 private:
  GraphOptions options_;
  std::set<std::uint8_t> calibration_free_;
  std::vector<Pose2> nodes_, submaps_;
  std::vector<std::uint8_t> anchored_;
  std::vector<Constraint> constraints_;
  std::vector<NodeLink> links_;
  std::map<std::uint8_t, std::array<double, 3>> calibration_;  // robot -> OdometryCalibration's three
  std::size_t optimizations_ = 0;
};

}  // namespace teamscan::posegraph
