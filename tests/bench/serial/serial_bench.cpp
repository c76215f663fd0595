// Figures for drivers/serial (printed, never pass/fail): how fast VirtualLink simulates an LMS-200 bring-up
// and 500 kBd stream, and the cost of the rate-mismatch garbler per byte.
#include <benchmark/benchmark.h>

#include <vector>

#include "drivers/lms200/client.hpp"
#include "drivers/lms200/emulator.hpp"
#include "drivers/serial/line_model.hpp"
#include "drivers/serial/virtual_link.hpp"

namespace teamscan::serial {
namespace {

// Simulated seconds of client + emulator per iteration; counters give simulated s per wall s.
void BM_VirtualLinkLmsStream(benchmark::State& state) {
  const auto simulated = std::chrono::seconds(state.range(0));
  std::uint64_t scans = 0, bytes = 0;
  for (auto _ : state) {
    lms200::LmsEmulatorOptions eo;
    eo.pace_output = false;
    lms200::LmsEmulator device{eo};
    lms200::LmsClient host{};
    device.power_up(Time{});
    host.start(Time{});
    VirtualLink link{host, device, VirtualLinkOptions{.device = DeviceKind::lms200, .record = state.range(1) != 0}};
    link.run_for(simulated);
    scans += host.statistics().scans;
    bytes += link.stats().bytes_to_host;
    benchmark::DoNotOptimize(link.capture().records.size());
  }
  state.counters["simulated_s_per_s"] =
      benchmark::Counter(static_cast<double>(state.iterations() * static_cast<std::uint64_t>(state.range(0))),
                         benchmark::Counter::kIsRate);
  state.counters["scans"] = static_cast<double>(scans) / static_cast<double>(state.iterations());
  state.SetBytesProcessed(static_cast<std::int64_t>(bytes));
}
BENCHMARK(BM_VirtualLinkLmsStream)->Args({5, 0})->Args({5, 1})->Unit(benchmark::kMillisecond);

void BM_Garbler(benchmark::State& state) {
  std::vector<std::uint8_t> bytes(4096, 0x5A);
  BaudMismatchGarbler g;
  for (auto _ : state) {
    g.garble(bytes);
    benchmark::DoNotOptimize(bytes.data());
  }
  state.SetBytesProcessed(static_cast<std::int64_t>(state.iterations() * bytes.size()));
}
BENCHMARK(BM_Garbler);

}  // namespace
}  // namespace teamscan::serial
