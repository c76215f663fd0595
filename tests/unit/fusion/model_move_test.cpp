// The fused model moved rigidly with the pose graph (groundstation/fusion/model_move.hpp): the move of
// each scan between two placements (a scan in both estimates, in one, in neither: its robot's tails),
// and FusionCore's model store moved a slice at a time while scans are released: every point where its
// scan's move takes it, the scans released meanwhile where they were placed, the cap per voxel applied
// again where moved points meet, the old store handed back.

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <map>
#include <memory>
#include <numbers>
#include <tuple>
#include <vector>

#include "groundstation/fusion/core.hpp"
#include "groundstation/fusion/model_move.hpp"

namespace teamscan::fusion {
namespace {

constexpr std::int64_t kMs = 1'000'000;

std::shared_ptr<const GraphEstimate> estimate(const std::vector<GraphScanPose>& poses) {
  std::shared_ptr<GraphEstimate> e = GraphEstimate::of_scans(poses);
  e->version = 1;
  return e;
}

void expect_move(const RigidMove& m, const Pose2& want, const char* what) {
  const RigidMove w = RigidMove::of(want);
  EXPECT_NEAR(m.cos_theta, w.cos_theta, 1e-12) << what;
  EXPECT_NEAR(m.sin_theta, w.sin_theta, 1e-12) << what;
  EXPECT_NEAR(m.x_m, w.x_m, 1e-12) << what;
  EXPECT_NEAR(m.y_m, w.y_m, 1e-12) << what;
}

TEST(ScanMoves, EachScanGoesFromWhereOnePlacementPutItToWhereTheOtherPutsIt) {
  const Pose2 odom{1.0, 2.0, 0.3};
  // Before: robot 1's scans 1 and 2 in the estimate; after: scans 2 and 3 (scan 1 went? never: a scan
  // only the first holds is still placed by the second's tail).
  const Pose2 a1{1.1, 2.0, 0.3}, a2{1.2, 2.1, 0.35}, b2{0.9, 1.8, 0.25}, b3{0.5, 2.5, 0.1};
  const ScanPlacement from = ScanPlacement::on(estimate({{1, 1, 10 * kMs, odom, a1}, {1, 2, 20 * kMs, odom, a2}}));
  const ScanPlacement to = ScanPlacement::on(estimate({{1, 2, 20 * kMs, odom, b2}, {1, 3, 30 * kMs, odom, b3}}));
  const Pose2 c_a1 = a1 * odom.inverse(), c_a2 = a2 * odom.inverse(), c_b2 = b2 * odom.inverse(), c_b3 = b3 * odom.inverse();
  EXPECT_EQ(from.tail[1], c_a2) << "the tail: the newest scan's correction";
  EXPECT_EQ(to.tail[1], c_b3);
  EXPECT_EQ(to.tail[2], Pose2{}) << "a robot without a scan in the estimate stays on its odometry";
  const ScanMoves moves(from, to);
  EXPECT_EQ(moves.scans(), 3u);
  expect_move(moves.at(1, 1), c_b3 * c_a1.inverse(), "in the first only: to the second's tail");
  expect_move(moves.at(1, 2), c_b2 * c_a2.inverse(), "in both");
  expect_move(moves.at(1, 3), c_b3 * c_a2.inverse(), "in the second only: from the first's tail");
  expect_move(moves.at(1, 99), c_b3 * c_a2.inverse(), "in neither: tail to tail");
  EXPECT_TRUE(moves.at(2, 5).identity()) << "a robot neither estimate holds";
  EXPECT_TRUE(moves.at(0, 1).identity()) << "no robot 0";
  // The largest shift: over `to`'s scans, the robot's position (where `from` put it) moved, plus the turn
  // times the reach.
  const Vec2 at2 = c_a2.apply({odom.x_m, odom.y_m}), at3 = c_a2.apply({odom.x_m, odom.y_m});
  const Vec2 to2 = (c_b2 * c_a2.inverse()).apply(at2), to3 = (c_b3 * c_a2.inverse()).apply(at3);
  const double shift = std::max(std::hypot(to2.x - at2.x, to2.y - at2.y), std::hypot(to3.x - at3.x, to3.y - at3.y));
  const double turn = std::max(std::abs((c_b2 * c_a2.inverse()).theta_rad), std::abs((c_b3 * c_a2.inverse()).theta_rad));
  EXPECT_NEAR(moves.largest_shift_m(0.0), shift, 1e-12);
  EXPECT_NEAR(moves.largest_shift_m(8.0), shift + 8.0 * turn, 1e-12);
  EXPECT_DOUBLE_EQ(ScanMoves(to, to).largest_shift_m(8.0), 0.0) << "an estimate against itself moves nothing";
  // From the odometry (no estimate) to `to`.
  const ScanMoves first({}, to);
  expect_move(first.at(1, 2), c_b2, "from the odometry");
  expect_move(first.at(1, 7), c_b3, "a scan after the estimate's, from the odometry");
  // A robot restarted: its number 2 twice in an estimate, the newest scan's counts.
  const ScanPlacement restarted = ScanPlacement::on(estimate({{1, 2, 40 * kMs, odom, b3}, {1, 2, 20 * kMs, odom, b2}}));
  expect_move(ScanMoves({}, restarted).at(1, 2), c_b3, "a number held twice");
}

// A core storing every point (cap 2 per 5 cm voxel), robot 1 at rest at the origin.
std::unique_ptr<FusionCore> make_core() {
  CoreOptions o;
  o.method = "position";
  o.model_resolution_m = 0.05;
  o.max_points_per_voxel = 2;
  auto core = FusionCore::create(o);
  EXPECT_TRUE(core.ok());
  if (!core.ok()) return nullptr;
  for (std::int64_t t = 0; t <= 10'000 * kMs; t += 10 * kMs) (*core)->add_pose({1, t, 0, Pose2{0.0, 0.0, 0.0}, 0.0, 0.0});
  return std::move(*core);
}

// Scan `seq` of robot 1: a row of points along x at y = `y_m`, 10 cm apart.
ScanInput scan(std::uint32_t seq, float y_m, int points = 40) {
  ScanInput in;
  in.robot = 1;
  in.scan = seq;
  in.stamp_ns = 1'000 * kMs + seq * 13 * kMs;
  in.origin_m = {0.0, 0.0, 0.3};
  for (int i = 0; i < points; ++i) in.points.push_back({0.1f * static_cast<float>(i) + 0.025f, y_m, 0.5f});
  in.arrival_ns = in.stamp_ns;
  return in;
}

TEST(ModelMove, EveryStoredPointGoesWhereItsScansMoveTakesItAndTheReleasesMeanwhileStayPut) {
  std::unique_ptr<FusionCore> core = make_core();
  ASSERT_TRUE(core);
  // Scans 1..3: rows at y = 1.025, 2.025 and 3.025 m, one point a voxel.
  for (std::uint32_t s = 1; s <= 3; ++s) ASSERT_TRUE(core->add_scan(scan(s, 0.025f + static_cast<float>(s))));
  core->flush();
  ASSERT_EQ(core->model_voxels(), 120u);
  ASSERT_EQ(core->counters().stored_points, 120u);

  // The estimate puts scan 1 a quarter turn about the origin and 0.5 m along x; scan 2 where it was;
  // scan 3, the robot's newest in it, 1 m down y; a scan after it goes by that tail.
  const Pose2 odom{};
  const Pose2 turn{0.5, 0.0, std::numbers::pi / 2}, down{0.0, -1.0, 0.0};
  const ScanPlacement to = ScanPlacement::on(estimate({{1, 1, 0, odom, turn}, {1, 2, 0, odom, odom}, {1, 3, 0, odom, down}}));
  core->begin_model_move(std::make_shared<const ScanMoves>(ScanPlacement{}, to));
  ASSERT_TRUE(core->moving_model());
  // The corrections are the caller's: a scan released during the move is placed by the tail already.
  core->poses().set_map_from_odom(1, core->newest_released_stamp_ns() + 1, to.tail[1], 0.0, 0.0, false);
  std::unique_ptr<ModelStore> old;
  std::vector<ModelPoint> moved;
  const auto keep = [&](const ModelPoint& p) { moved.push_back(p); };
  EXPECT_FALSE(core->continue_model_move(50, old, keep)) << "120 voxels: not in one slice of 50";
  EXPECT_EQ(old, nullptr);
  // Scan 4 released in the middle of the move, on scan 3's row as the odometry has it: the tail (1 m
  // down y) places it on scan 2's row, into the new store.
  ASSERT_TRUE(core->add_scan(scan(4, 3.025f)));
  core->flush();
  EXPECT_EQ(core->model_voxels(), 120u) << "the readers see the old store until the move is done";
  std::size_t calls = 1;
  for (bool done = false; !done; ++calls) done = core->continue_model_move(50, old, keep);
  EXPECT_EQ(calls, 3u) << "120 voxels, 50 a call";
  ASSERT_NE(old, nullptr) << "the old store handed back";
  EXPECT_EQ(old->points(), 120u);
  EXPECT_FALSE(core->moving_model());

  // Where every point is now, by scan: scan 1 turned, scan 2 unmoved with scan 4 on its row (two a
  // voxel), scan 3 moved onto that row too, where the voxels are full.
  std::map<std::uint32_t, std::vector<mapping::MapPoint>> by_scan;
  core->for_each_model_point([&](const ModelPoint& m, bool) { by_scan[m.seq].push_back(m.p); });
  ASSERT_EQ(by_scan[1].size(), 40u);
  for (const mapping::MapPoint& p : by_scan[1]) {  // (x, 1.025) turned a quarter: (-1.025, x), then +0.5 m in x
    EXPECT_NEAR(p.x, -0.525, 1e-5);
    EXPECT_GT(p.y, 0.0f);
    EXPECT_LT(p.y, 4.0f);
  }
  EXPECT_EQ(by_scan[2].size(), 40u);
  EXPECT_EQ(by_scan[4].size(), 40u);
  for (const mapping::MapPoint& p : by_scan[4]) EXPECT_NEAR(p.y, 2.025, 1e-5);
  EXPECT_EQ(by_scan.count(3), 0u) << "moved points beyond a voxel's cap are dropped";
  EXPECT_EQ(core->counters().stored_points, 120u);
  EXPECT_EQ(core->counters().capped_points, 40u);
  EXPECT_EQ(core->robot_counters(1).stored_points, 120u);
  // A second move (scan 2's row 0.5 m up, off scan 4's): the caps of the first stay counted.
  const ScanPlacement up = ScanPlacement::on(estimate({{1, 1, 0, odom, turn}, {1, 2, 0, odom, Pose2{0.0, 0.5, 0.0}},
                                                       {1, 3, 0, odom, down}, {1, 4, 0, odom, down}}));
  core->begin_model_move(std::make_shared<const ScanMoves>(to, up));
  while (!core->continue_model_move(50, old)) {
  }
  std::size_t on_row = 0;
  core->for_each_model_point([&](const ModelPoint& m, bool) { on_row += m.seq == 2 && std::abs(m.p.y - 2.525f) < 1e-5f ? 1 : 0; });
  EXPECT_EQ(on_row, 40u);
  EXPECT_EQ(core->counters().stored_points, 120u);
  EXPECT_EQ(core->counters().capped_points, 40u) << "the first move's caps, none new";
  // The moved points the live map is told of: scan 1's and 2's (scan 3's were capped; scan 4 was released
  // into the new store directly).
  EXPECT_EQ(moved.size(), 80u);
}

}  // namespace
}  // namespace teamscan::fusion
