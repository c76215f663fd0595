// LiveMap (groundstation/station/live_map.hpp): counts and flags per voxel, the changed voxels once per
// publication with their whole counts, points beyond the index range counted.
#include "groundstation/station/live_map.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <limits>
#include <vector>

namespace {

using teamscan::station::LiveMap;

const teamscan_msg_MapVoxel* find(const std::vector<teamscan_msg_MapVoxel>& v, std::int32_t x_mm, std::int32_t y_mm, std::int32_t z_mm) {
  for (const auto& m : v)
    if (m.x_mm == x_mm && m.y_mm == y_mm && m.z_mm == z_mm) return &m;
  return nullptr;
}

TEST(LiveMap, CountsPointsPerVoxelAndFlagsVoxelsWhosePointsWereAllRemoved) {
  LiveMap map(0.1);
  map.add({0.01f, 0.02f, 0.03f}, false);
  map.add({0.09f, 0.02f, 0.03f}, true);
  map.add({1.05f, -0.05f, 0.55f}, true);
  map.add({1.01f, -0.01f, 0.51f}, true);
  std::vector<teamscan_msg_MapVoxel> all;
  map.voxels(all);
  ASSERT_EQ(all.size(), 2u);
  const auto* a = find(all, 50, 50, 50);
  const auto* b = find(all, 1050, -50, 550);
  ASSERT_NE(a, nullptr);
  ASSERT_NE(b, nullptr);
  EXPECT_EQ(a->hits, 2);
  EXPECT_EQ(a->flags, 0);  // one point kept
  EXPECT_EQ(b->hits, 2);
  EXPECT_EQ(b->flags, 1);  // every point removed
}

TEST(LiveMap, ChangedVoxelsComeOncePerPublicationWithTheirWholeCounts) {
  LiveMap map(0.1);
  std::vector<teamscan_msg_MapVoxel> out;
  map.add({0.01f, 0.01f, 0.01f}, false);
  map.add({0.51f, 0.01f, 0.01f}, false);
  map.changed_voxels(out);
  EXPECT_EQ(out.size(), 2u);
  map.changed_voxels(out);
  EXPECT_TRUE(out.empty());
  map.add({0.02f, 0.02f, 0.02f}, false);
  map.add({0.03f, 0.03f, 0.03f}, true);
  map.changed_voxels(out);
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(out[0].hits, 3);  // the whole count, not the new points
  EXPECT_EQ(out[0].x_mm, 50);
  map.add({0.51f, 0.01f, 0.01f}, false);
  map.forget_changes();
  map.changed_voxels(out);
  EXPECT_TRUE(out.empty());
  EXPECT_EQ(map.occupied_voxels(), 2u);
}

TEST(LiveMap, PointsBeyondTheIndexRangeAreCountedNotMapped) {
  LiveMap map(0.1);
  map.add({1e9f, 0, 0}, false);
  map.add({std::numeric_limits<float>::quiet_NaN(), 0, 0}, false);
  EXPECT_EQ(map.occupied_voxels(), 0u);
  EXPECT_EQ(map.rejected_points(), 2u);
}

// add_all (a released scan at a time, prefetched) gives the map add() gives point by point: the same
// voxels and counts, the same changed voxels in the same order, the same rejected count.
TEST(LiveMap, AddAllMapsWhatAddMapsOneByOne) {
  LiveMap one(0.05), all(0.05);
  std::uint32_t seed = 3;
  auto next = [&] { return (seed = seed * 1664525u + 1013904223u) >> 8; };
  std::vector<teamscan_msg_MapVoxel> changed_one, changed_all;
  for (int scan = 0; scan < 200; ++scan) {
    std::vector<teamscan::mapping::MapPoint> pts;
    std::vector<std::uint8_t> removed;
    for (int b = 0; b < 181; ++b) {
      pts.push_back({static_cast<float>(next() % 300) * 0.01f, static_cast<float>(next() % 200) * 0.01f, 0.2f});
      if (b == 90) pts.back().x = 1e9f;  // beyond the index range
      removed.push_back(static_cast<std::uint8_t>(next() % 4 == 0));
    }
    for (std::size_t i = 0; i < pts.size(); ++i) one.add(pts[i], removed[i] != 0);
    all.add_all(pts, removed);
    if (scan % 20 == 19) {
      one.changed_voxels(changed_one);
      all.changed_voxels(changed_all);
      ASSERT_EQ(changed_all.size(), changed_one.size());
      for (std::size_t i = 0; i < changed_one.size(); ++i) {
        EXPECT_EQ(changed_all[i].x_mm, changed_one[i].x_mm);
        EXPECT_EQ(changed_all[i].y_mm, changed_one[i].y_mm);
        EXPECT_EQ(changed_all[i].hits, changed_one[i].hits);
        EXPECT_EQ(changed_all[i].flags, changed_one[i].flags);
      }
    }
  }
  EXPECT_EQ(all.rejected_points(), 200u);
  EXPECT_EQ(all.rejected_points(), one.rejected_points());
  EXPECT_EQ(all.occupied_voxels(), one.occupied_voxels());
}

}  // namespace
