// A robot that stops (SlamOptions::still_translation_m): the nodes it adds while standing are
// counted, neither searched for loop closures nor kept for the second search, and still placed where
// it stands; with the rule off the same drive searches from every one of them.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <vector>

#include "groundstation/posegraph/slam.hpp"
#include "tests/unit/posegraph/room.hpp"

namespace teamscan::posegraph {
namespace {

struct StopDrive {
  SlamStats stats;
  double worst_stop_m = 0.0;  // the standing nodes' largest position error against the truth
};

// Around the room's pillar on a 1.2 m circle (4 cm a scan, odometry drifting 0.3° per metre), with a
// stop of `stop_nodes` scans half-way round the second lap, then on to the end of a third.
StopDrive drive(const SlamOptions& options, int stop_nodes) {
  PlanarSlam slam(options);
  constexpr double kRadius = 1.2, kStep = 0.04;
  const Vec2 centre{3.25, 2.3};
  const int per_lap = static_cast<int>(2.0 * kPi * kRadius / kStep);
  std::vector<std::size_t> standing;
  Pose2 stop_truth;
  double travelled = 0.0;
  std::int64_t stamp_ns = 0;  // 10 scans a second, standing or not
  for (int k = 0, stopped = 0; k < 3 * per_lap;) {
    const double phase = 2.0 * kPi * k / per_lap;
    const Pose2 truth{centre.x + kRadius * std::cos(phase), centre.y + kRadius * std::sin(phase), phase + kPi / 2.0};
    const Pose2 odometry = Pose2{0.0, 0.0, 0.3 * kPi / 180.0 * travelled} * truth;
    const std::size_t node = slam.add_scan(1, stamp_ns += 100'000'000, odometry, test::scan(truth));
    if (k == per_lap + per_lap / 2 && stopped < stop_nodes) {
      ++stopped;
      standing.push_back(node);
      stop_truth = truth;
      continue;
    }
    ++k;
    travelled += kStep;
  }
  slam.finish();
  StopDrive run;
  run.stats = slam.stats();
  for (const std::size_t node : standing) {
    const Pose2 p = slam.pose(node);
    run.worst_stop_m = std::max(run.worst_stop_m, std::hypot(p.x_m - stop_truth.x_m, p.y_m - stop_truth.y_m));
  }
  return run;
}

TEST(SlamStill, AStandingRobotsNodesAreNotSearched) {
  SlamOptions on;  // the defaults, but every searched node's returns kept (no cap per square metre)
  on.rematch_nodes_per_cell = 0;
  SlamOptions off = on;
  off.still_translation_m = 0.0;
  const StopDrive still = drive(on, 300), searched = drive(off, 300), moving = drive(on, 0);
  for (const StopDrive* d : {&still, &searched, &moving})
    std::printf("%zu nodes (%zu standing), %zu searches, %zu followed, %zu closures (%zu from the second search), returns of %zu kept, worst at the stop %.3f m\n",
                d->stats.nodes, d->stats.still, d->stats.searches, d->stats.tracked, d->stats.closures, d->stats.rematches, d->stats.kept_returns,
                d->worst_stop_m);
  // The stop's nodes after its first: counted as standing, nothing else.
  EXPECT_EQ(still.stats.still, 300u);
  EXPECT_EQ(moving.stats.still, 0u);
  EXPECT_EQ(searched.stats.still, 0u);
  // Without the rule every sixth of them is searched (50 nodes), each against up to three finished
  // submaps, or refined from the closure before; and every third is kept for the second search.
  const auto tried = [](const StopDrive& d) { return d.stats.searches + d.stats.tracked; };
  EXPECT_GE(tried(searched), tried(still) + 50);
  EXPECT_GE(searched.stats.kept_returns, still.stats.kept_returns + 99);
  // With it the drive tries as many closures, and keeps as many nodes' returns, as one that never
  // stopped (give or take the numbering).
  EXPECT_NEAR(static_cast<double>(tried(still)), static_cast<double>(tried(moving)), 3.0);
  EXPECT_NEAR(static_cast<double>(still.stats.kept_returns), static_cast<double>(moving.stats.kept_returns), 2.0);
  // And the standing robot is where it stands: its odometry holds its nodes to the first of them.
  EXPECT_LT(still.worst_stop_m, 0.03);
  EXPECT_LT(searched.worst_stop_m, 0.03);
}

}  // namespace
}  // namespace teamscan::posegraph
