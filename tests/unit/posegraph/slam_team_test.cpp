// A team's scans interleaved (SlamOptions::closure_every_n_nodes, rematch_every_n_nodes): each robot's
// own nodes are counted for which are searched and kept, so every robot's drift is closed out, not
// only that of the robot whose nodes the team's numbering happens to favour.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <vector>

#include "groundstation/posegraph/slam.hpp"
#include "tests/unit/posegraph/room.hpp"

namespace teamscan::posegraph {
namespace {

struct Circle {
  Vec2 centre;
  double radius_m;
  double drift_rad_per_m;
};

TEST(SlamTeam, EveryRobotsNodesAreSearched) {
  // Three robots in the room, one scan each in turn (the graph's nodes 0, 1, 2 are robots 1, 2, 3),
  // each on its own circle for two and a half laps, their odometry drifting in heading.
  const std::array<Circle, 3> circles{{{{3.25, 2.3}, 1.2, 0.005}, {{6.0, 1.6}, 0.9, -0.006}, {{1.5, 4.3}, 0.9, 0.007}}};
  constexpr double kStep = 0.04;
  PlanarSlam slam;
  std::array<std::vector<std::size_t>, 3> nodes;
  std::array<std::vector<Pose2>, 3> truths;
  std::array<double, 3> worst_odometry_m{};
  const int scans = static_cast<int>(2.5 * 2.0 * kPi * circles[0].radius_m / kStep);
  for (int k = 0; k < scans; ++k)
    for (std::size_t i = 0; i < circles.size(); ++i) {
      const Circle& c = circles[i];
      const double travelled = k * kStep, phase = travelled / c.radius_m;
      const Pose2 truth{c.centre.x + c.radius_m * std::cos(phase), c.centre.y + c.radius_m * std::sin(phase), phase + kPi / 2.0};
      // The drift turns the track about the robot's start.
      const Pose2 start{c.centre.x + c.radius_m, c.centre.y, kPi / 2.0};
      const Pose2 odometry = start * Pose2{0.0, 0.0, c.drift_rad_per_m * travelled} * (start.inverse() * truth);
      worst_odometry_m[i] = std::max(worst_odometry_m[i], std::hypot(odometry.x_m - truth.x_m, odometry.y_m - truth.y_m));
      nodes[i].push_back(slam.add_scan(static_cast<std::uint8_t>(i + 1), k * 100'000'000LL, odometry, test::scan(truth)));
      truths[i].push_back(truth);
    }
  slam.finish();
  const PoseGraph& graph = slam.graph();
  std::vector<int> closures_of_node(graph.nodes().size(), 0);
  for (const Constraint& c : graph.constraints())
    if (c.kind == Constraint::Kind::closure) ++closures_of_node[c.node];
  for (std::size_t i = 0; i < circles.size(); ++i) {
    std::size_t closed = 0;
    double worst_m = 0.0;
    for (std::size_t k = 0; k < nodes[i].size(); ++k) {
      closed += closures_of_node[nodes[i][k]] > 0 ? 1 : 0;
      const Pose2 p = slam.pose(nodes[i][k]);
      worst_m = std::max(worst_m, std::hypot(p.x_m - truths[i][k].x_m, p.y_m - truths[i][k].y_m));
    }
    std::printf("robot %zu: %zu nodes, %zu with a loop closure; worst %.3f m (odometry %.3f m)\n", i + 1, nodes[i].size(), closed,
                worst_m, worst_odometry_m[i]);
    // Every robot's nodes are searched (every sixth online, every third again at the end): a good
    // share of each robot's nodes is tied to the submaps by a closure of its own.
    EXPECT_GE(closed, nodes[i].size() / 5) << "robot " << i + 1;
    EXPECT_GT(worst_odometry_m[i], 0.15) << "robot " << i + 1;
    EXPECT_LT(worst_m, 0.03) << "robot " << i + 1;
  }
}

}  // namespace
}  // namespace teamscan::posegraph
