// A level laser's scan given to the graph's back end as the fusion core releases it with no correction:
// robot 1's k-th scan (0.1 s apart), its returns in the map frame, released where `odometry` puts it.
// Shared by the back end's tests of level lasers.
#pragma once

#include <cstdint>
#include <vector>

#include "common/pose.hpp"
#include "groundstation/fusion/graph_backend.hpp"

namespace teamscan::fusion::testing {

inline void add_level_scan(GraphBackend& backend, int k, const Pose2& odometry, const std::vector<mapping::MapPoint>& points) {
  mapping::ScanView v;
  v.robot = 1;
  v.scan = static_cast<std::uint32_t>(k);
  v.stamp_ns = 1'000'000'000LL + k * 100'000'000LL;
  v.origin_m = {odometry.x_m, odometry.y_m, 0.3};
  v.map_from_robot = odometry;
  v.points = points;
  FusedScan f;
  f.view = &v;
  f.odom_from_robot = odometry;  // no correction: the released pose is the odometry's
  backend.add(f);
}

}  // namespace teamscan::fusion::testing
