// PCD throughput: writing and reading the data set's labelled points (binary), the generic reader on
// ascii/binary, and binary_compressed (LZF) on the real room_scan1.pcd. Figures, not pass/fail.
#include <benchmark/benchmark.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <string>
#include <vector>

#include "common/dataset/pcd.hpp"
#include "tests/support/real_data.hpp"

namespace teamscan {
namespace {

std::vector<LabelledPoint> make_points(std::size_t n) {
  std::vector<LabelledPoint> pts(n);
  for (std::size_t i = 0; i < n; ++i) {
    auto& p = pts[i];
    p.x = static_cast<float>(std::sin(static_cast<double>(i)) * 5);
    p.y = static_cast<float>(std::cos(static_cast<double>(i) * 0.7) * 4);
    p.z = static_cast<float>(i % 300) * 0.01f;
    p.robot = static_cast<std::uint8_t>(1 + i % 2);
    p.scan = static_cast<std::uint32_t>(i / 181);
    p.beam = static_cast<std::uint16_t>(i % 181);
    p.label = static_cast<PointClass>(i % 6);
    p.tx = p.x; p.ty = p.y; p.tz = p.z;
  }
  return pts;
}

void BM_EncodeLabelledPcd(benchmark::State& state) {
  const auto pts = make_points(static_cast<std::size_t>(state.range(0)));
  for (auto _ : state) benchmark::DoNotOptimize(encode_labelled_pcd(pts));
  state.SetItemsProcessed(state.iterations() * state.range(0));
  state.SetBytesProcessed(state.iterations() * state.range(0) * 35);
}
BENCHMARK(BM_EncodeLabelledPcd)->Arg(100000)->Arg(1000000)->Unit(benchmark::kMillisecond);

void BM_ParseLabelledPcd(benchmark::State& state) {
  const auto bytes = encode_labelled_pcd(make_points(static_cast<std::size_t>(state.range(0))));
  for (auto _ : state) benchmark::DoNotOptimize(parse_labelled_pcd(bytes));
  state.SetItemsProcessed(state.iterations() * state.range(0));
  state.SetBytesProcessed(state.iterations() * static_cast<std::int64_t>(bytes.size()));
}
BENCHMARK(BM_ParseLabelledPcd)->Arg(100000)->Arg(1000000)->Unit(benchmark::kMillisecond);

void BM_ParseGenericBinary(benchmark::State& state) {
  const auto bytes = encode_labelled_pcd(make_points(static_cast<std::size_t>(state.range(0))));
  for (auto _ : state) benchmark::DoNotOptimize(parse_pcd(bytes));
  state.SetItemsProcessed(state.iterations() * state.range(0));
}
BENCHMARK(BM_ParseGenericBinary)->Arg(100000)->Unit(benchmark::kMillisecond);

void BM_ParseAscii(benchmark::State& state) {
  std::string text = "FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nWIDTH " + std::to_string(state.range(0)) + "\nHEIGHT 1\nDATA ascii\n";
  for (std::int64_t i = 0; i < state.range(0); ++i)
    text += std::to_string(std::sin(static_cast<double>(i))) + " " + std::to_string(i * 0.001) + " 1.2345678\n";
  const std::vector<std::uint8_t> bytes(text.begin(), text.end());
  for (auto _ : state) benchmark::DoNotOptimize(parse_pcd(bytes));
  state.SetItemsProcessed(state.iterations() * state.range(0));
}
BENCHMARK(BM_ParseAscii)->Arg(100000)->Unit(benchmark::kMillisecond);

void BM_ReadRoomScan1BinaryCompressed(benchmark::State& state) {
  const std::string path = teamscan::test::real_data_path("room_scan1.pcd");
  const auto bytes = read_file_bytes(path);
  if (!bytes) {
    state.SkipWithError(("cannot read " + path).c_str());
    return;
  }
  std::size_t n = 0;
  for (auto _ : state) {
    const auto cloud = parse_pcd(*bytes);
    n = cloud ? cloud->size() : 0;
    benchmark::DoNotOptimize(n);
  }
  state.SetItemsProcessed(state.iterations() * static_cast<std::int64_t>(n));
}
BENCHMARK(BM_ReadRoomScan1BinaryCompressed)->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace teamscan
