// WebSocket clients of the station's browser view for the benchmarks: each connects to
// ws://127.0.0.1:PORT/ws (retrying until the server listens), reads and decodes everything until `stop`
// or the server goes away, and counts what it got. `slow_ms`: sleep after each message (a slow browser).
#pragma once

#include <atomic>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <thread>

#include <boost/asio/ip/tcp.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/websocket.hpp>

#include "groundstation/view/protocol.hpp"

namespace teamscan::bench {

struct ViewClientFigures {
  std::uint64_t messages = 0, bytes = 0, whole_maps = 0, changed = 0, states = 0, bad = 0;
  std::size_t voxels_last_whole = 0;
  bool connected = false;
};

inline void run_view_client(std::uint16_t port, const std::atomic<bool>& stop, int slow_ms, ViewClientFigures& f) {
  namespace beast = boost::beast;
  namespace net = boost::asio;
  using tcp = net::ip::tcp;
  while (!stop.load()) {
    try {
      net::io_context ioc;
      beast::websocket::stream<tcp::socket> ws{ioc};
      ws.next_layer().connect(tcp::endpoint(net::ip::make_address("127.0.0.1"), port));
      ws.handshake("127.0.0.1", "/ws");
      f.connected = true;
      beast::flat_buffer buffer;
      while (!stop.load()) {
        buffer.clear();
        ws.read(buffer);  // the view sends a state every period, so this returns
        ++f.messages;
        f.bytes += buffer.size();
        if (ws.got_binary()) {
          auto m = view::decode_voxels(beast::buffers_to_string(buffer.data()));
          if (!m.ok()) {
            ++f.bad;
          } else if (m.value().kind == view::VoxelKind::kWholeMap) {
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
      ws.close(beast::websocket::close_code::normal, ec);
      return;
    } catch (const std::exception&) {
      if (f.connected) return;  // the server went away
      std::this_thread::sleep_for(std::chrono::milliseconds(200));
    }
  }
}

inline void print_view_client(std::size_t index, const ViewClientFigures& f) {
  std::printf(
      "  view client %zu: %s, %llu messages, %.1f MB (%llu whole maps, last %zu voxels; %llu changes; %llu states; "
      "%llu undecodable)\n",
      index, f.connected ? "connected" : "NEVER CONNECTED", static_cast<unsigned long long>(f.messages),
      static_cast<double>(f.bytes) * 1e-6, static_cast<unsigned long long>(f.whole_maps), f.voxels_last_whole,
      static_cast<unsigned long long>(f.changed), static_cast<unsigned long long>(f.states),
      static_cast<unsigned long long>(f.bad));
}

}  // namespace teamscan::bench
