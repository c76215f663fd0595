// Per-scan cost of the store-and-forward ring (onboard/ring): the record alone (encode + CRC-32C of a
// 361-point scan) and append_scan (the record and its pwrite into the ring file's page cache), with the
// fdatasync of the flush policy measured apart (its cost depends on the storage, not on the scan).
// Reports the median and p99 of single-scan times (goal: <= 5 µs per scan), the allocations per scan
// (tests/support alloc counter) and the flush's median and maximum. The ring file goes to
// $TEAMSCAN_RING_BENCH_DIR (default /tmp: on this machine a tmpfs or a disk, say which in the figures).
// A figure, not a pass/fail test.
#include <benchmark/benchmark.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "common/clock.hpp"
#include "onboard/ring/record.hpp"
#include "onboard/ring/scan_ring.hpp"
#include "tests/support/alloc_counter.hpp"

namespace teamscan::onboard::ring {
namespace {

ScanPoints bench_scan() {
  ScanPoints s;
  s.robot_id = 1;
  s.count = 361;
  for (std::uint16_t i = 0; i < 361; ++i)
    s.points[i] = ScanPoint{1000 + i * 7, -2000 + i * 3, 450 - i, i, static_cast<std::uint16_t>(i % 5 == 0 ? 1 : 0)};
  return s;
}

void report(benchmark::State& state, std::vector<double>& us, const test::AllocStats& heap, std::int64_t n) {
  state.counters["allocs_per_scan"] =
      static_cast<double>(heap.allocs) / static_cast<double>(std::max<std::int64_t>(1, n));
  state.counters["alloc_counter_active"] = test::alloc_counter_active() ? 1 : 0;
  std::sort(us.begin(), us.end());
  if (us.empty()) return;
  state.counters["median_us"] = us[us.size() / 2];
  state.counters["p99_us"] = us[std::min(us.size() - 1, us.size() * 99 / 100)];
  state.counters["cpu_at_75Hz_pct"] = us[us.size() / 2] * 75.0 / 1e6 * 100.0;
}

void BM_RingRecord(benchmark::State& state) {
  ScanPoints scan = bench_scan();
  alignas(64) std::array<std::uint8_t, kSlotBytes> slot{};
  std::vector<double> us;
  us.reserve(1'000'000);
  std::int64_t k = 0;
  const test::AllocScope allocs;
  for (auto _ : state) {
    scan.seq = static_cast<std::uint32_t>(++k);
    const auto a = std::chrono::steady_clock::now();
    const std::size_t n = encode_scan_record(scan, static_cast<std::uint64_t>(k), slot);
    benchmark::DoNotOptimize(n);
    benchmark::ClobberMemory();
    const auto b = std::chrono::steady_clock::now();
    if (us.size() < us.capacity()) us.push_back(std::chrono::duration<double, std::micro>(b - a).count());
  }
  report(state, us, allocs.delta(), k);
}
BENCHMARK(BM_RingRecord)->MinTime(1.0);

void BM_RingAppendScan(benchmark::State& state) {
  const char* dir = std::getenv("TEAMSCAN_RING_BENCH_DIR");
  RingConfig config;
  config.path =
      std::string(dir != nullptr ? dir : "/tmp") + "/teamscan-ring-bench-" + std::to_string(::getpid()) + ".ring";
  config.capacity_s = 60.0;  // 5100 slots, 34 MB: wraps during the run
  config.flush_records = 75;
  config.flush_period = std::chrono::seconds(1);
  auto ring = ScanRing::open(config, 1, 300);
  if (!ring.ok()) {
    state.SkipWithError(ring.error().what);
    return;
  }
  ScanPoints scan = bench_scan();
  std::vector<double> us, flush_us;
  us.reserve(1'000'000);
  flush_us.reserve(100'000);
  std::int64_t k = 0;
  const test::AllocScope allocs;
  for (auto _ : state) {
    scan.seq = static_cast<std::uint32_t>(++k);
    const Time now = now_monotonic();
    const auto a = std::chrono::steady_clock::now();
    const Status s = ring.value()->append_scan(scan, now);
    const auto b = std::chrono::steady_clock::now();
    benchmark::DoNotOptimize(s);
    if (us.size() < us.capacity()) us.push_back(std::chrono::duration<double, std::micro>(b - a).count());
    if (k % 75 == 0) {  // the default policy at 75 Hz: one fdatasync a second
      const auto c = std::chrono::steady_clock::now();
      (void)ring.value()->flush();
      const auto d = std::chrono::steady_clock::now();
      if (flush_us.size() < flush_us.capacity())
        flush_us.push_back(std::chrono::duration<double, std::micro>(d - c).count());
    }
  }
  report(state, us, allocs.delta(), k);
  std::sort(flush_us.begin(), flush_us.end());
  if (!flush_us.empty()) {
    state.counters["flush_median_us"] = flush_us[flush_us.size() / 2];
    state.counters["flush_max_us"] = flush_us.back();
  }
  state.counters["write_errors"] = static_cast<double>(ring.value()->index().counters().write_errors);
  ring.value().reset();
  std::remove(config.path.c_str());
}
BENCHMARK(BM_RingAppendScan)->MinTime(2.0);

}  // namespace
}  // namespace teamscan::onboard::ring
