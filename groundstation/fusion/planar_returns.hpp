// Which of a released scan's returns go into the 2-D pose graph (graph_backend.hpp): those that say
// where the robot is in x, y and yaw. A level laser's returns all lie in its scan plane: all are taken.
// A tilted laser (the simulator's robots) sweeps floor, walls, furniture and teammates in 3-D: only
// the returns in a height band above the floor are taken (walls and furniture sides, which pin x, y
// and yaw; floor and ceiling say nothing about them). Either way the points a match must not use
// (match_points.hpp: onboard-flagged, inside a teammate's tracked body) are left out, as the
// registration leaves them out. Truth is never read.
#pragma once

#include <cstdint>
#include <vector>

#include "common/dataset/dataset.hpp"
#include "groundstation/mapping/filter.hpp"
#include "groundstation/mapping/tracked_filter.hpp"

namespace teamscan::fusion {

struct PlanarReturnOptions {
  // A tilted laser's returns kept: height above the floor (the map's z = 0), metres. Below the band:
  // the floor and what lies on it (its noise, cables); above: ceilings, lamps.
  double min_height_m = 0.15;
  double max_height_m = 2.0;
  // A tilted laser's scans gathered into one node of the graph (seconds, from the node's first scan's
  // stamp): a tilted scan is one stripe across what it sees, 75 of them a second; a node of them is a
  // cross-section of the walls around the robot, as a level laser's scan is.
  double tilted_node_s = 0.25;
  // The teammates' body boxes (the team state is the one the scan is given: the back end gives the
  // odometry's, FusedScan::odom_team).
  mapping::TrackedOptions tracked;
};

struct PlanarReturnCounts {
  std::uint64_t kept = 0;
  std::uint64_t flagged = 0;      // flagged by the robot (invalid, its direction filter)
  std::uint64_t teammates = 0;    // inside a teammate's body
  std::uint64_t out_of_band = 0;  // a tilted laser's, below or above the height band
};

// Whether a robot's laser scans a level plane (mount roll and pitch zero).
[[nodiscard]] bool level_laser(const DatasetRobot& robot);
// Whether a scan is a level laser's: every point at its sensor's height (within a centimetre).
[[nodiscard]] bool level_scan(const mapping::ScanView& scan);

// `taken[i]` = 1 for each of the scan's points the graph takes (`tilted`: the height band applies);
// `taken` is resized to the scan's points. The scan's team state (nullptr: none known) masks teammates.
void take_planar_returns(const mapping::ScanView& scan, bool tilted, const PlanarReturnOptions& options, std::vector<std::uint8_t>& taken,
                         PlanarReturnCounts& counts);

}  // namespace teamscan::fusion
