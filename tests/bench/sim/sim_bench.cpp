// Simulation speed: the whole Lap2 run (figure: × real time) and single ray casts.
#include <benchmark/benchmark.h>

#include <cstdlib>
#include <string>

#include "sim/simulator.hpp"

namespace teamscan::sim {
namespace {

Scenario load(const char* name) {
  const char* src = std::getenv("TEAMSCAN_SOURCE_DIR");
  const std::string dir = src ? std::string{src} + "/sim/scenarios/" : std::string{TEAMSCAN_BENCH_SCENARIO_DIR} + "/";
  const ScenarioLoad l = load_scenario_file(dir + name + ".toml");
  if (!l.scenario) std::abort();
  return *l.scenario;
}

// Arg 1: device streams (emulators, clients, VirtualLinks, captures); 0: the direct path.
void BM_SimulateLap2(benchmark::State& state) {
  const Scenario sc = load("lap2");
  SimOptions options;
  options.device_streams = state.range(0) != 0;
  double simulated_s = 0;
  for (auto _ : state) {
    const SimOutput out = simulate(sc, options);
    simulated_s += out.dataset.duration_s;
    benchmark::DoNotOptimize(out.dataset.points.data());
  }
  // Simulated seconds per second of this thread's CPU time = × real time on one core.
  state.counters["x_real_time"] = benchmark::Counter(simulated_s, benchmark::Counter::kIsRate);
}
BENCHMARK(BM_SimulateLap2)->Arg(1)->Arg(0)->Unit(benchmark::kMillisecond)->Iterations(3);

void BM_CastBeam(benchmark::State& state) {
  const Scenario sc = load("team3");
  const TeamWorld team{sc};
  std::vector<PlacedRobot> placed;
  team.place(20.0, placed);
  double angle = -kPi / 2;
  for (auto _ : state) {
    const Ray ray = team.beam_ray(0, placed[0].map_from_robot, angle);
    benchmark::DoNotOptimize(team.world().cast(ray, placed, placed[0].id));
    angle = angle > kPi / 2 ? -kPi / 2 : angle + 0.01;
  }
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_CastBeam);

}  // namespace
}  // namespace teamscan::sim
