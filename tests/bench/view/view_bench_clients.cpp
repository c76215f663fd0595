// view_bench_clients: N WebSocket clients of the station's browser view, as a process for
// tests/bench/scale/run_scale.sh (VIEW_CLIENTS=N: "three browsers connected"); they stay until the
// station goes away or the time is up, then print what they got.
// usage: view_bench_clients PORT [--clients N] [--seconds S] [--slow-ms MS]
#include <cstdlib>
#include <cstring>
#include <vector>

#include "tests/bench/view/ws_clients.hpp"

int main(int argc, char** argv) {
  using namespace teamscan::bench;
  if (argc < 2) {
    std::fprintf(stderr, "usage: view_bench_clients PORT [--clients N] [--seconds S] [--slow-ms MS]\n");
    return 2;
  }
  const auto port = static_cast<std::uint16_t>(std::atoi(argv[1]));
  int clients = 3, slow_ms = 0;
  double seconds = 60;
  for (int i = 2; i + 1 < argc; i += 2) {
    if (!std::strcmp(argv[i], "--clients")) clients = std::atoi(argv[i + 1]);
    if (!std::strcmp(argv[i], "--seconds")) seconds = std::atof(argv[i + 1]);
    if (!std::strcmp(argv[i], "--slow-ms")) slow_ms = std::atoi(argv[i + 1]);
  }
  std::atomic<bool> stop{false};
  std::vector<ViewClientFigures> figures(static_cast<std::size_t>(clients));
  std::vector<std::thread> threads;
  std::atomic<int> finished{0};
  for (std::size_t c = 0; c < figures.size(); ++c) {
    threads.emplace_back([&, c] {
      run_view_client(port, stop, slow_ms, figures[c]);
      ++finished;
    });
  }
  // Until the time is up or every client saw the station go away (the demo's end).
  const auto end = std::chrono::steady_clock::now() + std::chrono::milliseconds(static_cast<long>(seconds * 1000));
  while (std::chrono::steady_clock::now() < end && finished.load() < clients) {
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  stop = true;
  for (std::thread& t : threads) t.join();
  int connected = 0;
  for (std::size_t c = 0; c < figures.size(); ++c) {
    print_view_client(c + 1, figures[c]);
    connected += figures[c].connected ? 1 : 0;
  }
  return connected == clients ? 0 : 1;
}
