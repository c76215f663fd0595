// Per-scan cost of the onboard data path: decode a 361-value 0xB0 telegram -> 3-D points in the map
// frame (per-beam odometry interpolation) -> direction filter against 8 teammates -> scan message.
// Reports the median and p99 of single-scan times (goal: <= 20 µs median), the CPU share at the
// LMS's 75 Hz and the heap allocations per scan (tests/support alloc counter; the data path's own,
// without DDS: tests/hil/onboard/pipeline_dds_alloc_test counts dds_write). A figure, not a pass/fail test.
#include <benchmark/benchmark.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <string>
#include <vector>

#include "drivers/lms200/codec.hpp"
#include "drivers/lms200/scan.hpp"
#include "onboard/core/pipeline.hpp"
#include "tests/support/onboard_config_fixture.hpp"
#include "tests/support/alloc_counter.hpp"

namespace teamscan::onboard {
namespace {

OnboardConfig bench_config(bool gates) {
  std::string msg;
  auto c = parse_onboard_config(test::pipeline_test_config_toml(1, gates), msg);
  return c.value();
}

void BM_ScanPipeline(benchmark::State& state) {
  const bool gates = state.range(0) != 0;
  auto pipeline = OnboardPipeline::create(bench_config(gates));
  std::array<std::uint16_t, 361> words{};
  for (std::size_t i = 0; i < 361; ++i)
    words[i] = lms200::encode_value_word(static_cast<std::uint32_t>(600 + (i * 37) % 7000), 0,
                                         i % 60 == 5 ? lms200::BeamInvalid::dazzled : lms200::BeamInvalid::none,
                                         lms200::Unit::mm, lms200::MeasuringMode::m8_fields_dazzle);
  lms200::CountWord cw;
  cw.values = 361;
  cw.unit_bits = static_cast<std::uint8_t>(lms200::Unit::mm);
  std::array<std::uint8_t, kMaxLmsTelegram> telegram{};
  const std::size_t len = lms200::build_scan_reply(telegram, cw.encode(), words, std::nullopt);
  lms200::ScanTelegram decoded;

  TeamSnapshot team;
  team.count = 8;
  for (std::uint32_t m = 0; m < 8; ++m) {
    team.members[m].robot_id = m + 2;
    team.members[m].x_mm = 1500 + static_cast<std::int32_t>(m) * 600;
    team.members[m].y_mm = static_cast<std::int32_t>(m % 4) * 900 - 1400;
    team.members[m].length_mm = 508;
    team.members[m].width_mm = 497;
    team.members[m].height_mm = 500;
  }
  const Time t0 = Time::from_ns(1'700'000'000'000'000'000);
  OnboardPose pose;
  std::vector<double> us;
  us.reserve(1'000'000);
  std::int64_t k = 0;
  std::uint64_t filtered = 0;
  const test::AllocScope allocs;  // from here on: odometry, team, decode, geometry, filter, message
  for (auto _ : state) {
    const Time stamp = t0 + Duration{k * 26'666'666};
    if (k % 4 == 0) (void)pipeline->on_odometry(stamp, {0.0004 * static_cast<double>(k), 0.0, 0.0}, 100, 0.0, pose);
    if (k % 10 == 0) {
      for (std::uint32_t m = 0; m < 8; ++m) team.members[m].valid_ns = stamp.ns();
      pipeline->on_team(team, stamp);
    }
    ++k;
    const auto a = std::chrono::steady_clock::now();
    (void)lms200::decode_scan(std::span<const std::uint8_t>(telegram.data(), len), lms200::MeasuringMode::m8_fields_dazzle,
                              decoded);
    const ScanPoints* s = pipeline->on_scan(decoded.sweep(), stamp);
    benchmark::DoNotOptimize(s);
    const auto b = std::chrono::steady_clock::now();
    filtered += pipeline->last_filter_stats().filtered;
    if (us.size() < us.capacity()) us.push_back(std::chrono::duration<double, std::micro>(b - a).count());
  }
  const test::AllocStats heap = allocs.delta();
  state.counters["allocs_per_scan"] = static_cast<double>(heap.allocs) / static_cast<double>(std::max<std::int64_t>(1, k));
  state.counters["alloc_counter_active"] = test::alloc_counter_active() ? 1 : 0;
  std::sort(us.begin(), us.end());
  if (!us.empty()) {
    const double median = us[us.size() / 2];
    state.counters["median_us"] = median;
    state.counters["p99_us"] = us[std::min(us.size() - 1, us.size() * 99 / 100)];
    state.counters["cpu_at_75Hz_pct"] = median * 75.0 / 1e6 * 100.0;
    state.counters["filtered_per_scan"] = static_cast<double>(filtered) / static_cast<double>(us.size());
  }
}
BENCHMARK(BM_ScanPipeline)->Arg(0)->Arg(1)->ArgName("gates")->MinTime(2.0);

}  // namespace
}  // namespace teamscan::onboard
