// The fused model moved rigidly with the pose graph (docs/slam.md "The live map follows the graph"):
// where a core's released scans sit (ScanPlacement: each scan of a graph estimate at its graph pose, any
// other at its robot's tail correction) and, between two placements, the rigid move of each scan's points
// (ScanMoves), which FusionCore::continue_model_move applies to its model store a slice at a time. A move
// costs one pass over the model store, which the cap per voxel bounds by the mapped space, however long
// the robots have mapped; the filters' evidence and the decisions at release stay as they were made.
#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <utility>
#include <vector>

#include "common/capacities.hpp"
#include "common/pose.hpp"
#include "groundstation/fusion/graph_backend.hpp"
#include "groundstation/mapping/voxel_map.hpp"

namespace teamscan::fusion {

// A rigid move in the plane, z kept: p -> R p + t.
struct RigidMove {
  double cos_theta = 1.0, sin_theta = 0.0, x_m = 0.0, y_m = 0.0;
  [[nodiscard]] static RigidMove of(const Pose2& p);
  [[nodiscard]] bool identity() const { return cos_theta == 1.0 && sin_theta == 0.0 && x_m == 0.0 && y_m == 0.0; }
  void apply(mapping::MapPoint& p) const {
    const double x = p.x, y = p.y;
    p.x = static_cast<float>(cos_theta * x - sin_theta * y + x_m);
    p.y = static_cast<float>(sin_theta * x + cos_theta * y + y_m);
  }
};

// Where a core placed its released scans' points, as corrections of the robots' odometry: each scan of
// `estimate` at the graph's pose (the correction graph · odom⁻¹: GraphScanPose), each other scan of a
// robot at its robot's tail correction, the one of its newest scan in the estimate (the scans released
// after it were placed with it). No estimate: where the odometry put them (every correction the identity).
struct ScanPlacement {
  std::shared_ptr<const GraphEstimate> estimate;
  std::array<Pose2, kMaxRobots + 1> tail{};  // per robot id
  [[nodiscard]] static ScanPlacement on(std::shared_ptr<const GraphEstimate> estimate);
};

// From one placement to another: for each scan, the move that takes its points from where `from` put
// them to where `to` puts them. Per robot, sorted by sequence number (a robot's scans by number: the
// model store knows a point's scan by robot and number only; a number the estimates hold twice, a robot
// restarted, takes the newest scan's).
class ScanMoves {
 public:
  ScanMoves(const ScanPlacement& from, const ScanPlacement& to);
  // The move of robot `robot`'s scan `seq` (robot 1..kMaxRobots; any other id: none).
  [[nodiscard]] const RigidMove& at(std::uint8_t robot, std::uint32_t seq) const;
  // Scans with a move of their own (those of either estimate).
  [[nodiscard]] std::size_t scans() const;
  // How far the moves shift a scan's returns at most: over the scans of `to`'s estimate, its sensor
  // position's shift (where `from` put it) plus its turn times `reach_m`, the laser's range (so a point
  // far across the map from the origin does not count the map origin's lever). Whether moving the model
  // is worth a pass over it.
  [[nodiscard]] double largest_shift_m(double reach_m) const { return largest_position_shift_m_ + reach_m * largest_turn_rad_; }

 private:
  struct Robot {
    std::vector<std::pair<std::uint32_t, RigidMove>> by_seq;  // ascending seq
    RigidMove tail;  // the other scans': to's tail after from's undone
  };
  std::array<Robot, kMaxRobots + 1> robots_;
  double largest_turn_rad_ = 0.0, largest_position_shift_m_ = 0.0;
  static const RigidMove kNone;
};

}  // namespace teamscan::fusion
