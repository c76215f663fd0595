// The SLAM's memory is bounded by the mapped space, not by the time mapped (SlamOptions::
// retire_after_submaps, rematch_nodes_per_cell, on by default): a robot that drives the same circle in a room lap after
// lap keeps as many live submaps and kept returns after twelve laps as after six, while without the
// bound they double; its poses stay as close to the truth as without.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <set>
#include <utility>
#include <vector>

#include "groundstation/posegraph/slam.hpp"

namespace teamscan::posegraph {
namespace {

constexpr double kPi = 3.14159265358979323846;

// A level laser's returns (`per_degree` beams a degree over 180°, robot frame) in an 8 m × 6 m room,
// from `pose`.
std::vector<Vec2> scan_of_room(const Pose2& pose, int per_degree = 1) {
  constexpr double kWidth = 8.0, kHeight = 6.0;
  std::vector<Vec2> out;
  for (int b = 0; b <= 180 * per_degree; ++b) {
    const double local = (b - 90.0 * per_degree) * kPi / (180.0 * per_degree), a = pose.theta_rad + local;
    const double dx = std::cos(a), dy = std::sin(a);
    double t = 1e9;
    if (dx > 1e-9) t = std::min(t, (kWidth - pose.x_m) / dx);
    if (dx < -1e-9) t = std::min(t, -pose.x_m / dx);
    if (dy > 1e-9) t = std::min(t, (kHeight - pose.y_m) / dy);
    if (dy < -1e-9) t = std::min(t, -pose.y_m / dy);
    out.push_back({t * std::cos(local), t * std::sin(local)});
  }
  return out;
}

struct Drive {
  SlamStats stats;
  double worst_m = 0.0;  // the graph's largest position error against the truth
  std::size_t cells = 0;  // 1 m squares the graph's poses lie in
};

// `laps` of a 1.5 m circle about the room's centre, 5 cm a scan, odometry drifting 0.2° per metre.
Drive drive(int laps, const SlamOptions& options, int beams_per_degree = 1) {
  PlanarSlam slam(options);
  constexpr double kRadius = 1.5, kStep = 0.05;
  const int per_lap = static_cast<int>(2.0 * kPi * kRadius / kStep);
  std::vector<Pose2> truth;
  std::vector<std::size_t> nodes;
  for (int k = 0; k < laps * per_lap; ++k) {
    const double phase = 2.0 * kPi * k / per_lap;
    const Pose2 t{4.0 + kRadius * std::cos(phase), 3.0 + kRadius * std::sin(phase), phase + kPi / 2.0};
    const double travelled = k * kStep;
    const double drift = 0.2 * kPi / 180.0 * travelled;
    const Pose2 odometry = Pose2{0.0, 0.0, drift} * t;  // the odometry's frame turns slowly away
    truth.push_back(t);
    nodes.push_back(slam.add_scan(1, k * 100'000'000LL, odometry, scan_of_room(t, beams_per_degree)));
  }
  slam.finish();
  Drive r;
  r.stats = slam.stats();
  std::set<std::pair<int, int>> cells;
  for (std::size_t i = 0; i < nodes.size(); ++i) {
    const Pose2 p = slam.pose(nodes[i]);
    r.worst_m = std::max(r.worst_m, std::hypot(p.x_m - truth[i].x_m, p.y_m - truth[i].y_m));
    cells.emplace(static_cast<int>(std::floor(p.x_m)), static_cast<int>(std::floor(p.y_m)));
  }
  r.cells = cells.size();
  std::printf("%d laps: %zu nodes, %zu submaps (%zu retired), returns of %zu nodes kept, %.1f MB, worst position %.3f m\n", laps,
              r.stats.nodes, r.stats.submaps, r.stats.retired, r.stats.kept_returns, static_cast<double>(r.stats.memory_bytes) / 1e6,
              r.worst_m);
  return r;
}

TEST(SlamBounded, APlaceMappedAgainAndAgainKeepsItsMemory) {
  SlamOptions unbounded;
  unbounded.retire_after_submaps = 0;
  unbounded.rematch_nodes_per_cell = 0;
  const SlamOptions bounded;  // the defaults
  const Drive u6 = drive(6, unbounded), u12 = drive(12, unbounded);
  const Drive b6 = drive(6, bounded), b12 = drive(12, bounded);
  // Without the bound, twice the laps: about twice the submaps, returns and bytes.
  EXPECT_GT(u12.stats.memory_bytes, 18 * u6.stats.memory_bytes / 10);
  EXPECT_GT(u12.stats.kept_returns, 18 * u6.stats.kept_returns / 10);
  // With it: as many submaps made, but the live ones and the kept returns stay.
  EXPECT_EQ(b12.stats.submaps, u12.stats.submaps);
  EXPECT_GT(b12.stats.retired, b6.stats.retired);
  const std::size_t live6 = b6.stats.submaps - b6.stats.retired, live12 = b12.stats.submaps - b12.stats.retired;
  EXPECT_LE(live12, live6 + 2);
  EXPECT_LE(b12.stats.kept_returns, static_cast<std::size_t>(bounded.rematch_nodes_per_cell) * (b12.cells + 4));
  EXPECT_LT(b12.stats.memory_bytes, 12 * b6.stats.memory_bytes / 10);
  // The map is as good: every pose within 5 cm of the truth, as without the bound.
  EXPECT_LT(u12.worst_m, 0.05);
  EXPECT_LT(b12.worst_m, 0.05);
}

// The second search's returns are kept thinned to one a grid cell (SlamOptions::rematch_thin_m): a laser
// ten times as dense (a beam every 0.1°, as a tilted laser's node gathers thousands of wall returns)
// keeps a fraction of the bytes it would, and its poses are as good.
TEST(SlamBounded, DenseReturnsAreKeptThinnedToOneACell) {
  SlamOptions all;
  all.rematch_thin_m = 0.0;
  const SlamOptions thinned;  // the defaults
  const Drive a = drive(3, all, 10), t = drive(3, thinned, 10);
  ASSERT_EQ(a.stats.kept_returns, t.stats.kept_returns);
  ASSERT_GT(a.stats.kept_returns, 0u);
  EXPECT_EQ(a.stats.submaps, t.stats.submaps);
  // All of them take 1 801 returns × 8 bytes a kept node; thinned, less than half of that is left.
  const std::size_t all_returns_bytes = a.stats.kept_returns * 1801 * 2 * sizeof(float);
  ASSERT_LT(t.stats.memory_bytes, a.stats.memory_bytes);
  EXPECT_GT(a.stats.memory_bytes - t.stats.memory_bytes, all_returns_bytes / 2);
  EXPECT_LT(t.worst_m, 0.05);
  EXPECT_LT(a.worst_m, 0.05);
}

// A robot's calibration (SlamOptions::calibration_loop_m) stays at none until one of its nodes closes on
// a submap it started that far back: one lap of the circle (9.4 m) does not free it at 20 m, four laps
// do, and at 0 it is found from the first lap on.
TEST(SlamCalibration, HeldAtNoneUntilARobotClosesOnAPlaceItLeftLongBefore) {
  SlamOptions o;
  o.graph.calibrate_odometry = o.graph.calibrate_local_links = true;
  o.calibration_loop_m = 20.0;
  const auto calibration = [](const Drive& d) {
    EXPECT_EQ(d.stats.calibrations.size(), 1u);
    return d.stats.calibrations.empty() ? OdometryCalibration{} : d.stats.calibrations.front().odometry;
  };
  const OdometryCalibration one_lap = calibration(drive(1, o));
  EXPECT_EQ(one_lap.distance_scale, 1.0);
  EXPECT_EQ(one_lap.turn_scale, 1.0);
  EXPECT_EQ(one_lap.heading_drift_rad_per_m, 0.0);
  const OdometryCalibration four_laps = calibration(drive(4, o));
  EXPECT_NE(four_laps.heading_drift_rad_per_m, 0.0);
  o.calibration_loop_m = 0.0;
  const OdometryCalibration from_the_start = calibration(drive(1, o));
  EXPECT_NE(from_the_start.heading_drift_rad_per_m, 0.0);
}

}  // namespace
}  // namespace teamscan::posegraph
