// A data set's scans as planar returns for the 2-D pose graph (groundstation/posegraph, `teamscan eval
// --pose-graph`): the returns that say where the robot is in x, y and yaw, in each scan's robot frame.
// A level laser's returns all lie in its scan plane: all are taken. A tilted laser (the simulator's
// robots) sweeps floor, walls, furniture and teammates in 3-D: only the returns in a height band above
// the floor are taken (walls and furniture sides, which pin x, y and yaw; floor and ceiling say nothing
// about them). A tilted laser's scan is one stripe across what it sees (75 of them a second): a node of
// the graph gathers a robot's consecutive scans over `tilted_node_s`, put into its last scan's frame by
// the odometry (which drifts by millimetres over such a span), so that each node is a cross-section of
// the walls around the robot as a level laser's scan is. Either way the points a match must not use (match_points.hpp: onboard-flagged, inside a
// teammate's tracked body) are left out, as the registration leaves them out. Truth is never read.
#pragma once

#include <cstdint>
#include <vector>

#include "common/dataset/dataset.hpp"
#include "common/pose.hpp"
#include "groundstation/mapping/tracked_filter.hpp"
#include "groundstation/mapping/tracker.hpp"

namespace teamscan::fusion {

struct PlanarReturnOptions {
  // A tilted laser's returns kept: height above the floor (the data set's z = 0), metres. Below the
  // band: the floor and what lies on it (its noise, cables); above: ceilings, lamps.
  double min_height_m = 0.15;
  double max_height_m = 2.0;
  // A tilted laser's scans gathered into one node (seconds, from the node's first scan's stamp).
  double tilted_node_s = 0.25;
  // The teammates' tracks (fed the data set's odometry, as the fusion core is) and their body boxes.
  mapping::TrackerOptions tracker;
  mapping::TrackedOptions tracked;
};

// One node of the graph: a level laser's scan, or a tilted laser's scans over tilted_node_s.
struct PlanarNode {
  std::uint8_t robot = 0;
  std::size_t row = 0;             // the Dataset::scans row whose odometry pose the node takes: its last
  std::vector<std::size_t> rows;   // every row it gathers, in order (`row` last)
  std::vector<Vec2> returns;       // in the robot frame of `row`
};

struct PlanarReturns {
  std::vector<PlanarNode> nodes;   // in the order of their last scan: stamp, then robot, then scan
  std::vector<std::uint8_t> taken;  // per Dataset::points row: 1 = one of the returns above
  std::uint64_t kept = 0;
  std::uint64_t masked = 0;       // onboard-flagged or inside a teammate's body
  std::uint64_t out_of_band = 0;  // a tilted laser's, below or above the height band
};

// Whether a robot's laser scans a level plane (mount roll and pitch zero).
[[nodiscard]] bool level_laser(const DatasetRobot& robot);

[[nodiscard]] PlanarReturns planar_returns(const Dataset& dataset, const PlanarReturnOptions& options = {});

// Every Dataset::scans row's pose from its node's pose (`node_poses[k]` for `returns.nodes[k]`): the
// node's pose moved by the odometry's motion from the node's row to the scan's. Rows in no node keep
// their odometry pose.
[[nodiscard]] std::vector<Pose2> scan_poses(const Dataset& dataset, const PlanarReturns& returns, const std::vector<Pose2>& node_poses);

}  // namespace teamscan::fusion
