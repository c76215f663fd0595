// Firmware discipline (STYLE.md 5) for the store-and-forward ring: after ScanRing::open, appending scans and
// poses, flushing, confirmations, back-fill and a full ring that wraps allocate nothing (tests/support
// alloc counter, every thread of the process).
#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdio>
#include <string>

#include "onboard/ring/scan_ring.hpp"
#include "tests/support/alloc_counter.hpp"

namespace teamscan::onboard::ring {
namespace {

TEST(RingAllocation, CounterIsLinkedIn) { EXPECT_TRUE(test::alloc_counter_active()); }

TEST(RingAllocation, AppendFlushConfirmBackfillAllocateNothing) {
  RingConfig config;
  config.path = testing::TempDir() + "/alloc-" + std::to_string(::getpid()) + ".ring";
  std::remove(config.path.c_str());
  config.capacity_s = 10.0;  // 850 slots: the 3000 scans below wrap it three times
  config.flush_records = 75;
  auto opened = ScanRing::open(config, 1, 300);
  ASSERT_TRUE(opened.ok()) << opened.error().what;
  ScanRing& ring = *opened.value();

  ScanPoints scan;
  scan.robot_id = 1;
  scan.count = 361;
  for (std::uint16_t i = 0; i < 361; ++i) scan.points[i] = ScanPoint{i, -i, 400, i, 0};
  OnboardPose pose;
  pose.robot_id = 1;
  ScanPoints back;
  Time now = Time::from_ns(1'000'000'000'000);
  std::uint64_t backfilled = 0;

  const test::AllocStats before = test::process_alloc_stats();
  for (std::uint32_t k = 1; k <= 3000; ++k) {
    now = now + std::chrono::microseconds(13'333);
    scan.seq = k;
    scan.stamp = now;
    ASSERT_TRUE(ring.append_scan(scan, now).ok());
    if (k % 8 == 0) {
      pose.seq = k / 8;
      ASSERT_TRUE(ring.append_pose(pose, now).ok());
    }
    ASSERT_TRUE(ring.flush_if_due(now).ok());
    // A station that confirms up to 1000, goes away for 1000 scans and comes back.
    if (k <= 1000 || k > 2000) (void)ring.on_confirmation(1, k <= 1000 ? k : 1000 + (k - 2000), now);
    (void)ring.on_confirmation(40, 1, now);  // refused: unknown robot
    ring.start_turn(now);
    while (ring.next_backfill(now, back)) ++backfilled;
  }
  const test::AllocStats delta = test::process_alloc_stats() - before;
  EXPECT_EQ(delta.allocs, 0u) << delta.bytes << " bytes";
  EXPECT_GT(backfilled, 0u);
  EXPECT_GT(ring.index().counters().dropped_unconfirmed, 0u);
  EXPECT_GT(ring.flush_counters().flushes, 0u);
  std::remove(config.path.c_str());
}

}  // namespace
}  // namespace teamscan::onboard::ring
