// The pose graph's back end holds, for each scan it took, only what places that scan (NodeScan) and
// its share of the graph: the returns it handed the graph are freed, so a robot that drives the same
// circle lap after lap costs, per scan, that much and not its returns besides. Measured on
// the process's heap (glibc's mallinfo2: every arena, in use, the graph's thread's included), in its
// own binary so that nothing else allocates meanwhile.
#include <gtest/gtest.h>

#include <malloc.h>

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdio>
#include <vector>

#include "groundstation/fusion/graph_backend.hpp"
#include "tests/unit/fusion/level_scan.hpp"

namespace teamscan {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr int kBeams = 361;  // a level laser over the full circle, 1° apart

std::size_t heap_in_use() {
  const struct mallinfo2 m = mallinfo2();
  return m.uordblks + m.hblkhd;
}

// The returns of a level laser at `pose` in an 8 m × 6 m room with its corner at the origin, in the
// map frame (the released scan's points), at 0.3 m.
void scan_of_room(const Pose2& pose, std::vector<mapping::MapPoint>& out) {
  out.clear();
  for (int b = 0; b < kBeams; ++b) {
    const double a = pose.theta_rad + b * kPi / 180.0, c = std::cos(a), s = std::sin(a);
    double t = 1e9;
    if (c > 1e-9) t = std::min(t, (8.0 - pose.x_m) / c);
    if (c < -1e-9) t = std::min(t, -pose.x_m / c);
    if (s > 1e-9) t = std::min(t, (6.0 - pose.y_m) / s);
    if (s < -1e-9) t = std::min(t, -pose.y_m / s);
    out.push_back({static_cast<float>(pose.x_m + t * c), static_cast<float>(pose.y_m + t * s), 0.3f});
  }
}

struct Held {
  std::size_t scans = 0;
  std::size_t bytes = 0;  // the heap in use with the back end done and alive, less before it
};

// `laps` of a 1.5 m circle about the room's centre, 5 cm a scan, one robot, the odometry exact: the
// heap the back end holds once it is done (its final poses included).
Held drive(int laps) {
  const std::size_t before = heap_in_use();
  Held h;
  {
    fusion::GraphBackendOptions o;
    posegraph::SlamOptions slam;
    slam.rematch_nodes_per_cell = 8;  // the kept returns' bound reached in the first laps
    o.slam = slam;
    fusion::GraphBackend backend(o);
    std::vector<mapping::MapPoint> points;
    constexpr double kRadius = 1.5, kStep = 0.05;
    const int per_lap = static_cast<int>(2.0 * kPi * kRadius / kStep);
    for (int k = 0; k < laps * per_lap; ++k) {
      const double phase = 2.0 * kPi * k / per_lap;
      const Pose2 pose{4.0 + kRadius * std::cos(phase), 3.0 + kRadius * std::sin(phase), phase + kPi / 2.0};
      scan_of_room(pose, points);
      fusion::testing::add_level_scan(backend, k, pose, points);
    }
    h.scans = backend.poses().size();
    EXPECT_EQ(h.scans, static_cast<std::size_t>(laps * per_lap));
    EXPECT_EQ(backend.counters().nodes, h.scans);  // a level laser's scan is a node
    std::vector<mapping::MapPoint>().swap(points);  // the test's own buffer, out of the figure
    h.bytes = heap_in_use() - before;
    const posegraph::SlamStats stats = backend.graph_stats();
    std::printf("%d laps: %zu scans, %zu submaps (%zu retired), returns of %zu nodes kept, %zu closures; heap held %.2f MB\n", laps,
                h.scans, stats.submaps, stats.retired, stats.kept_returns, stats.closures, static_cast<double>(h.bytes) / 1e6);
  }
  return h;
}

TEST(GraphBackendMemory, EachLapMoreCostsTheScansPlacesNotTheirReturns) {
  const Held a = drive(4), b = drive(8);
  ASSERT_GT(b.scans, a.scans);
  const double per_scan = static_cast<double>(b.bytes - std::min(b.bytes, a.bytes)) / static_cast<double>(b.scans - a.scans);
  constexpr double kReturnsBytes = kBeams * sizeof(Vec2);
  std::printf("the second four laps: %.0f bytes a scan more held (a scan's returns: %.0f bytes)\n", per_scan, kReturnsBytes);
  // Its place (NodeScan), its final pose, its entry among the scans taken, its graph node and
  // constraints (two insertions, the odometry's link, its closures), with the vectors' room to grow.
  // Keeping its returns would add kBeams × 16 bytes.
  EXPECT_LT(per_scan, kReturnsBytes / 3);
}

}  // namespace
}  // namespace teamscan
