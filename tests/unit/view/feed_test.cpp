// ViewFeed: the station -> view hand-off is bounded: full tap buffer drops scans (counted), too many pending
// voxel changes ask for the whole map instead, only the newest snapshot is kept; drain swaps everything out.
#include "groundstation/view/feed.hpp"

#include <gtest/gtest.h>

#include <thread>

namespace teamscan::view {
namespace {

TEST(ViewFeed, DrainHandsOverWhatWasOffered) {
  ViewFeed feed({.max_scans = 4, .max_voxels = 100});
  const TapPoint pts[] = {{1, 2, 3}, {4, 5, 6}};
  feed.offer_scan(7, pts);
  const VoxelUpdate v[] = {{50, 50, 50, 3, 1}};
  feed.offer_voxels(v);
  TeamSnapshot t;
  t.count = 1;
  t.robots[0].robot_id = 7;
  feed.offer_snapshot(t);
  FeedBatch b;
  feed.drain(b);
  ASSERT_EQ(b.scan_count, 1u);
  EXPECT_EQ(b.scans[0].robot_id, 7u);
  ASSERT_EQ(b.scans[0].count, 2u);
  EXPECT_EQ(b.scans[0].points[1].y_mm, 5);
  ASSERT_EQ(b.voxels.size(), 1u);
  EXPECT_EQ(b.voxels[0].hits, 3);
  ASSERT_TRUE(b.snapshot.has_value());
  EXPECT_EQ(b.snapshot->robots[0].robot_id, 7u);
  feed.drain(b);  // nothing new
  EXPECT_EQ(b.scan_count, 0u);
  EXPECT_TRUE(b.voxels.empty());
  EXPECT_FALSE(b.snapshot.has_value());
}

TEST(ViewFeed, AFullTapBufferDropsScansAndCountsThem) {
  ViewFeed feed({.max_scans = 3, .max_voxels = 100});
  const TapPoint p[] = {{0, 0, 0}};
  for (std::uint32_t i = 1; i <= 10; ++i) feed.offer_scan(i, p);
  EXPECT_EQ(feed.counters().scans_offered, 10u);
  EXPECT_EQ(feed.counters().scans_dropped, 7u);
  FeedBatch b;
  feed.drain(b);
  ASSERT_EQ(b.scan_count, 3u);
  EXPECT_EQ(b.scans[2].robot_id, 3u);
  feed.offer_scan(11, p);  // room again after the drain
  EXPECT_EQ(feed.counters().scans_dropped, 7u);
}

TEST(ViewFeed, TooManyPendingChangesAskForTheWholeMap) {
  ViewFeed feed({.max_scans = 1, .max_voxels = 10});
  std::vector<VoxelUpdate> six(6);
  feed.offer_voxels(six);
  EXPECT_FALSE(feed.wants_full_map());
  feed.offer_voxels(six);  // 12 > 10: dropped
  EXPECT_TRUE(feed.wants_full_map());
  EXPECT_EQ(feed.counters().voxel_overflows, 1u);
  feed.offer_voxels(six);  // ignored until the whole map comes
  FeedBatch b;
  feed.drain(b);
  EXPECT_TRUE(b.voxels.empty());
  std::vector<VoxelUpdate> whole(8);
  feed.offer_voxels(whole, true);
  EXPECT_FALSE(feed.wants_full_map());
  feed.drain(b);
  EXPECT_EQ(b.voxels.size(), 8u);
  EXPECT_TRUE(b.voxels_are_full_map);
}

TEST(ViewFeed, OnlyTheNewestSnapshotIsKept) {
  ViewFeed feed;
  TeamSnapshot t;
  for (int i = 1; i <= 5; ++i) {
    t.stamp_ns = i;
    feed.offer_snapshot(t);
  }
  EXPECT_EQ(feed.counters().snapshots_replaced, 4u);
  FeedBatch b;
  feed.drain(b);
  ASSERT_TRUE(b.snapshot.has_value());
  EXPECT_EQ(b.snapshot->stamp_ns, 5);
}

TEST(ViewFeed, OfferAndDrainFromTwoThreads) {
  ViewFeed feed({.max_scans = 16, .max_voxels = 1000});
  std::atomic<bool> done{false};
  std::uint64_t drained_scans = 0, drained_voxels = 0;
  std::thread view([&] {
    FeedBatch b;
    while (!done.load()) {
      feed.drain(b);
      drained_scans += b.scan_count;
      drained_voxels += b.voxels.size();
    }
    feed.drain(b);
    drained_scans += b.scan_count;
    drained_voxels += b.voxels.size();
  });
  const TapPoint p[] = {{1, 1, 1}};
  const VoxelUpdate v[] = {{1, 1, 1, 1, 0}};
  for (int i = 0; i < 20000; ++i) {
    feed.offer_scan(1, p);
    feed.offer_voxels(v);
  }
  done = true;
  view.join();
  const FeedCounters c = feed.counters();
  EXPECT_EQ(drained_scans + c.scans_dropped, 20000u);  // every offered scan drained or counted as dropped
  EXPECT_EQ(c.voxel_overflows == 0 ? drained_voxels : 0u, c.voxel_overflows == 0 ? 20000u : 0u);
}

}  // namespace
}  // namespace teamscan::view
