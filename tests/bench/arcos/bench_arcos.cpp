// Benchmarks of the ARCOS codec and parser: parser throughput (MB/s) on clean and corrupted SIP
// streams, SIP decode and encode time. Figures only, never pass/fail (STYLE.md Tests).
#include <benchmark/benchmark.h>

#include <random>
#include <vector>

#include "drivers/arcos/codec.hpp"
#include "drivers/arcos/parser.hpp"

namespace teamscan::arcos {
namespace {

SipPacket typical_sip(std::uint16_t i) {
  SipPacket s;
  s.type = 0x33;
  s.x_raw = i;
  s.y_raw = static_cast<std::uint16_t>(i * 3);
  s.th_raw = static_cast<std::int16_t>(i % 4096);
  s.left_vel = 300;
  s.right_vel = 310;
  s.battery_dv = 128;
  s.sonar_count = 4;  // a typical SIP carries a few changed sonar readings
  for (std::uint8_t k = 0; k < 4; ++k) s.sonar[k] = {k, static_cast<std::uint16_t>(1000 + k)};
  s.tail_fields = 9;
  return s;
}

std::vector<std::uint8_t> sip_stream(std::size_t n, double corruption) {
  std::vector<std::uint8_t> out;
  std::mt19937 rng{1};
  std::uniform_real_distribution<double> u{0, 1};
  for (std::size_t i = 0; i < n; ++i) {
    const auto p = encode_sip(typical_sip(static_cast<std::uint16_t>(i)));
    for (std::size_t b = 0; b < p.size; ++b) {
      out.push_back(u(rng) < corruption ? static_cast<std::uint8_t>(rng()) : p.bytes[b]);
    }
  }
  return out;
}

void parse_stream(benchmark::State& state, double corruption) {
  const auto stream = sip_stream(10000, corruption);
  std::uint64_t packets = 0;
  for (auto _ : state) {
    ArcosParser p;
    p.push(stream, [&](const PacketView& v) { packets += v.type; });
    benchmark::DoNotOptimize(packets);
  }
  state.SetBytesProcessed(static_cast<std::int64_t>(state.iterations()) * static_cast<std::int64_t>(stream.size()));
}

void BM_ParserCleanSipStream(benchmark::State& state) { parse_stream(state, 0.0); }
void BM_ParserSipStream1PercentCorrupt(benchmark::State& state) { parse_stream(state, 0.01); }
void BM_ParserSipStream10PercentCorrupt(benchmark::State& state) { parse_stream(state, 0.10); }

void BM_SipDecode(benchmark::State& state) {
  const auto wire = encode_sip(typical_sip(1234));
  const auto view = verify_packet(wire.span()).value();
  for (auto _ : state) {
    auto s = decode_sip(view);
    benchmark::DoNotOptimize(s);
  }
}

void BM_SipVerifyAndDecode(benchmark::State& state) {
  const auto wire = encode_sip(typical_sip(1234));
  for (auto _ : state) {
    auto s = decode_sip(verify_packet(wire.span()).value());
    benchmark::DoNotOptimize(s);
  }
}

void BM_SipEncode(benchmark::State& state) {
  const SipPacket s = typical_sip(99);
  for (auto _ : state) {
    auto w = encode_sip(s);
    benchmark::DoNotOptimize(w);
  }
}

BENCHMARK(BM_ParserCleanSipStream);
BENCHMARK(BM_ParserSipStream1PercentCorrupt);
BENCHMARK(BM_ParserSipStream10PercentCorrupt);
BENCHMARK(BM_SipDecode);
BENCHMARK(BM_SipVerifyAndDecode);
BENCHMARK(BM_SipEncode);

}  // namespace
}  // namespace teamscan::arcos
