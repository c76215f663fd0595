// FusionCore::take_state: the live core takes the rebuilt core's whole state and keeps its own release
// callback; the rebuilt core is left with the live core's old state (so its owner frees it where it
// likes: the station, off its loop) and no callback.

#include <gtest/gtest.h>

#include <cstdint>
#include <memory>
#include <vector>

#include "groundstation/fusion/core.hpp"

namespace teamscan::fusion {
namespace {

constexpr std::int64_t kMs = 1'000'000;

std::unique_ptr<FusionCore> make_core() {
  CoreOptions o;
  o.method = "position";
  o.max_points_per_voxel = 0;
  auto core = FusionCore::create(o);
  EXPECT_TRUE(core.ok());
  if (!core.ok()) return nullptr;
  for (std::int64_t t = 0; t <= 3'000 * kMs; t += 10 * kMs) (*core)->add_pose({1, t, 0, Pose2{0.0, 0.0, 0.0}, 0.0, 0.0});
  return std::move(*core);
}

// `n` scans of robot 1 from sequence number `first`, then everything held released.
void feed(FusionCore& core, std::uint32_t first, std::uint32_t n) {
  const std::vector<mapping::MapPoint> points{{1.0f, 1.0f, 0.5f}, {2.0f, 1.0f, 0.5f}};
  for (std::uint32_t k = 0; k < n; ++k) {
    ScanInput in;
    in.robot = 1;
    in.scan = first + k;
    in.stamp_ns = 1'000 * kMs + (first + k) * 13 * kMs;
    in.origin_m = {0.0, 0.0, 0.3};
    in.points = points;
    in.arrival_ns = in.stamp_ns;
    ASSERT_TRUE(core.add_scan(in));
  }
  core.flush();
}

TEST(FusionCoreTakeState, TheLiveCoreTakesTheStateAndKeepsItsCallbackTheOtherKeepsTheOldState) {
  std::unique_ptr<FusionCore> live = make_core(), rebuilt = make_core();
  ASSERT_TRUE(live && rebuilt);
  unsigned live_calls = 0, rebuilt_calls = 0;
  live->set_release_callback([&](const FusedScan&) { ++live_calls; });
  rebuilt->set_release_callback([&](const FusedScan&) { ++rebuilt_calls; });
  feed(*live, 1, 2);
  feed(*rebuilt, 1, 5);
  ASSERT_EQ(live->counters().scans_released, 2u);
  ASSERT_EQ(rebuilt->counters().scans_released, 5u);
  ASSERT_EQ(live_calls, 2u);
  ASSERT_EQ(rebuilt_calls, 5u);

  live->take_state(*rebuilt);
  EXPECT_EQ(live->counters().scans_released, 5u);
  EXPECT_EQ(rebuilt->counters().scans_released, 2u);  // the live core's old state

  feed(*live, 6, 1);
  EXPECT_EQ(live->counters().scans_released, 6u);
  EXPECT_EQ(live_calls, 3u);  // its own callback, kept
  EXPECT_EQ(rebuilt_calls, 5u);
  feed(*rebuilt, 3, 1);  // the old state goes on without any callback
  EXPECT_EQ(rebuilt->counters().scans_released, 3u);
  EXPECT_EQ(live_calls, 3u);
  EXPECT_EQ(rebuilt_calls, 5u);
}

}  // namespace
}  // namespace teamscan::fusion
