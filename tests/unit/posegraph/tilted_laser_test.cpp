// The pose graph on a simulated team of tilted-laser robots (fusion/planar_returns.hpp,
// posegraph::tilted_laser_options): lap2-drift's first 40 s simulated in-process (two robots, one
// laser pitched down and one up, both drifting); the graph's poses beat odometry alone by a wide
// margin, and no floor or ceiling return goes into the graph.
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <vector>

#include <gtest/gtest.h>

#include "groundstation/fusion/planar_returns.hpp"
#include "groundstation/mapping/dataset_registration.hpp"
#include "groundstation/posegraph/slam.hpp"
#include "sim/scenario.hpp"
#include "sim/simulator.hpp"

namespace teamscan {
namespace {

const Dataset& lap2_drift_start() {
  static const Dataset d = [] {
    const sim::ScenarioLoad l = sim::resolve_scenario("lap2-drift");
    if (!l.scenario) {
      ADD_FAILURE() << l.error;
      return Dataset{};
    }
    sim::SimOptions o;
    o.duration_s = 40.0;
    o.device_streams = false;  // the direct path: `teamscan sim --direct`
    return sim::simulate(*l.scenario, o).dataset;
  }();
  return d;
}

TEST(TiltedLaserReturns, NoFloorOrCeilingReturnIsTaken) {
  const Dataset& d = lap2_drift_start();
  ASSERT_FALSE(d.points.empty());
  for (const DatasetRobot& r : d.robots) EXPECT_FALSE(fusion::level_laser(r)) << "robot " << int{r.id};
  const fusion::PlanarReturns planar = fusion::planar_returns(d);
  ASSERT_EQ(planar.taken.size(), d.points.size());
  std::size_t floor_points = 0, floor_taken = 0, ceiling_taken = 0, wall_points = 0, wall_taken = 0;
  for (std::size_t i = 0; i < d.points.size(); ++i) {
    const LabelledPoint& p = d.points[i];
    if (p.label == PointClass::floor) {
      ++floor_points;
      floor_taken += planar.taken[i];
    }
    if (p.label == PointClass::ceiling) ceiling_taken += planar.taken[i];
    if (p.label == PointClass::wall) {
      ++wall_points;
      wall_taken += planar.taken[i];
    }
  }
  EXPECT_GT(floor_points, 1000u);  // the down-laser sweeps the floor: there is floor to leave out
  EXPECT_EQ(floor_taken, 0u);
  EXPECT_EQ(ceiling_taken, 0u);
  // The walls are what the graph is made of: most of their returns are taken.
  EXPECT_GT(wall_taken, wall_points / 2);
  EXPECT_EQ(planar.kept + planar.masked + planar.out_of_band, d.points.size());
  // A node gathers a robot's scans over a quarter of a second: far fewer nodes than scans, every scan in one.
  std::size_t rows = 0;
  for (const fusion::PlanarNode& n : planar.nodes) {
    rows += n.rows.size();
    ASSERT_FALSE(n.rows.empty());
    EXPECT_EQ(n.rows.back(), n.row);
  }
  EXPECT_EQ(rows, d.scans.size());
  EXPECT_LT(planar.nodes.size(), d.scans.size() / 10);
}

TEST(TiltedLaserGraph, BeatsOdometryAlone) {
  const Dataset& d = lap2_drift_start();
  ASSERT_FALSE(d.truth.empty());
  const fusion::PlanarReturns planar = fusion::planar_returns(d);
  posegraph::PlanarSlam slam(posegraph::tilted_laser_options());
  std::vector<std::size_t> node(planar.nodes.size());
  for (std::size_t k = 0; k < planar.nodes.size(); ++k)
    node[k] = slam.add_scan(planar.nodes[k].robot, d.scans[planar.nodes[k].row].pose, planar.nodes[k].returns);
  slam.finish();
  std::vector<Pose2> node_poses(planar.nodes.size());
  for (std::size_t k = 0; k < planar.nodes.size(); ++k) node_poses[k] = slam.pose(node[k]);
  const std::vector<Pose2> poses = fusion::scan_poses(d, planar, node_poses);
  ASSERT_EQ(poses.size(), d.scans.size());
  mapping::ErrorStats odo_m, odo_deg, graph_m, graph_deg, points;
  mapping::measure_errors(d, odo_m, odo_deg, points);
  mapping::measure_errors(d, graph_m, graph_deg, points, {}, poses);
  // Odometry alone drifts by tens of centimetres and several degrees in 40 s; the graph holds both
  // robots to a fraction of that.
  EXPECT_GT(odo_m.p99, 0.15);
  EXPECT_LT(graph_m.p99, 0.5 * odo_m.p99) << "graph p99 " << graph_m.p99 << " m, odometry " << odo_m.p99 << " m";
  EXPECT_LT(graph_deg.p99, 0.5 * odo_deg.p99) << "graph p99 " << graph_deg.p99 << "°, odometry " << odo_deg.p99 << "°";
  EXPECT_LT(graph_m.max, 0.15);
}

}  // namespace
}  // namespace teamscan
