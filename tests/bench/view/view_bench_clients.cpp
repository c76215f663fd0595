// view_bench_clients: N WebSocket clients of the station's browser view for the benchmarks (issue 13:
// "three browsers connected"): each connects to ws://127.0.0.1:PORT/ws (retrying until the station
// listens), reads and decodes everything it is sent for the given time, and prints what it got. With
// --slow-ms a client sleeps after each message (a slow browser: the station must skip it, not queue).
// usage: view_bench_clients PORT [--clients N] [--seconds S] [--slow-ms MS]
#include <atomic>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <thread>
#include <vector>

#include <boost/asio/ip/tcp.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/websocket.hpp>

#include "groundstation/view/protocol.hpp"

namespace {

namespace beast = boost::beast;
namespace websocket = beast::websocket;
namespace net = boost::asio;
using tcp = net::ip::tcp;
using Clock = std::chrono::steady_clock;

struct ClientFigures {
  std::uint64_t messages = 0, bytes = 0, whole_maps = 0, changed = 0, states = 0, bad = 0;
  std::size_t voxels_last_whole = 0;
  bool connected = false;
};

void run_client(std::uint16_t port, Clock::time_point end, int slow_ms, ClientFigures& f) {
  while (Clock::now() < end) {
    try {
      net::io_context ioc;
      websocket::stream<tcp::socket> ws{ioc};
      ws.next_layer().connect(tcp::endpoint(net::ip::make_address("127.0.0.1"), port));
      ws.handshake("127.0.0.1", "/ws");
      f.connected = true;
      beast::flat_buffer buffer;
      while (Clock::now() < end) {
        buffer.clear();
        ws.read(buffer);  // the view sends a state every 100 ms
        ++f.messages;
        f.bytes += buffer.size();
        if (ws.got_binary()) {
          auto m = teamscan::view::decode_voxels(beast::buffers_to_string(buffer.data()));
          if (!m.ok()) {
            ++f.bad;
          } else if (m.value().kind == teamscan::view::VoxelKind::kWholeMap) {
            ++f.whole_maps;
            f.voxels_last_whole = m.value().voxels.size();
          } else {
            ++f.changed;
          }
        } else {
          ++f.states;
        }
        if (slow_ms > 0) std::this_thread::sleep_for(std::chrono::milliseconds(slow_ms));
      }
      beast::error_code ec;
      ws.close(websocket::close_code::normal, ec);
      return;
    } catch (const std::exception&) {
      if (f.connected) return;  // the station went away
      std::this_thread::sleep_for(std::chrono::milliseconds(200));
    }
  }
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) {
    std::fprintf(stderr, "usage: view_bench_clients PORT [--clients N] [--seconds S] [--slow-ms MS]\n");
    return 2;
  }
  const auto port = static_cast<std::uint16_t>(std::atoi(argv[1]));
  int clients = 3, slow_ms = 0;
  double seconds = 60;
  for (int i = 2; i + 1 < argc; i += 2) {
    if (!std::strcmp(argv[i], "--clients")) clients = std::atoi(argv[i + 1]);
    else if (!std::strcmp(argv[i], "--seconds")) seconds = std::atof(argv[i + 1]);
    else if (!std::strcmp(argv[i], "--slow-ms")) slow_ms = std::atoi(argv[i + 1]);
  }
  const Clock::time_point end = Clock::now() + std::chrono::milliseconds(static_cast<long>(seconds * 1000));
  std::vector<ClientFigures> figures(static_cast<std::size_t>(clients));
  std::vector<std::thread> threads;
  for (int c = 0; c < clients; ++c) {
    threads.emplace_back(run_client, port, end, slow_ms, std::ref(figures[static_cast<std::size_t>(c)]));
  }
  for (std::thread& t : threads) t.join();
  int connected = 0;
  for (std::size_t c = 0; c < figures.size(); ++c) {
    const ClientFigures& f = figures[c];
    connected += f.connected ? 1 : 0;
    std::printf("view client %zu: %s, %llu messages, %.1f MB (%llu whole maps, last %zu voxels; %llu changes; %llu states; %llu undecodable)\n",
                c + 1, f.connected ? "connected" : "NEVER CONNECTED", static_cast<unsigned long long>(f.messages),
                static_cast<double>(f.bytes) * 1e-6, static_cast<unsigned long long>(f.whole_maps), f.voxels_last_whole,
                static_cast<unsigned long long>(f.changed), static_cast<unsigned long long>(f.states),
                static_cast<unsigned long long>(f.bad));
  }
  return connected == clients ? 0 : 1;
}
