// ViewServer: the browser view's HTTP and WebSocket server (Boost.Beast on one Asio thread of its own).
// It serves the page's files from the web root, /api/state and /api/stats (JSON), and /ws, where every
// client gets the whole map and state first, then the changes. Every tick (100 ms) it drains the
// station's ViewFeed into the ViewHub and queues the resulting messages per client (ClientQueue: a slow
// client skips to the latest state). A WebSocket upgrade offering `foxglove.websocket.v1` (on /, /ws or
// /foxglove) is a Foxglove client instead: the channels of foxglove_channels.hpp, read-only. The
// station's loop only ever touches the ViewFeed.
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "common/result.hpp"
#include "common/thread_placement.hpp"
#include "common/time.hpp"
#include "groundstation/view/client_queue.hpp"
#include "groundstation/view/feed.hpp"
#include "groundstation/view/foxglove_channels.hpp"
#include "groundstation/view/hub.hpp"
#include "groundstation/view/requests.hpp"

namespace teamscan::view {

struct ServerOptions {
  ListenAddress listen{"127.0.0.1", 8080};
  std::string web_root;  // the built page (index.html, app.js, ...); empty: API and /ws only
  RequestLimits requests;
  QueueLimits queue;
  HubOptions hub;
  foxglove::ChannelOptions foxglove;
  Duration tick = std::chrono::milliseconds(100);
  Duration http_timeout = std::chrono::seconds(10);  // a request not complete by then: connection closed
  std::size_t max_connections = 32;                  // beyond: 503, counted as refused
  // The server thread's CPUs (none: the process's). A station whose receive loop has a core of its own
  // puts the view on the others ([view] cpus; docs/view.md "Cost").
  std::vector<int> cpus;
};

class ViewServer {
 public:
  // Binds, loads the web root's files and starts the server thread. Fails if it cannot listen.
  [[nodiscard]] static Result<std::unique_ptr<ViewServer>> start(const ServerOptions& options, ViewFeed& feed);
  ~ViewServer();  // stops the thread, closes every connection
  ViewServer(const ViewServer&) = delete;
  ViewServer& operator=(const ViewServer&) = delete;

  // Drains the feed now (the Foxglove map channel's map sent whatever its interval) and waits, at most
  // `timeout`, until every page's and Foxglove client's queue is written to its socket: the station's
  // last offers (its final map and state at shutdown) reach the open clients before the server stops.
  // False on the timeout.
  [[nodiscard]] bool flush(Duration timeout);

  [[nodiscard]] std::uint16_t port() const;
  [[nodiscard]] std::string url() const;  // http://HOST:PORT/
  [[nodiscard]] std::size_t files() const;
  [[nodiscard]] const ViewCounters& counters() const;
  // The server thread's class and CPUs as the kernel reports them (affinity_error: ServerOptions::cpus refused).
  [[nodiscard]] ThreadScheduling scheduling() const;

  struct Impl;

 private:
  explicit ViewServer(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

}  // namespace teamscan::view
