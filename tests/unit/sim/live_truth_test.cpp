// sim::match_truth (sim/live.hpp): how the demo pairs a stored scan with the truth the live feeder
// recorded when it cast that scan: the nearest sweep end within the tolerance, nothing outside it.
#include <gtest/gtest.h>

#include <vector>

#include "sim/live.hpp"

namespace teamscan::sim {
namespace {

std::vector<LiveScanTruth> truths_at(const std::vector<std::int64_t>& ends_ns) {
  std::vector<LiveScanTruth> t;
  for (std::int64_t e : ends_ns) t.push_back({e, {}});
  return t;
}

TEST(LiveTruth, MatchesTheNearestSweepEndWithinTolerance) {
  // 75 Hz scans: 13.333 ms apart.
  const auto t = truths_at({1'000'000'000, 1'013'333'333, 1'026'666'667, 1'040'000'000});
  // A stamp a little before (arrival truncated to µs minus line time) or after its sweep end.
  ASSERT_NE(match_truth(t, 1'013'330'000, 6'000'000), nullptr);
  EXPECT_EQ(match_truth(t, 1'013'330'000, 6'000'000)->sweep_end_realtime_ns, 1'013'333'333);
  EXPECT_EQ(match_truth(t, 1'026'670'000, 6'000'000)->sweep_end_realtime_ns, 1'026'666'667);
  // Nearer to the next one than to the previous: the next.
  EXPECT_EQ(match_truth(t, 1'021'000'000, 6'000'000)->sweep_end_realtime_ns, 1'026'666'667);
  // First and last.
  EXPECT_EQ(match_truth(t, 999'000'000, 6'000'000)->sweep_end_realtime_ns, 1'000'000'000);
  EXPECT_EQ(match_truth(t, 1'041'000'000, 6'000'000)->sweep_end_realtime_ns, 1'040'000'000);
}

TEST(LiveTruth, NothingOutsideTheTolerance) {
  const auto t = truths_at({1'000'000'000, 1'013'333'333});
  EXPECT_EQ(match_truth(t, 1'006'666'000, 6'000'000), nullptr);  // 6.67 ms from both
  EXPECT_EQ(match_truth(t, 990'000'000, 6'000'000), nullptr);
  EXPECT_EQ(match_truth(t, 1'030'000'000, 6'000'000), nullptr);
  EXPECT_EQ(match_truth({}, 1'000'000'000, 6'000'000), nullptr);
  // Exactly at the tolerance still matches.
  EXPECT_NE(match_truth(t, 1'006'000'000, 6'000'000), nullptr);
}

}  // namespace
}  // namespace teamscan::sim
