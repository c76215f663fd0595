// The pose graph of the team (Hess et al. 2016, section V; the sparse pose adjustment of Konolige et
// al. 2010): nodes (one per scan) and submaps with global poses, constraints between a submap and a
// node (the node's pose in the submap's frame: from scan-to-submap matching as the scan was inserted,
// or a loop closure) and between consecutive nodes of a robot (odometry). Solved with Ceres as a sparse
// problem; loop closures under a Huber loss, so a false closure is outvoted rather than obeyed.
#pragma once

#include <cstdint>
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
  double closure_huber_scale = 1e1;
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
};

struct NodeLink {  // between consecutive nodes of one robot
  std::size_t from = 0, to = 0;
  Pose2 from_to_odometry;  // odometry's motion
  Pose2 from_to_local;     // local SLAM's motion
};

class PoseGraph {
 public:
  explicit PoseGraph(GraphOptions options = {}) : options_(options) {}

  std::size_t add_node(const Pose2& global, bool anchor);
  std::size_t add_submap(const Pose2& global);
  void add_constraint(const Constraint& c) { constraints_.push_back(c); }
  void add_link(const NodeLink& l) { links_.push_back(l); }

  // Least squares over every pose (the anchors held). Deterministic: one thread, a fixed order.
  // `final`: the last one, with final_max_iterations.
  void optimize(bool final = false);

  [[nodiscard]] const std::vector<Pose2>& nodes() const { return nodes_; }
  [[nodiscard]] const std::vector<Pose2>& submaps() const { return submaps_; }
  [[nodiscard]] const std::vector<Constraint>& constraints() const { return constraints_; }
  [[nodiscard]] const Constraint& last_constraint() const { return constraints_.back(); }
  [[nodiscard]] std::size_t closures() const;
  [[nodiscard]] std::size_t optimizations() const { return optimizations_; }

 private:
  GraphOptions options_;
  std::vector<Pose2> nodes_, submaps_;
  std::vector<std::uint8_t> anchored_;
  std::vector<Constraint> constraints_;
  std::vector<NodeLink> links_;
  std::size_t optimizations_ = 0;
};

}  // namespace teamscan::posegraph
