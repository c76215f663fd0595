// ViewHub: each voxel's robot from its update (the fused model), not from the scan tap; the whole map for
// a new client, changes as deltas, tracks, scan rate, and the recent states answered by seq.
#include "groundstation/view/hub.hpp"

#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

namespace teamscan::view {
namespace {

FeedBatch batch_with(std::vector<std::pair<std::uint32_t, TapPoint>> taps, std::vector<VoxelUpdate> voxels) {
  FeedBatch b;
  b.scans.resize(taps.size());
  for (const auto& [robot, p] : taps) {
    TapScan& s = b.scans[b.scan_count++];
    s.robot_id = robot;
    s.count = 1;
    s.points[0] = p;
  }
  b.voxels = std::move(voxels);
  return b;
}

TeamSnapshot snapshot(std::int64_t stamp_ns, double x1, std::uint64_t scans1) {
  TeamSnapshot t;
  t.stamp_ns = stamp_ns;
  t.count = 2;
  t.robots[0].robot_id = 1;
  t.robots[0].x_m = x1;
  t.robots[0].scans = scans1;
  t.robots[1].robot_id = 2;
  t.robots[1].lost = true;
  return t;
}

std::vector<nlohmann::json> states(const std::vector<SharedMessage>& out) {
  std::vector<nlohmann::json> s;
  for (const SharedMessage& m : out)
    if (!m->binary) s.push_back(nlohmann::json::parse(m->bytes));
  return s;
}

std::vector<VoxelMessage> voxel_messages(const std::vector<SharedMessage>& out) {
  std::vector<VoxelMessage> v;
  for (const SharedMessage& m : out)
    if (m->binary) v.push_back(decode_voxels(m->bytes).value());
  return v;
}

TEST(ViewHub, ChangedVoxelsCarryTheRobotOfTheirUpdateNotOfTheTap) {
  ViewHub hub({.map_resolution_mm = 100});
  std::vector<SharedMessage> out;
  // Robot 2's tap scan hits both voxels; the model says robot 1 put the first point in (1, 1, 0) and robot 3
  // in (-1, 0, 0): the voxels carry the model's robots (the taps are the Foxglove scan channels').
  hub.apply(batch_with({{2, {120, 130, 40}}, {2, {-20, 30, 50}}},
                       {{150, 150, 50, 2, 0, 1}, {-50, 50, 50, 1, 1, 3}}),
            out);
  const auto msgs = voxel_messages(out);
  ASSERT_EQ(msgs.size(), 1u);
  EXPECT_EQ(msgs[0].kind, VoxelKind::kChanged);
  ASSERT_EQ(msgs[0].voxels.size(), 2u);
  EXPECT_EQ(msgs[0].voxels[0], (WireVoxel{150, 150, 50, 2, 0, 1}));
  EXPECT_EQ(msgs[0].voxels[1], (WireVoxel{-50, 50, 50, 1, 1, 3}));
  EXPECT_EQ(hub.map_voxels(), 2u);
  EXPECT_EQ(hub.counters().tap_scans, 2u);
  EXPECT_TRUE(states(out).empty());  // no snapshot came: no state message
}

TEST(ViewHub, WholeMapHasEveryVoxelOnceWithItsNewestValues) {
  ViewHub hub({.map_resolution_mm = 100});
  std::vector<SharedMessage> out;
  hub.apply(batch_with({}, {{50, 50, 50, 1, 0}, {150, 50, 50, 1, 0}}), out);
  hub.apply(batch_with({}, {{50, 50, 50, 5, 1}}), out);  // the same voxel again: replaced
  // A tap-only voxel (no map update yet) is not in the whole map.
  hub.apply(batch_with({{3, {950, 950, 950}}}, {}), out);
  std::vector<SharedMessage> whole;
  hub.whole(whole);
  const auto msgs = voxel_messages(whole);
  ASSERT_EQ(msgs.size(), 1u);
  EXPECT_EQ(msgs[0].kind, VoxelKind::kWholeMap);
  EXPECT_EQ(msgs[0].total_voxels, 2u);
  ASSERT_EQ(msgs[0].voxels.size(), 2u);
  bool found = false;
  for (const WireVoxel& v : msgs[0].voxels) {
    if (v.x_mm == 50) {
      found = true;
      EXPECT_EQ(v.hits, 5);
      EXPECT_EQ(v.flags, 1);
    }
  }
  EXPECT_TRUE(found);
  EXPECT_TRUE(states(whole).empty());  // no snapshot yet: no state
}

// A whole map from the station that leaves out a voxel the pages hold (the map decided again: the final
// model on the pose graph's poses) goes out whole, so a page clears and holds exactly it; a whole map
// that holds every voxel (the periodic one) goes out as its changes.
TEST(ViewHub, AWholeMapThatDropsVoxelsReplacesThePagesMap) {
  ViewHub hub({.map_resolution_mm = 100});
  std::vector<SharedMessage> out;
  hub.apply(batch_with({}, {{50, 50, 50, 1, 0, 1}, {150, 50, 50, 1, 0, 1}}), out);
  FeedBatch periodic = batch_with({}, {{50, 50, 50, 2, 0, 1}, {150, 50, 50, 1, 0, 1}});
  periodic.voxels_are_full_map = true;
  out.clear();
  hub.apply(periodic, out);
  auto msgs = voxel_messages(out);
  ASSERT_EQ(msgs.size(), 1u);
  EXPECT_EQ(msgs[0].kind, VoxelKind::kChanged);
  EXPECT_EQ(hub.counters().replacing_maps, 0u);

  FeedBatch decided_again = batch_with({}, {{150, 50, 50, 3, 1, 2}, {250, 50, 50, 1, 0, 2}});
  decided_again.voxels_are_full_map = true;
  out.clear();
  hub.apply(decided_again, out);
  msgs = voxel_messages(out);
  ASSERT_EQ(msgs.size(), 1u);
  EXPECT_EQ(msgs[0].kind, VoxelKind::kWholeMap);
  EXPECT_EQ(msgs[0].total_voxels, 2u);
  ASSERT_EQ(msgs[0].voxels.size(), 2u);
  for (const WireVoxel& v : msgs[0].voxels) EXPECT_NE(v.x_mm, 50) << "the voxel the map no longer holds";
  EXPECT_EQ(hub.map_voxels(), 2u);
  EXPECT_EQ(hub.counters().replacing_maps, 1u);
  std::vector<SharedMessage> whole;
  hub.whole(whole);  // a page that connects now gets the same two
  EXPECT_EQ(voxel_messages(whole).at(0).voxels.size(), 2u);
}

TEST(ViewHub, StatesCarryTrackTailsAndTheWholeStateCarriesWholeTracks) {
  ViewHub hub({.map_resolution_mm = 100, .track_step_mm = 20});
  std::vector<SharedMessage> out;
  FeedBatch b;
  b.snapshot = snapshot(1'000'000'000, 0.0, 0);
  hub.apply(b, out);
  b.snapshot = snapshot(1'500'000'000, 0.01, 10);  // moved 1 cm: below the step, no new point
  hub.apply(b, out);
  b.snapshot = snapshot(2'000'000'000, 0.5, 75);
  hub.apply(b, out);
  const auto s = states(out);
  ASSERT_EQ(s.size(), 3u);
  EXPECT_EQ(s[0]["seq"], 1);
  EXPECT_EQ(s[0]["robots"][0]["track"], nlohmann::json::parse("[0.0,0.0]"));  // first: whole
  EXPECT_EQ(s[1]["robots"][0]["track_add"], nlohmann::json::array());
  EXPECT_EQ(s[2]["robots"][0]["track_add"], nlohmann::json::parse("[0.5,0.0]"));
  EXPECT_EQ(s[2]["robots"][1]["lost"], true);
  // 75 scans in 1 s since the first snapshot.
  EXPECT_DOUBLE_EQ(s[2]["robots"][0]["scan_rate_hz"].get<double>(), 75.0);
  std::vector<SharedMessage> whole;
  hub.whole(whole);
  const auto w = states(whole);
  ASSERT_EQ(w.size(), 1u);
  EXPECT_EQ(w[0]["whole"], true);
  EXPECT_EQ(w[0]["robots"][0]["track"], nlohmann::json::parse("[0.0,0.0,0.5,0.0]"));
}

TEST(ViewHub, TracksAreCappedPerRobot) {
  ViewHub hub({.map_resolution_mm = 100, .track_step_mm = 20, .track_max_points = 100});
  std::vector<SharedMessage> out;
  FeedBatch b;
  for (int i = 0; i < 1000; ++i) {
    b.snapshot = snapshot(1'000'000'000 + i * 100'000'000LL, i * 0.1, 0);
    hub.apply(b, out);
  }
  std::vector<SharedMessage> whole;
  hub.whole(whole);
  const auto w = states(whole);
  ASSERT_EQ(w.size(), 1u);
  const std::size_t points = w[0]["robots"][0]["track"].size() / 2;
  EXPECT_LE(points, 101u);
  EXPECT_GE(points, 50u);
  EXPECT_DOUBLE_EQ(w[0]["robots"][0]["track"][2 * points - 2].get<double>(), 99.9);  // the newest is kept
}

TEST(ViewHub, StateJsonBySeqWhileHeld) {
  ViewHub hub({.map_resolution_mm = 100, .state_history = 4});
  EXPECT_FALSE(hub.state_json(std::nullopt).has_value());
  std::vector<SharedMessage> out;
  FeedBatch b;
  for (int i = 1; i <= 6; ++i) {
    b.snapshot = snapshot(i * 1'000'000'000LL, i, 0);
    hub.apply(b, out);
  }
  const auto newest = nlohmann::json::parse(*hub.state_json(std::nullopt));
  EXPECT_EQ(newest["seq"], 6);
  EXPECT_FALSE(newest["robots"][0].contains("track"));
  const auto third = nlohmann::json::parse(*hub.state_json(3));
  EXPECT_DOUBLE_EQ(third["robots"][0]["x_m"].get<double>(), 3.0);
  EXPECT_FALSE(hub.state_json(2).has_value());  // beyond the 4 held
  EXPECT_FALSE(hub.state_json(7).has_value());
}

}  // namespace
}  // namespace teamscan::view
