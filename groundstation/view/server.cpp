// ViewServer: HTTP + WebSocket with Boost.Beast on one Asio thread (server.hpp).
#include "groundstation/view/server.hpp"

#include <boost/asio/bind_executor.hpp>
#include <boost/asio/dispatch.hpp>
#include <boost/asio/ip/tcp.hpp>
#include <boost/asio/steady_timer.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/http.hpp>
#include <boost/beast/websocket.hpp>
#include <pthread.h>
#include <sched.h>

#include <atomic>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <thread>
#include <vector>

namespace teamscan::view {

namespace beast = boost::beast;
namespace http = beast::http;
namespace websocket = beast::websocket;
namespace net = boost::asio;
using tcp = net::ip::tcp;
using error_code = boost::system::error_code;

namespace {

class WsSession;

std::string_view sv(beast::string_view s) { return {s.data(), s.size()}; }

}  // namespace

struct ViewServer::Impl {
  // Declared first, destroyed last: handlers still queued own sessions whose sockets need it.
  net::io_context ioc{1};
  tcp::acceptor acceptor{ioc};
  net::steady_timer ticker{ioc};
  std::thread thread;
  std::atomic<int> thread_id{0};         // the server thread's kernel id, once it runs
  std::atomic<int> affinity_error{0};    // of options.cpus
  ServerOptions options;
  ViewFeed& feed;
  ViewHub hub;
  FeedBatch batch;
  std::vector<SharedMessage> outgoing;
  std::map<std::string, std::string, std::less<>> files;
  ViewCounters counters;
  std::shared_ptr<std::size_t> connections = std::make_shared<std::size_t>(0);  // server thread only
  std::vector<std::shared_ptr<WsSession>> clients;
  std::uint16_t port = 0;

  Impl(const ServerOptions& o, ViewFeed& f) : options{o}, feed{f}, hub{o.hub} {}
  void accept();
  void schedule_tick();
  void tick();
  void remove_client(const WsSession* s);
};

namespace {

// Counts a connection for as long as a session (HTTP or WebSocket) holds it.
struct ConnectionSlot {
  std::shared_ptr<std::size_t> count;
  explicit ConnectionSlot(std::shared_ptr<std::size_t> c) : count{std::move(c)} { ++*count; }
  ~ConnectionSlot() { --*count; }
  ConnectionSlot(const ConnectionSlot&) = delete;
  ConnectionSlot& operator=(const ConnectionSlot&) = delete;
};

class WsSession : public std::enable_shared_from_this<WsSession> {
 public:
  WsSession(ViewServer::Impl& srv, beast::tcp_stream&& stream, std::shared_ptr<ConnectionSlot> slot)
      : srv_{srv}, ws_{std::move(stream)}, queue_{srv.options.queue}, slot_{std::move(slot)} {}

  void start(http::request<http::string_body> req) {
    req_ = std::move(req);
    beast::get_lowest_layer(ws_).expires_never();
    ws_.set_option(websocket::stream_base::timeout::suggested(beast::role_type::server));
    ws_.read_message_max(srv_.options.requests.max_ws_message_bytes);
    ws_.async_accept(req_, [self = shared_from_this()](error_code ec) { self->on_accept(ec); });
  }

  void push(const SharedMessage& m) {
    const std::uint64_t skips = queue_.skips();
    queue_.push(m);
    if (queue_.skips() != skips) ++srv_.counters.skips;
  }
  [[nodiscard]] std::size_t queued_bytes() const { return queue_.bytes(); }

  void kick() {
    if (writing_ || closed_) return;
    SharedMessage m;
    if (whole_next_ < whole_.size()) {
      m = whole_[whole_next_++];
    } else {
      whole_.clear();
      whole_next_ = 0;
      switch (queue_.next(m)) {
        case ClientQueue::Next::kNothing:
          return;
        case ClientQueue::Next::kWholeState:
          srv_.hub.whole(whole_);
          if (whole_.empty()) return;
          m = whole_[whole_next_++];
          break;
        case ClientQueue::Next::kMessage:
          break;
      }
    }
    writing_ = true;
    current_ = std::move(m);
    ws_.binary(current_->binary);
    ws_.async_write(net::buffer(current_->bytes),
                    [self = shared_from_this()](error_code ec, std::size_t n) { self->on_write(ec, n); });
  }

  void close() {
    if (closed_) return;
    closed_ = true;
    error_code ignored;
    beast::get_lowest_layer(ws_).socket().shutdown(tcp::socket::shutdown_both, ignored);
    beast::get_lowest_layer(ws_).socket().close(ignored);
  }

 private:
  void on_accept(error_code ec) {
    if (ec) {
      ++srv_.counters.malformed;  // a /ws upgrade that failed its handshake
      return;
    }
    ++srv_.counters.ws_opened;
    ++srv_.counters.ws_open;
    opened_ = true;
    srv_.clients.push_back(shared_from_this());
    read();
    kick();
  }

  void read() {
    ws_.async_read(rbuf_, [self = shared_from_this()](error_code ec, std::size_t) { self->on_read(ec); });
  }

  void on_read(error_code ec) {
    if (ec) {
      if (ec == websocket::error::message_too_big) {
        ++srv_.counters.oversized;  // Beast closes with 1009 (message too big)
      } else if (ec != websocket::error::closed &&
                 ec.category() == websocket::make_error_code(websocket::error::closed).category()) {
        ++srv_.counters.malformed;  // a WebSocket protocol violation: Beast closes with 1002
      }
      finish();
      return;
    }
    // The view is read-only: whatever a client sends is answered with an error and counted.
    ++srv_.counters.ws_rejected;
    rbuf_.consume(rbuf_.size());
    auto m = std::make_shared<Message>();
    m->bytes = encode_error("the view is read-only: client messages are not accepted");
    queue_.push(std::move(m));
    kick();
    read();
  }

  void on_write(error_code ec, std::size_t n) {
    writing_ = false;
    current_.reset();
    if (ec) {
      finish();
      return;
    }
    ++srv_.counters.messages_sent;
    srv_.counters.bytes_sent += n;
    kick();
  }

  void finish() {
    if (opened_) {
      opened_ = false;
      --srv_.counters.ws_open;
      srv_.remove_client(this);
    }
    close();
  }

  ViewServer::Impl& srv_;
  websocket::stream<beast::tcp_stream> ws_;
  http::request<http::string_body> req_;
  beast::flat_buffer rbuf_;
  ClientQueue queue_;
  std::shared_ptr<ConnectionSlot> slot_;
  std::vector<SharedMessage> whole_;
  std::size_t whole_next_ = 0;
  SharedMessage current_;
  bool writing_ = false;
  bool closed_ = false;
  bool opened_ = false;
};

class HttpSession : public std::enable_shared_from_this<HttpSession> {
 public:
  HttpSession(ViewServer::Impl& srv, tcp::socket&& socket)
      : srv_{srv}, stream_{std::move(socket)}, slot_{std::make_shared<ConnectionSlot>(srv.connections)} {}

  void run() {
    if (*srv_.connections > srv_.options.max_connections) {
      srv_.counters.count_error(503);
      respond_error(503, "too many connections", 11, false);
      return;
    }
    read();
  }

 private:
  void read() {
    parser_.emplace();
    parser_->header_limit(static_cast<std::uint32_t>(srv_.options.requests.max_header_bytes));
    parser_->body_limit(srv_.options.requests.max_body_bytes);
    stream_.expires_after(srv_.options.http_timeout);
    http::async_read(stream_, buffer_, *parser_,
                     [self = shared_from_this()](error_code ec, std::size_t) { self->on_read(ec); });
  }

  void on_read(error_code ec) {
    if (ec == http::error::end_of_stream || ec == net::error::eof || ec == beast::error::timeout ||
        ec == net::error::operation_aborted || ec == net::error::connection_reset) {
      shutdown();
      return;
    }
    if (ec) {
      ++srv_.counters.requests;
      int status = 400;
      const char* why = "malformed request";
      if (ec == http::error::header_limit) {
        status = 431;
        why = "request header fields too large";
      } else if (ec == http::error::body_limit) {
        status = 413;
        why = "request body too large (the view is read-only)";
      } else if (ec.category() != http::make_error_code(http::error::bad_method).category()) {
        shutdown();  // a socket error: nobody to answer
        return;
      }
      srv_.counters.count_error(status);
      respond_error(status, why, 11, false);
      return;
    }
    ++srv_.counters.requests;
    http::request<http::string_body>& req = parser_->get();
    const unsigned version = req.version();
    const bool keep_alive = req.keep_alive();
    const RouteDecision d = route_request(
        sv(req.method_string()), sv(req.target()), websocket::is_upgrade(req), req.body().size(), srv_.options.requests,
        [&](std::string_view name) { return srv_.files.find(name) != srv_.files.end(); });
    switch (d.route) {
      case Route::kError:
        srv_.counters.count_error(d.status);
        respond_error(d.status, d.error, version, keep_alive && d.status == 404);
        return;
      case Route::kWebSocket: {
        auto ws = std::make_shared<WsSession>(srv_, std::move(stream_), slot_);
        ws->start(parser_->release());
        return;
      }
      case Route::kState: {
        const std::optional<std::string> s = srv_.hub.state_json(d.seq);
        if (!s) {
          srv_.counters.count_error(404);
          respond_error(404, d.seq ? "no state with that seq (only the newest are kept)" : "no state yet", version,
                        keep_alive);
          return;
        }
        respond(http::status::ok, "application/json", *s, version, keep_alive, req.method() == http::verb::head);
        return;
      }
      case Route::kStats:
        respond(http::status::ok, "application/json", srv_.counters.json(), version, keep_alive,
                req.method() == http::verb::head);
        return;
      case Route::kFile: {
        const auto it = srv_.files.find(d.file);
        respond(http::status::ok, content_type_of(d.file), it->second, version, keep_alive,
                req.method() == http::verb::head);
        return;
      }
    }
  }

  void respond_error(int status, std::string_view why, unsigned version, bool keep_alive) {
    respond(static_cast<http::status>(status), "application/json", encode_error(why), version, keep_alive, false);
  }

  void respond(http::status status, std::string_view type, const std::string& body, unsigned version, bool keep_alive,
               bool head) {
    auto res = std::make_shared<http::response<http::string_body>>(status, version);
    res->set(http::field::server, "teamscan-groundstation view");
    res->set(http::field::content_type, beast::string_view(type.data(), type.size()));
    res->set(http::field::cache_control, "no-store");
    res->keep_alive(keep_alive);
    if (head) {
      res->content_length(body.size());
    } else {
      res->body() = body;
      res->prepare_payload();
    }
    response_ = res;
    http::async_write(stream_, *res, [self = shared_from_this(), keep_alive](error_code ec, std::size_t n) {
      self->srv_.counters.bytes_sent += n;
      self->response_.reset();
      if (ec || !keep_alive) {
        self->shutdown();
        return;
      }
      self->read();
    });
  }

  void shutdown() {
    error_code ignored;
    stream_.socket().shutdown(tcp::socket::shutdown_send, ignored);
    stream_.socket().close(ignored);
  }

  ViewServer::Impl& srv_;
  beast::tcp_stream stream_;
  beast::flat_buffer buffer_;
  std::optional<http::request_parser<http::string_body>> parser_;
  std::shared_ptr<void> response_;
  std::shared_ptr<ConnectionSlot> slot_;
};

}  // namespace

void ViewServer::Impl::accept() {
  acceptor.async_accept([this](error_code ec, tcp::socket socket) {
    if (ec == net::error::operation_aborted) return;
    if (!ec) std::make_shared<HttpSession>(*this, std::move(socket))->run();
    accept();
  });
}

void ViewServer::Impl::schedule_tick() {
  ticker.expires_after(options.tick);
  ticker.async_wait([this](error_code ec) {
    if (ec) return;
    tick();
    schedule_tick();
  });
}

void ViewServer::Impl::tick() {
  feed.drain(batch);
  if (batch.scan_count != 0 || !batch.voxels.empty() || batch.snapshot) {
    outgoing.clear();
    hub.apply(batch, outgoing);
    for (const std::shared_ptr<WsSession>& c : clients) {
      for (const SharedMessage& m : outgoing) c->push(m);
    }
  }
  std::size_t queued = 0;
  for (const std::shared_ptr<WsSession>& c : clients) {
    c->kick();
    queued += c->queued_bytes();
  }
  counters.queued_bytes = queued;
  counters.hub_bytes = hub.memory_bytes();
}

void ViewServer::Impl::remove_client(const WsSession* s) {
  std::erase_if(clients, [s](const std::shared_ptr<WsSession>& c) { return c.get() == s; });
}

ViewServer::ViewServer(std::unique_ptr<Impl> impl) : impl_{std::move(impl)} {}

ViewServer::~ViewServer() {
  impl_->ioc.stop();
  if (impl_->thread.joinable()) impl_->thread.join();
  for (const std::shared_ptr<WsSession>& c : impl_->clients) c->close();
  impl_->clients.clear();
  error_code ignored;
  impl_->acceptor.close(ignored);
}

Result<std::unique_ptr<ViewServer>> ViewServer::start(const ServerOptions& options, ViewFeed& feed) {
  auto impl = std::make_unique<Impl>(options, feed);
  error_code ec;
  const net::ip::address address = net::ip::make_address(options.listen.host, ec);
  if (ec) return Error{"view: [view] listen: not an IP address"};
  const tcp::endpoint endpoint{address, options.listen.port};
  impl->acceptor.open(endpoint.protocol(), ec);
  if (!ec) impl->acceptor.set_option(net::socket_base::reuse_address(true), ec);
  if (!ec) impl->acceptor.bind(endpoint, ec);
  if (!ec) impl->acceptor.listen(net::socket_base::max_listen_connections, ec);
  if (ec) return Error{"view: cannot listen on [view] listen", ec.value()};
  impl->port = impl->acceptor.local_endpoint().port();

  // The page's files, read once: the server never touches the disk afterwards.
  namespace fs = std::filesystem;
  std::error_code fec;
  if (!options.web_root.empty() && fs::is_directory(options.web_root, fec)) {
    for (const fs::directory_entry& e : fs::directory_iterator(options.web_root, fec)) {
      const std::string name = e.path().filename().string();
      if (!e.is_regular_file(fec) || !detail::valid_file_name(name) || e.file_size(fec) > (64u << 20)) continue;
      std::ifstream in(e.path(), std::ios::binary);
      std::ostringstream ss;
      ss << in.rdbuf();
      impl->files.emplace(name, ss.str());
    }
  }

  Impl& s = *impl;
  s.accept();
  s.schedule_tick();
  s.thread = std::thread([&s] {
    pthread_setname_np(pthread_self(), "teamscan-view");  // named for top -H and the benchmarks
    // SCHED_BATCH (sched(7)): the view's encoding and sending never preempt the station's receive loop
    // when it wakes; they take their fair share at the scheduler's ticks (a station pinned to one core
    // otherwise had the view cut into every burst of scans: docs/view.md "Cost").
    sched_param param{};
    (void)pthread_setschedparam(pthread_self(), SCHED_BATCH, &param);
    s.affinity_error.store(set_current_thread_cpus(s.options.cpus));
    s.thread_id.store(current_thread_id());
    s.thread_id.notify_all();
    s.ioc.run();
  });
  s.thread_id.wait(0);  // placed (class, CPUs) before start() returns: scheduling() reports it
  return std::unique_ptr<ViewServer>(new ViewServer(std::move(impl)));
}

std::uint16_t ViewServer::port() const { return impl_->port; }
std::string ViewServer::url() const {
  return "http://" + impl_->options.listen.host + ":" + std::to_string(impl_->port) + "/";
}
std::size_t ViewServer::files() const { return impl_->files.size(); }
const ViewCounters& ViewServer::counters() const { return impl_->counters; }
ThreadScheduling ViewServer::scheduling() const {
  ThreadScheduling out = thread_scheduling(impl_->thread.native_handle(), impl_->thread_id.load());
  out.affinity_error = impl_->affinity_error.load();
  return out;
}

}  // namespace teamscan::view
