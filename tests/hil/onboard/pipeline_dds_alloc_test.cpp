// Firmware discipline end to end: 10 000 scans through the full robot data path - LMS
// telegram decode -> 3-D points -> direction filter against 8 teammates -> DdsBridge::publish_scan
// (dds_write) - allocate nothing in our code and a constant number of blocks inside Cyclone's write.
// Uses the loopback DDS config (CYCLONEDDS_URI, set by ctest) in a domain of its own.
#include <gtest/gtest.h>

#include <unistd.h>

#include <array>
#include <cstdio>
#include <map>
#include <string>
#include <vector>

#include "drivers/lms200/codec.hpp"
#include "drivers/lms200/scan.hpp"
#include "onboard/core/pipeline.hpp"
#include "tests/support/onboard_config_fixture.hpp"
#include "onboard/bridge/bridge.hpp"
#include "tests/support/alloc_counter.hpp"

namespace teamscan::onboard {
namespace {

using namespace teamscan::dds;

constexpr int kScans = 10'000;

TEST(PipelineDdsAllocations, CounterIsLinkedIn) { EXPECT_TRUE(test::alloc_counter_active()); }

TEST(PipelineDdsAllocations, DecodeFilterPublishTenThousandScans) {
  std::string msg;
  auto config = parse_onboard_config(test::pipeline_test_config_toml(7, true), msg);
  ASSERT_TRUE(config.ok()) << msg;
  auto pipeline = OnboardPipeline::create(config.value());
  ASSERT_TRUE(pipeline.ok());
  DdsBridgeOptions options;
  options.robot_id = 7;
  options.domain_id = static_cast<std::uint32_t>(150 + ::getpid() % 80);  // away from other tests' traffic
  options.scan_history_depth = 300;
  options.subscribe_team = false;
  auto bridge = DdsBridge::create(options);
  ASSERT_TRUE(bridge.ok()) << bridge.error().what;

  // One 361-value telegram as the scanner sends it (mm, measuring mode 0).
  std::array<std::uint16_t, 361> words{};
  for (std::size_t i = 0; i < 361; ++i)
    words[i] = lms200::encode_value_word(static_cast<std::uint32_t>(600 + (i * 37) % 7000), 0, lms200::BeamInvalid::none,
                                         lms200::Unit::mm, lms200::MeasuringMode::m8_fields_dazzle);
  lms200::CountWord cw;
  cw.values = 361;
  cw.unit_bits = static_cast<std::uint8_t>(lms200::Unit::mm);
  std::array<std::uint8_t, kMaxLmsTelegram> telegram{};
  const std::size_t len = lms200::build_scan_reply(telegram, cw.encode(), words, std::nullopt);
  static lms200::ScanTelegram decoded;

  static TeamSnapshot team;
  team.count = 8;
  for (std::uint32_t m = 0; m < 8; ++m) {
    team.members[m].robot_id = m + 8;
    team.members[m].x_mm = 1500 + static_cast<std::int32_t>(m) * 600;
    team.members[m].y_mm = static_cast<std::int32_t>(m % 4) * 900 - 1400;
  }

  std::vector<std::uint32_t> ours(kScans), in_write(kScans);  // preallocated before counting
  const Time t0 = Time::from_ns(1'700'000'000'000'000'000);
  OnboardPose pose;
  std::uint64_t filtered = 0;
  for (int k = 0; k < kScans; ++k) {
    const Time stamp = t0 + Duration{static_cast<std::int64_t>(k) * 26'666'666};
    test::AllocScope scope;
    if (k % 4 == 0) (void)pipeline->on_odometry(stamp, {0.0004 * k, 0.0, 0.0}, 100, 0.0, pose);
    if (k % 10 == 0) {
      for (std::uint32_t m = 0; m < 8; ++m) team.members[m].valid_ns = stamp.ns();
      pipeline->on_team(team, stamp);
    }
    ASSERT_TRUE(lms200::decode_scan(std::span<const std::uint8_t>(telegram.data(), len),
                                    lms200::MeasuringMode::m8_fields_dazzle, decoded).ok());
    const ScanPoints* scan = pipeline->on_scan(decoded.sweep(), stamp);
    ASSERT_NE(scan, nullptr);
    filtered += pipeline->last_filter_stats().filtered;
    ours[static_cast<std::size_t>(k)] = static_cast<std::uint32_t>(scope.delta().allocs);
    scope.restart();
    const Status st = bridge->publish_scan(*scan);
    in_write[static_cast<std::size_t>(k)] = static_cast<std::uint32_t>(scope.delta().allocs);
    ASSERT_TRUE(st.ok()) << st.error().what;
  }
  EXPECT_GT(filtered, 0u);  // the filter really ran against the teammates

  std::uint64_t ours_total = 0;
  for (auto a : ours) ours_total += a;
  EXPECT_EQ(ours_total, 0u);

  // After the writer history (300 scans) has filled, every write costs the same.
  std::map<std::uint32_t, int> histogram;
  for (std::size_t i = 2 * options.scan_history_depth; i < in_write.size(); ++i) ++histogram[in_write[i]];
  std::string h;
  for (const auto& [allocs, n] : histogram) h += std::to_string(allocs) + " allocs x" + std::to_string(n) + "; ";
  std::printf("allocations per scan: decode+points+filter %llu in total; publish_scan after warm-up: %s\n",
              static_cast<unsigned long long>(ours_total), h.c_str());
  EXPECT_EQ(histogram.size(), 1u) << h;
  EXPECT_LE(histogram.begin()->first, 3u) << h;  // Cyclone's own blocks (DDS_SYSTEMD.md 1.8)
}

}  // namespace
}  // namespace teamscan::onboard
