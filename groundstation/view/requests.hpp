// Request handling of the view, pure (the server only moves bytes): what an HTTP request asks for, or
// which error it gets; the listen address; the view's counters. Everything is read-only: GET and HEAD
// of the page's files, /api/state, /api/stats and the /ws WebSocket; anything else is an error, counted.
#pragma once

#include <atomic>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>

#include "common/result.hpp"

namespace teamscan::view {

struct RequestLimits {
  std::size_t max_header_bytes = 8192;      // request line + headers; beyond: 431, counted as oversized
  std::size_t max_body_bytes = 0;           // a read-only view takes no body; beyond: 413, oversized
  std::size_t max_target_bytes = 1024;      // beyond: 414, oversized
  std::size_t max_ws_message_bytes = 4096;  // a client's WebSocket message beyond: closed (1009), oversized
};

enum class Route { kFile, kWebSocket, kState, kStats, kError };

struct RouteDecision {
  Route route = Route::kError;
  int status = 200;                  // HTTP status of the answer
  std::string file;                  // kFile: the file name in the web root ("index.html" for "/")
  std::optional<std::uint64_t> seq;  // kState: ?seq=N
  std::string error;                 // kError: the reason, sent as the body
};

// Decides what to do with a request that parsed. `websocket_upgrade`: the request asks to upgrade.
// `has_file(name)` tells whether the web root serves `name`.
template <class HasFile>
RouteDecision route_request(std::string_view method, std::string_view target, bool websocket_upgrade,
                            std::uint64_t content_length, const RequestLimits& limits, HasFile&& has_file);

// The view's counters, shared between the server thread and the station's loop (which logs them).
struct ViewCounters {
  std::atomic<std::uint64_t> requests{0};
  std::atomic<std::uint64_t> malformed{0};   // unparseable HTTP: 400
  std::atomic<std::uint64_t> oversized{0};   // headers, target, body or a WebSocket message too big
  std::atomic<std::uint64_t> not_found{0};   // 404
  std::atomic<std::uint64_t> bad_method{0};  // not GET/HEAD (read-only): 405
  std::atomic<std::uint64_t> bad_query{0};   // 400 for a known path with a bad query
  std::atomic<std::uint64_t> refused{0};     // over max connections: 503
  std::atomic<std::uint64_t> ws_opened{0};
  std::atomic<std::uint64_t> ws_open{0};
  std::atomic<std::uint64_t> ws_rejected{0};  // client messages (the view takes no command)
  std::atomic<std::uint64_t> skips{0};        // slow clients skipped to the whole state
  std::atomic<std::uint64_t> messages_sent{0};
  std::atomic<std::uint64_t> bytes_sent{0};
  std::atomic<std::uint64_t> hub_bytes{0};     // the hub's memory (map copy, tracks, states)
  std::atomic<std::uint64_t> queued_bytes{0};  // bytes in every client's queue
  std::atomic<std::uint64_t> foxglove_opened{0};     // Foxglove WebSocket clients (foxglove.websocket.v1)
  std::atomic<std::uint64_t> foxglove_open{0};
  std::atomic<std::uint64_t> foxglove_refused{0};    // publish, service, parameter, graph, asset requests
  std::atomic<std::uint64_t> foxglove_malformed{0};  // not a Foxglove client message
  std::atomic<std::uint64_t> foxglove_skips{0};      // slow Foxglove clients skipped to the newest messages
  // Counts the error answer `status` under its counter.
  void count_error(int status);
  [[nodiscard]] std::string json() const;
  [[nodiscard]] std::string line() const;
};

struct ListenAddress {
  std::string host;  // IPv4 dotted quad
  std::uint16_t port = 0;
};
// "127.0.0.1:8080" (port 0: any free port). "localhost" means 127.0.0.1. Errors say what is wrong.
[[nodiscard]] bool parse_listen(std::string_view text, ListenAddress& out, std::string& error);

// A Foxglove client's WebSocket upgrade: GET of "/", "/ws" or "/foxglove" (any query) whose
// Sec-WebSocket-Protocol header (comma-separated tokens) offers `protocol`.
[[nodiscard]] bool is_foxglove_upgrade(std::string_view method, std::string_view target, bool websocket_upgrade,
                                       std::string_view protocols_header, std::string_view protocol);

// Content type of a web root file by extension.
[[nodiscard]] std::string_view content_type_of(std::string_view file);

// ---- implementation of the template

namespace detail {
bool valid_file_name(std::string_view name);
bool parse_seq_query(std::string_view query, std::optional<std::uint64_t>& seq);
}  // namespace detail

template <class HasFile>
RouteDecision route_request(std::string_view method, std::string_view target, bool websocket_upgrade,
                            std::uint64_t content_length, const RequestLimits& limits, HasFile&& has_file) {
  RouteDecision d;
  auto error = [&](int status, std::string why) {
    d.route = Route::kError;
    d.status = status;
    d.error = std::move(why);
    return d;
  };
  if (target.size() > limits.max_target_bytes) return error(414, "request target too long");
  if (content_length > limits.max_body_bytes) return error(413, "request body too large (the view is read-only)");
  if (method != "GET" && method != "HEAD") return error(405, "method not allowed (the view is read-only)");
  if (target.empty() || target.front() != '/') return error(400, "request target must start with /");
  const std::size_t q = target.find('?');
  const std::string_view path = target.substr(0, q);
  const std::string_view query = q == std::string_view::npos ? std::string_view{} : target.substr(q + 1);
  if (path == "/ws") {
    if (!websocket_upgrade) return error(400, "/ws is a WebSocket: send an Upgrade request");
    d.route = Route::kWebSocket;
    return d;
  }
  if (path == "/api/state") {
    if (!detail::parse_seq_query(query, d.seq)) return error(400, "/api/state takes ?seq=N only");
    d.route = Route::kState;
    return d;
  }
  if (path == "/api/stats") {
    if (!query.empty()) return error(400, "/api/stats takes no query");
    d.route = Route::kStats;
    return d;
  }
  const std::string_view name = path == "/" ? std::string_view{"index.html"} : path.substr(1);
  if (!detail::valid_file_name(name) || !has_file(name)) return error(404, "not found");
  d.route = Route::kFile;
  d.file = std::string(name);
  return d;
}

}  // namespace teamscan::view
