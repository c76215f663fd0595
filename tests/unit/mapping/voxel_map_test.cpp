// Sparse voxel map: keys by floor division, counts, column minima, μ and σ of eq. 3.
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "groundstation/mapping/voxel_map.hpp"

namespace teamscan::mapping {
namespace {

TEST(VoxelMap, KeyIsFloorOfCoordinateOverResolution) {
  const VoxelMap map(0.1);
  EXPECT_EQ(map.key_of({0.05f, 0.15f, 0.0f}), (VoxelKey{0, 1, 0}));
  // floor, not truncation: −0.01 m is in voxel −1.
  EXPECT_EQ(map.key_of({-0.01f, -0.15f, -0.2f}), (VoxelKey{-1, -2, -3}));
}

TEST(VoxelMap, PackRoundTripsIncludingNegativeAndExtremeIndices) {
  for (const VoxelKey k : {VoxelKey{0, 0, 0}, VoxelKey{-1, 2, -3}, VoxelKey{VoxelMap::kIndexLimit - 1, -VoxelMap::kIndexLimit, 7}})
    EXPECT_EQ(VoxelMap::unpack(VoxelMap::pack(k)), k);
  EXPECT_NE(VoxelMap::pack({1, 0, 0}), VoxelMap::pack({0, 1, 0}));
}

TEST(VoxelMap, EmptyMapHasNoVoxelsAndZeroStatistics) {
  const VoxelMap map(0.05);
  EXPECT_EQ(map.occupied_voxels(), 0u);
  EXPECT_EQ(map.count({0, 0, 0}), 0u);
  EXPECT_FALSE(map.column_lowest_z(0, 0).has_value());
  EXPECT_EQ(map.mean_count(), 0.0);
  EXPECT_EQ(map.stddev_count(), 0.0);
}

TEST(VoxelMap, CountsPointsPerVoxelAndLowestZPerColumn) {
  VoxelMap map(0.1);
  map.insert({0.01f, 0.01f, 0.31f});  // column (0,0), z 3
  map.insert({0.02f, 0.02f, 0.32f});  // same voxel
  map.insert({0.03f, 0.03f, 0.05f});  // column (0,0), z 0
  map.insert({0.5f, 0.5f, 1.0f});     // column (5,5), z 10 (1.0/0.1 rounds to exactly 10)
  EXPECT_EQ(map.points(), 4u);
  EXPECT_EQ(map.occupied_voxels(), 3u);
  EXPECT_EQ(map.occupied_columns(), 2u);
  EXPECT_EQ(map.count({0, 0, 3}), 2u);
  EXPECT_EQ(map.count({0, 0, 0}), 1u);
  EXPECT_EQ(map.count({0, 0, 1}), 0u);
  EXPECT_EQ(map.column_lowest_z(0, 0), 0);
  EXPECT_EQ(map.column_lowest_z(5, 5), 10);
  EXPECT_FALSE(map.column_lowest_z(1, 0).has_value());
}

TEST(VoxelMap, MeanAndDeviationOverOccupiedVoxels) {
  // Counts 1, 2, 3, 6 in four voxels: μ = 3, population σ² = (4 + 1 + 0 + 9) / 4 = 3.5.
  VoxelMap map(1.0);
  const int counts[] = {1, 2, 3, 6};
  for (int v = 0; v < 4; ++v)
    for (int i = 0; i < counts[v]; ++i) map.insert({static_cast<float>(v) + 0.5f, 0.5f, 0.5f});
  EXPECT_DOUBLE_EQ(map.mean_count(), 3.0);
  EXPECT_NEAR(map.stddev_count(), std::sqrt(3.5), 1e-12);
}

TEST(VoxelMap, BatchAndIncrementalInsertGiveTheSameMap) {
  std::vector<MapPoint> cloud;
  for (int i = 0; i < 5000; ++i)
    cloud.push_back({static_cast<float>(std::sin(i) * 3.0), static_cast<float>(std::cos(i * 0.7) * 3.0),
                     static_cast<float>((i % 37) * 0.013)});
  VoxelMap batch(0.05), incremental(0.05);
  batch.insert(cloud);
  for (const MapPoint& p : cloud) incremental.insert(p);
  ASSERT_EQ(batch.occupied_voxels(), incremental.occupied_voxels());
  batch.for_each_voxel([&](VoxelKey k, std::uint32_t c) { EXPECT_EQ(incremental.count(k), c); });
  EXPECT_DOUBLE_EQ(batch.mean_count(), incremental.mean_count());
}

TEST(VoxelMap, NonFiniteAndFarPointsAreCountedNotStored) {
  VoxelMap map(0.05);
  map.insert({NAN, 0.0f, 0.0f});
  map.insert({1e9f, 0.0f, 0.0f});
  map.insert({0.0f, 0.0f, 0.0f});
  EXPECT_EQ(map.rejected_points(), 2u);
  EXPECT_EQ(map.points(), 1u);
  EXPECT_EQ(map.occupied_voxels(), 1u);
}

TEST(VoxelMap, GrowsPastManyRehashesAndKeepsEveryVoxel) {
  VoxelMap map(0.1);
  for (int x = 0; x < 100; ++x)
    for (int y = 0; y < 100; ++y) map.insert({x * 0.1f + 0.05f, y * 0.1f + 0.05f, 0.05f});
  EXPECT_EQ(map.occupied_voxels(), 10000u);
  EXPECT_EQ(map.count({99, 99, 0}), 1u);
  EXPECT_GT(map.memory_bytes(), 10000u * 12u);  // at least key + count per voxel
}

}  // namespace
}  // namespace teamscan::mapping
