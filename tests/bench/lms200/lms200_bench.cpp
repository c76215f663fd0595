// Benchmarks of the LMS 2xx driver: stream parser throughput (bytes/s over 361-value telegrams with
// ACKs and some garbage), per-scan decode time of a 361-value telegram, and the SICK CRC alone.
// Figures only: no pass/fail.
#include <benchmark/benchmark.h>

#include <array>
#include <random>
#include <vector>

#include "drivers/lms200/codec.hpp"
#include "drivers/lms200/parser.hpp"
#include "drivers/lms200/scan.hpp"

namespace teamscan::lms200 {
namespace {

std::vector<std::uint8_t> scan_telegram(std::mt19937& rng, std::uint16_t values) {
  std::array<std::uint16_t, kMaxBeams> words{};
  for (std::size_t i = 0; i < values; ++i) words[i] = static_cast<std::uint16_t>(rng() & 0x3FFF);
  std::array<std::uint8_t, kMaxLmsTelegram> t{};
  const std::size_t n = build_scan_reply(t, CountWord{values, 0, false, 1}.encode(), std::span{words}.first(values),
                                         std::nullopt);
  return {t.begin(), t.begin() + static_cast<std::ptrdiff_t>(n)};
}

void BM_ParserThroughput361(benchmark::State& state) {
  std::mt19937 rng{7};
  std::vector<std::uint8_t> stream;
  for (int k = 0; k < 200; ++k) {
    const auto t = scan_telegram(rng, 361);
    stream.insert(stream.end(), t.begin(), t.end());
    if (k % 10 == 0) stream.push_back(kAck);
    if (k % 50 == 0) stream.insert(stream.end(), {0xFF, 0x02, 0x80, 0x01});  // garbage and a bad header
  }
  std::uint64_t telegrams = 0;
  for (auto _ : state) {
    LmsParser p;
    std::span<const std::uint8_t> in{stream};
    while (!in.empty()) {
      in = in.subspan(p.feed(in));
      LmsEvent e;
      while (p.next(e)) benchmark::DoNotOptimize(e.bytes.data());
    }
    telegrams += p.statistics().telegrams;
  }
  state.SetBytesProcessed(static_cast<std::int64_t>(state.iterations()) * static_cast<std::int64_t>(stream.size()));
  state.counters["telegrams/s"] = benchmark::Counter(static_cast<double>(telegrams), benchmark::Counter::kIsRate);
}
BENCHMARK(BM_ParserThroughput361);

void BM_DecodeScan361(benchmark::State& state) {
  std::mt19937 rng{9};
  const auto t = scan_telegram(rng, 361);
  ScanTelegram s;
  for (auto _ : state) {
    const Status st = decode_scan(t, MeasuringMode::m8_fields_dazzle, s);
    benchmark::DoNotOptimize(st.ok());
    benchmark::DoNotOptimize(s.ranges_mm.data());
  }
  state.SetItemsProcessed(static_cast<std::int64_t>(state.iterations()));
}
BENCHMARK(BM_DecodeScan361);

void BM_SickCrc732(benchmark::State& state) {
  std::mt19937 rng{11};
  const auto t = scan_telegram(rng, 361);
  for (auto _ : state) benchmark::DoNotOptimize(sick_crc16(std::span{t}.first(t.size() - 2)));
  state.SetBytesProcessed(static_cast<std::int64_t>(state.iterations()) * static_cast<std::int64_t>(t.size() - 2));
}
BENCHMARK(BM_SickCrc732);

}  // namespace
}  // namespace teamscan::lms200
