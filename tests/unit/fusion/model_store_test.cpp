// ModelStore (groundstation/fusion/model_store.hpp): the cap per voxel, the order of voxels and points,
// chunk and page boundaries, non-finite points, and memory that follows the voxels, not the points fed.
#include "groundstation/fusion/model_store.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <vector>

namespace {

using teamscan::fusion::ModelPoint;
using teamscan::fusion::ModelStore;

ModelPoint point(float x, float y, float z, std::uint32_t seq, std::uint16_t beam = 0, std::uint8_t robot = 1) {
  ModelPoint m;
  m.p = {x, y, z};
  m.seq = seq;
  m.beam = beam;
  m.robot = robot & 0x7Fu;
  m.bits = static_cast<std::uint8_t>(seq & 0xFFu);
  m.removed_at_release = (seq % 2) != 0 ? 1 : 0;
  return m;
}

std::vector<ModelPoint> voxel(const ModelStore& s, std::size_t k) {
  std::vector<ModelPoint> out;
  s.for_each_in_voxel(k, [&](const ModelPoint& m) { out.push_back(m); });
  return out;
}

TEST(ModelStore, KeepsTheFirstCapPointsOfEachVoxelInOrderAndCountsTheRest) {
  ModelStore s(0.05, 10);  // 10: three chunks of 4, the last partly used
  for (std::uint32_t i = 0; i < 25; ++i) EXPECT_EQ(s.add(point(0.01f + 0.001f * static_cast<float>(i), 0.02f, 0.03f, i, static_cast<std::uint16_t>(i))), i < 10);
  ASSERT_EQ(s.voxels(), 1u);
  EXPECT_EQ(s.points(), 10u);
  EXPECT_EQ(s.capped_points(), 15u);
  const std::vector<ModelPoint> v = voxel(s, 0);
  ASSERT_EQ(v.size(), 10u);
  for (std::uint32_t i = 0; i < 10; ++i) {
    EXPECT_EQ(v[i].seq, i);
    EXPECT_EQ(v[i].beam, i);
    EXPECT_EQ(v[i].robot, 1u);
    EXPECT_EQ(v[i].bits, i);
    EXPECT_EQ(v[i].removed_at_release, i % 2);
    EXPECT_FLOAT_EQ(v[i].p.x, 0.01f + 0.001f * static_cast<float>(i));
  }
}

TEST(ModelStore, VoxelsKeepTheOrderTheyWereFirstHitAcrossChunkPages) {
  // More voxels than one page of chunks (4096), each voxel's points interleaved with the others'.
  ModelStore s(0.05, 8);
  const int n = 5000;
  for (std::uint32_t round = 0; round < 3; ++round)
    for (int i = 0; i < n; ++i) ASSERT_TRUE(s.add(point(0.05f * static_cast<float>(i) + 0.025f, -1.0f, 0.5f, round * 100000u + static_cast<std::uint32_t>(i), 0, 31)));
  ASSERT_EQ(s.voxels(), static_cast<std::size_t>(n));
  for (int i = 0; i < n; i += 997) {
    const std::vector<ModelPoint> v = voxel(s, static_cast<std::size_t>(i));
    ASSERT_EQ(v.size(), 3u);
    for (std::uint32_t round = 0; round < 3; ++round) {
      EXPECT_EQ(v[round].seq, round * 100000u + static_cast<std::uint32_t>(i));
      EXPECT_EQ(v[round].robot, 31u);
    }
  }
}

TEST(ModelStore, NegativeCoordinatesFallInTheirOwnVoxels) {
  ModelStore s(0.05, 8);
  EXPECT_TRUE(s.add(point(-0.01f, 0.01f, 0.01f, 1)));
  EXPECT_TRUE(s.add(point(0.01f, 0.01f, 0.01f, 2)));
  EXPECT_TRUE(s.add(point(-0.04f, 0.01f, 0.01f, 3)));
  EXPECT_EQ(s.voxels(), 2u);
  EXPECT_EQ(s.voxel_points(0), 2u);  // -0.01 and -0.04: voxel −1
  EXPECT_EQ(s.voxel_points(1), 1u);
}

TEST(ModelStore, RefusesNonFinitePointsWithoutCountingThemCapped) {
  ModelStore s(0.05, 8);
  const float nan = std::numeric_limits<float>::quiet_NaN(), inf = std::numeric_limits<float>::infinity();
  EXPECT_FALSE(s.add(point(nan, 0, 0, 1)));
  EXPECT_FALSE(s.add(point(0, inf, 0, 2)));
  EXPECT_FALSE(s.add(point(0, 0, -inf, 3)));
  EXPECT_EQ(s.voxels(), 0u);
  EXPECT_EQ(s.points(), 0u);
  EXPECT_EQ(s.capped_points(), 0u);
}

TEST(ModelStore, ACapOfZeroStoresNothing) {
  ModelStore s(0.05, 0);
  EXPECT_FALSE(s.add(point(0, 0, 0, 1)));
  EXPECT_EQ(s.voxels(), 0u);
}

// The bound: memory follows the voxels (and their capped points), not how many points were fed.
TEST(ModelStore, MemoryFollowsTheVoxelsNotThePointsFed) {
  ModelStore s(0.05, 8);
  for (int i = 0; i < 2000; ++i) s.add(point(0.05f * static_cast<float>(i % 1000) + 0.01f, 0, 0, static_cast<std::uint32_t>(i)));
  const std::size_t after_two_passes = s.memory_bytes();
  for (int pass = 0; pass < 50; ++pass)
    for (int i = 0; i < 1000; ++i) s.add(point(0.05f * static_cast<float>(i) + 0.02f, 0, 0, static_cast<std::uint32_t>(pass * 1000 + i)));
  EXPECT_EQ(s.voxels(), 1000u);
  EXPECT_EQ(s.points(), 8000u);
  EXPECT_EQ(s.capped_points(), 52000u - 8000u);
  // Eight points per voxel need a second chunk (four points a chunk): at most one more page was paid for.
  EXPECT_LE(s.memory_bytes(), after_two_passes + 4096u * (4u * sizeof(ModelPoint) + 4u));
  EXPECT_LE(s.memory_bytes(), 1000u * 8u * sizeof(ModelPoint) + 4096u * (4u * sizeof(ModelPoint) + 4u) * 2u + 64u * 1024u);
}

}  // namespace

// add_all (a scan at a time, prefetched) stores exactly what add() one point at a time stores: the
// same voxels in the same order, the same points in each, the same counts, across scans that revisit
// voxels, fill them past the cap, carry non-finite points and cross chunk pages.
TEST(ModelStore, AddAllStoresWhatAddStoresOneByOne) {
  ModelStore one(0.05, 8), all(0.05, 8);
  std::uint32_t seed = 7;
  auto next = [&] { return (seed = seed * 1664525u + 1013904223u) >> 8; };
  std::size_t stored_one = 0, stored_all = 0;
  for (std::uint32_t scan = 0; scan < 400; ++scan) {
    std::vector<ModelPoint> pts;
    for (std::uint16_t b = 0; b < 181; ++b) {
      const float x = static_cast<float>(next() % 400) * 0.01f - 2.0f, y = static_cast<float>(next() % 300) * 0.01f;
      pts.push_back(point(x, y, 0.3f, scan, b, static_cast<std::uint8_t>(1 + scan % 5)));
      if (b % 50 == 7) pts.back().p.x = std::numeric_limits<float>::quiet_NaN();
      if (b % 3 == 0 && b > 0) pts.back().p = pts[b - 1].p;  // neighbouring beams in one voxel
    }
    for (const ModelPoint& m : pts) stored_one += one.add(m) ? 1 : 0;
    stored_all += all.add_all(pts);
  }
  EXPECT_EQ(stored_all, stored_one);
  EXPECT_EQ(all.points(), one.points());
  EXPECT_EQ(all.capped_points(), one.capped_points());
  EXPECT_GT(one.capped_points(), 0u);
  ASSERT_EQ(all.voxels(), one.voxels());
  for (std::size_t k = 0; k < one.voxels(); ++k) {
    std::vector<std::pair<std::uint32_t, std::uint16_t>> a, b;
    one.for_each_in_voxel(k, [&](const ModelPoint& m) { a.emplace_back(m.seq, m.beam); });
    all.for_each_in_voxel(k, [&](const ModelPoint& m) { b.emplace_back(m.seq, m.beam); });
    ASSERT_EQ(a, b) << "voxel " << k;
  }
}
