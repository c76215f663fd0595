// The fused map on given poses (fusion/graph_map.hpp), on a small synthetic survey: a row the graph did
// not take gets no correction (its robot's scan before it decides where it goes); the cores fed on the
// poses release every scan at its given pose and place its points by the same correction; the poses
// must be one per scan row, and the registration cannot place the scans as well.
#include <cmath>
#include <cstddef>
#include <optional>
#include <vector>

#include <gtest/gtest.h>

#include "groundstation/fusion/core_set.hpp"
#include "groundstation/fusion/graph_map.hpp"
#include "tests/bench/mapping/synthetic_survey.hpp"

namespace teamscan::fusion {
namespace {

Dataset survey() {
  bench::SurveyOptions o;
  o.robots = 2;
  o.duration_s = 3.0;
  o.room_m = 6.0;
  o.seed = 5;
  return bench::synthetic_survey(o);
}

// A pose per row: the row's own moved by a shift that grows with the row's index (a closure's pull).
std::vector<std::optional<Pose2>> moved_poses(const Dataset& d) {
  std::vector<std::optional<Pose2>> out(d.scans.size());
  for (std::size_t i = 0; i < d.scans.size(); ++i)
    out[i] = Pose2{0.001 * static_cast<double>(i), -0.0005 * static_cast<double>(i), 0.0002 * static_cast<double>(i)} * d.scans[i].pose;
  return out;
}

TEST(GraphMap, RowsTheGraphDidNotTakeGetNoPose) {
  const Dataset d = survey();
  ASSERT_GE(d.scans.size(), 4u);
  std::vector<GraphScanPose> graph;
  for (std::size_t i = 0; i < d.scans.size(); i += 2)
    graph.push_back({d.scans[i].robot, d.scans[i].scan, d.scans[i].stamp_ns, d.scans[i].pose, Pose2{1.0, 2.0, 0.5}});
  const std::vector<std::optional<Pose2>> by_row = graph_poses_by_row(d, graph);
  ASSERT_EQ(by_row.size(), d.scans.size());
  for (std::size_t i = 0; i < d.scans.size(); ++i) {
    ASSERT_EQ(by_row[i].has_value(), i % 2 == 0) << "row " << i;
    if (by_row[i]) {
      EXPECT_EQ(by_row[i]->x_m, 1.0);
    }
  }
}

TEST(GraphMap, TheCoresDecideEveryScanAtItsGivenPose) {
  const Dataset d = survey();
  const std::vector<std::optional<Pose2>> poses = moved_poses(d);
  CoreOptions o;
  o.method = "best";
  o.max_points_per_voxel = 0;
  auto cores = CoreSet::create(o, {"visibility"});
  ASSERT_TRUE(cores.ok()) << cores.error().what;
  std::size_t released = 0, points = 0;
  double worst_pose = 0.0, worst_point = 0.0;
  cores.value()->primary().set_release_callback([&](const FusedScan& f) {
    ++released;
    for (std::size_t i = 0; i < d.scans.size(); ++i) {
      const ScanRecord& row = d.scans[i];
      if (row.robot != f.view->robot || row.scan != f.view->scan) continue;
      const Pose2 got = f.view->map_from_robot, want = *poses[i];
      worst_pose = std::max({worst_pose, std::abs(got.x_m - want.x_m), std::abs(got.y_m - want.y_m), std::abs(got.theta_rad - want.theta_rad)});
      // Its points: the robot's, moved by the correction from the row's pose to the given one.
      const Pose2 m = want * row.pose.inverse();
      std::size_t j = 0;
      for (const LabelledPoint& p : d.points) {
        if (p.robot != row.robot || p.scan != row.scan) continue;
        if (j >= f.view->points.size()) break;
        const double x = m.x_m + std::cos(m.theta_rad) * p.x - std::sin(m.theta_rad) * p.y;
        const double y = m.y_m + std::sin(m.theta_rad) * p.x + std::cos(m.theta_rad) * p.y;
        worst_point = std::max({worst_point, std::abs(f.view->points[j].x - x), std::abs(f.view->points[j].y - y)});
        ++j;
        ++points;
      }
    }
  });
  const Result<std::size_t> fed = feed_on_poses(d, poses, *cores.value());
  ASSERT_TRUE(fed.ok()) << fed.error().what;
  EXPECT_EQ(fed.value(), d.scans.size());
  EXPECT_EQ(released, d.scans.size()) << "flushed: every scan released";
  EXPECT_LT(worst_pose, 1e-6);
  EXPECT_GT(points, d.points.size() / 2) << "the points compared with their moved positions";
  EXPECT_LT(worst_point, 1e-4);
  EXPECT_GT(cores.value()->at(1).counters().scans_released, 0u) << "the compared core fed too";
}

TEST(GraphMap, PosesMustBeOnePerRowAndTheRegistrationOff) {
  const Dataset d = survey();
  std::vector<std::optional<Pose2>> poses = moved_poses(d);
  poses.pop_back();
  CoreOptions o;
  o.method = "visibility";
  auto cores = CoreSet::create(o, {});
  ASSERT_TRUE(cores.ok());
  Result<std::size_t> fed = feed_on_poses(d, poses, *cores.value());
  ASSERT_FALSE(fed.ok());
  EXPECT_NE(std::string(fed.error().what).find("one per row"), std::string::npos) << fed.error().what;
  o.registration = true;
  auto registered = CoreSet::create(o, {});
  ASSERT_TRUE(registered.ok()) << registered.error().what;
  fed = feed_on_poses(d, moved_poses(d), *registered.value());
  ASSERT_FALSE(fed.ok());
  EXPECT_NE(std::string(fed.error().what).find("registration"), std::string::npos) << fed.error().what;
}

}  // namespace
}  // namespace teamscan::fusion
