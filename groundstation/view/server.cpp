// ViewServer: HTTP + WebSocket with Boost.Beast on one Asio thread (server.hpp).
#include "groundstation/view/server.hpp"

#include <boost/asio/bind_executor.hpp>
#include <boost/asio/dispatch.hpp>
#include <boost/asio/ip/tcp.hpp>
#include <boost/asio/post.hpp>
#include <boost/asio/steady_timer.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/http.hpp>
#include <boost/beast/websocket.hpp>
#include <pthread.h>
#include <sched.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <future>
#include <map>
#include <sstream>
#include <thread>
#include <vector>

#include "common/clock.hpp"
#include "groundstation/view/foxglove_channels.hpp"

namespace teamscan::view {

namespace beast = boost::beast;
namespace http = beast::http;
namespace websocket = beast::websocket;
namespace net = boost::asio;
using tcp = net::ip::tcp;
using error_code = boost::system::error_code;

namespace {

class WsSession;
class FoxgloveSession;

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
  foxglove::FoxgloveChannels fox;
  std::vector<foxglove::ChannelMessage> fox_out;
  std::vector<foxglove::Channel> fox_added;
  std::vector<std::shared_ptr<FoxgloveSession>> fox_clients;
  std::string session_id = std::to_string(now_realtime().ns());
  std::uint16_t port = 0;

  Impl(const ServerOptions& o, ViewFeed& f) : options{o}, feed{f}, hub{o.hub}, fox{o.foxglove} {}
  void accept();
  void schedule_tick();
  // `final_map`: the station's last map, which the Foxglove map channel sends whatever its interval.
  void tick(bool final_map = false);
  [[nodiscard]] bool clients_sent_all() const;
  void remove_client(const WsSession* s);
  void remove_fox_client(const FoxgloveSession* s);
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

// What both kinds of WebSocket client share: the stream, the client's bounded queue, and the write loop
// that sends the `whole_` messages first (the whole state: after connecting or a skip), then the queue.
// Derived supplies whole(out) (the whole state), its own opened/closed counters (on_opened, on_finished)
// and on_message (what the client sent).
template <class Derived>
class QueuedWebSocket : public std::enable_shared_from_this<Derived> {
 public:
  QueuedWebSocket(ViewServer::Impl& srv, beast::tcp_stream&& stream, std::shared_ptr<ConnectionSlot> slot)
      : srv_{srv}, ws_{std::move(stream)}, queue_{srv.options.queue}, slot_{std::move(slot)} {}

  void start(http::request<http::string_body> req) {
    req_ = std::move(req);
    beast::get_lowest_layer(ws_).expires_never();
    ws_.set_option(websocket::stream_base::timeout::suggested(beast::role_type::server));
    ws_.read_message_max(srv_.options.requests.max_ws_message_bytes);
    ws_.async_accept(req_, [self = self_ptr()](error_code ec) { self->on_accept(ec); });
  }

  [[nodiscard]] std::size_t queued_bytes() const { return queue_.bytes(); }
  // Everything queued for this client written to its socket (or the client gone).
  [[nodiscard]] bool sent_all() const {
    return closed_ || !opened_ ||
           (!writing_ && whole_next_ >= whole_.size() && queue_.size() == 0 && !queue_.whole_pending());
  }

  void kick() {
    if (writing_ || closed_ || !opened_) return;
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
          derived().whole(whole_);
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
                    [self = self_ptr()](error_code ec, std::size_t n) { self->on_write(ec, n); });
  }

  void close() {
    if (closed_) return;
    closed_ = true;
    error_code ignored;
    beast::get_lowest_layer(ws_).socket().shutdown(tcp::socket::shutdown_both, ignored);
    beast::get_lowest_layer(ws_).socket().close(ignored);
  }

 protected:
  // Queues `m`; true if the queue had to skip (dropped, the whole state next).
  bool push(SharedMessage m) {
    const std::uint64_t skips = queue_.skips();
    queue_.push(std::move(m));
    return queue_.skips() != skips;
  }

  ViewServer::Impl& srv_;
  websocket::stream<beast::tcp_stream> ws_;
  std::vector<SharedMessage> whole_;  // sent before the queue

 private:
  Derived& derived() { return static_cast<Derived&>(*this); }
  std::shared_ptr<Derived> self_ptr() { return this->shared_from_this(); }

  void on_accept(error_code ec) {
    if (ec) {
      ++srv_.counters.malformed;  // an upgrade that failed its handshake
      return;
    }
    opened_ = true;
    derived().on_opened();
    read();
    kick();
  }

  void read() {
    ws_.async_read(rbuf_, [self = self_ptr()](error_code ec, std::size_t) { self->on_read(ec); });
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
    const auto data = rbuf_.cdata();
    derived().on_message(std::string_view(static_cast<const char*>(data.data()), data.size()), ws_.got_text());
    rbuf_.consume(rbuf_.size());
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
      derived().on_finished();
    }
    close();
  }

  http::request<http::string_body> req_;
  beast::flat_buffer rbuf_;
  ClientQueue queue_;
  std::shared_ptr<ConnectionSlot> slot_;
  std::size_t whole_next_ = 0;
  SharedMessage current_;
  bool writing_ = false;
  bool closed_ = false;
  bool opened_ = false;
};

SharedMessage text_message(std::string bytes) {
  auto m = std::make_shared<Message>();
  m->bytes = std::move(bytes);
  return m;
}

// A browser view client (/ws): the whole map and state first, then the changes.
class WsSession : public QueuedWebSocket<WsSession> {
 public:
  using QueuedWebSocket::QueuedWebSocket;

  void push(const SharedMessage& m) {
    if (QueuedWebSocket::push(m)) ++srv_.counters.skips;
  }

  void whole(std::vector<SharedMessage>& out) { srv_.hub.whole(out); }
  void on_opened() {
    ++srv_.counters.ws_opened;
    ++srv_.counters.ws_open;
    srv_.clients.push_back(shared_from_this());
  }
  void on_finished() {
    --srv_.counters.ws_open;
    srv_.remove_client(this);
  }
  // The view is read-only: whatever a client sends is answered with an error and counted.
  void on_message(std::string_view, bool) {
    ++srv_.counters.ws_rejected;
    (void)QueuedWebSocket::push(text_message(encode_error("the view is read-only: client messages are not accepted")));
  }
};

// A Foxglove client (foxglove.websocket.v1, foxglove_protocol.hpp): serverInfo and the channels first;
// then Message Data of the channels it subscribed to, through its own bounded ClientQueue. A client that
// falls behind skips to the channels' newest messages (advertised again first). Read-only: requests to
// publish, call services, get or set parameters are refused with a status message and counted.
class FoxgloveSession : public QueuedWebSocket<FoxgloveSession> {
 public:
  FoxgloveSession(ViewServer::Impl& srv, beast::tcp_stream&& stream, std::shared_ptr<ConnectionSlot> slot)
      : QueuedWebSocket{srv, std::move(stream), std::move(slot)} {
    ws_.set_option(websocket::stream_base::decorator([](websocket::response_type& res) {
      res.set(http::field::sec_websocket_protocol, foxglove::kSubprotocol);
      res.set(http::field::server, "teamscan-groundstation view");
    }));
  }

  // A channel's new message: queued if subscribed.
  void deliver(const foxglove::ChannelMessage& m) {
    if (m.channel_id >= subscription_of_.size() || subscription_of_[m.channel_id] == kNone) return;
    push(data_message(subscription_of_[m.channel_id], m));
  }
  void advertise(const std::vector<foxglove::Channel>& added) {
    push(text_message(foxglove::encode_advertise(added)));
  }

  // First and after a skip: every channel, then each subscribed channel's newest message.
  void whole(std::vector<SharedMessage>& out) {
    out.push_back(text_message(foxglove::encode_advertise(srv_.fox.channels())));
    for (std::uint32_t channel = 0; channel < subscription_of_.size(); ++channel) {
      if (subscription_of_[channel] == kNone) continue;
      if (const foxglove::ChannelMessage* latest = srv_.fox.latest(channel))
        out.push_back(data_message(subscription_of_[channel], *latest));
    }
  }
  void on_opened() {
    ++srv_.counters.foxglove_opened;
    ++srv_.counters.foxglove_open;
    srv_.fox_clients.push_back(shared_from_this());
    whole_.push_back(text_message(foxglove::encode_server_info("teamscan-groundstation", srv_.session_id)));
  }
  void on_finished() {
    --srv_.counters.foxglove_open;
    srv_.remove_fox_client(this);
  }

  void on_message(std::string_view bytes, bool text) {
    const foxglove::ClientRequest r = text ? foxglove::decode_client_text(bytes) : foxglove::decode_client_binary(bytes);
    switch (r.kind) {
      case foxglove::ClientRequest::Kind::kSubscribe:
        subscribe(r);
        break;
      case foxglove::ClientRequest::Kind::kUnsubscribe:
        for (std::uint32_t id : r.subscription_ids) {
          const auto it = channel_of_.find(id);
          if (it == channel_of_.end()) continue;
          subscription_of_[it->second] = kNone;
          channel_of_.erase(it);
        }
        break;
      case foxglove::ClientRequest::Kind::kRefused:
        ++srv_.counters.foxglove_refused;
        status(foxglove::StatusLevel::kError, "the teamscan view is read-only: " + r.op + " is refused");
        break;
      case foxglove::ClientRequest::Kind::kMalformed:
        ++srv_.counters.foxglove_malformed;
        status(foxglove::StatusLevel::kError, "malformed message: " + r.why);
        break;
    }
  }

 private:
  static constexpr std::uint32_t kNone = ~std::uint32_t{0};

  void push(SharedMessage m) {
    if (QueuedWebSocket::push(std::move(m))) ++srv_.counters.foxglove_skips;
  }

  static SharedMessage data_message(std::uint32_t subscription, const foxglove::ChannelMessage& m) {
    auto out = std::make_shared<Message>();
    out->binary = true;
    out->bytes = foxglove::encode_message_data(subscription, m.stamp_ns, *m.payload);
    return out;
  }

  void status(foxglove::StatusLevel level, const std::string& message) {
    push(text_message(foxglove::encode_status(level, message)));
  }

  void subscribe(const foxglove::ClientRequest& r) {
    for (const auto& [id, channel] : r.subscriptions) {
      if (!srv_.fox.has_channel(channel)) {
        status(foxglove::StatusLevel::kError, "subscribe: no channel " + std::to_string(channel));
        continue;
      }
      if (channel_of_.contains(id)) {
        status(foxglove::StatusLevel::kError, "subscribe: subscription id " + std::to_string(id) + " is in use");
        continue;
      }
      if (subscription_of_.size() <= channel) subscription_of_.resize(channel + 1, kNone);
      if (subscription_of_[channel] != kNone) channel_of_.erase(subscription_of_[channel]);  // one per channel
      subscription_of_[channel] = id;
      channel_of_[id] = channel;
      if (const foxglove::ChannelMessage* latest = srv_.fox.latest(channel)) push(data_message(id, *latest));
    }
  }

  std::vector<std::uint32_t> subscription_of_;         // index channel id: subscription id, or kNone
  std::map<std::uint32_t, std::uint32_t> channel_of_;  // subscription id -> channel id
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
    if (is_foxglove_upgrade(sv(req.method_string()), sv(req.target()), websocket::is_upgrade(req),
                            sv(req[http::field::sec_websocket_protocol]), foxglove::kSubprotocol)) {
      auto fox = std::make_shared<FoxgloveSession>(srv_, std::move(stream_), slot_);
      fox->start(parser_->release());
      return;
    }
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

void ViewServer::Impl::tick(bool final_map) {
  feed.drain(batch);
  if (batch.scan_count != 0 || !batch.voxels.empty() || batch.snapshot) {
    outgoing.clear();
    hub.apply(batch, outgoing);
    for (const std::shared_ptr<WsSession>& c : clients) {
      for (const SharedMessage& m : outgoing) c->push(m);
    }
  }
  fox_out.clear();
  fox_added.clear();
  fox.apply(batch, hub, now_realtime().ns(), fox_out, fox_added, final_map);
  for (const std::shared_ptr<FoxgloveSession>& c : fox_clients) {
    if (!fox_added.empty()) c->advertise(fox_added);
    for (const foxglove::ChannelMessage& m : fox_out) c->deliver(m);
  }
  std::size_t queued = 0;
  for (const std::shared_ptr<WsSession>& c : clients) {
    c->kick();
    queued += c->queued_bytes();
  }
  for (const std::shared_ptr<FoxgloveSession>& c : fox_clients) {
    c->kick();
    queued += c->queued_bytes();
  }
  counters.queued_bytes = queued;
  counters.hub_bytes = hub.memory_bytes();
}

bool ViewServer::Impl::clients_sent_all() const {
  return std::all_of(clients.begin(), clients.end(), [](const std::shared_ptr<WsSession>& c) { return c->sent_all(); }) &&
         std::all_of(fox_clients.begin(), fox_clients.end(), [](const std::shared_ptr<FoxgloveSession>& c) { return c->sent_all(); });
}

void ViewServer::Impl::remove_client(const WsSession* s) {
  std::erase_if(clients, [s](const std::shared_ptr<WsSession>& c) { return c.get() == s; });
}

void ViewServer::Impl::remove_fox_client(const FoxgloveSession* s) {
  std::erase_if(fox_clients, [s](const std::shared_ptr<FoxgloveSession>& c) { return c.get() == s; });
}

ViewServer::ViewServer(std::unique_ptr<Impl> impl) : impl_{std::move(impl)} {}

namespace {

// ViewServer::flush on the server thread: the feed drained, then the clients' queues watched every 10 ms
// until all are written or the deadline passes.
struct FlushWatch : std::enable_shared_from_this<FlushWatch> {
  FlushWatch(ViewServer::Impl& s, std::chrono::steady_clock::time_point d) : srv{s}, timer{s.ioc}, deadline{d} {}
  void check() {
    const bool sent = srv.clients_sent_all();
    if (sent || std::chrono::steady_clock::now() >= deadline) {
      done.set_value(sent);
      return;
    }
    timer.expires_after(std::chrono::milliseconds(10));
    timer.async_wait([self = shared_from_this()](error_code ec) {
      if (ec) {
        self->done.set_value(false);
      } else {
        self->check();
      }
    });
  }
  ViewServer::Impl& srv;
  net::steady_timer timer;
  std::chrono::steady_clock::time_point deadline;
  std::promise<bool> done;
};

}  // namespace

bool ViewServer::flush(Duration timeout) {
  auto watch = std::make_shared<FlushWatch>(*impl_, std::chrono::steady_clock::now() + timeout);
  std::future<bool> sent = watch->done.get_future();
  net::post(impl_->ioc, [watch] {
    watch->srv.tick(true);
    watch->check();
  });
  if (sent.wait_for(timeout + std::chrono::seconds(1)) != std::future_status::ready) return false;
  return sent.get();
}

ViewServer::~ViewServer() {
  impl_->ioc.stop();
  if (impl_->thread.joinable()) impl_->thread.join();
  for (const std::shared_ptr<WsSession>& c : impl_->clients) c->close();
  impl_->clients.clear();
  for (const std::shared_ptr<FoxgloveSession>& c : impl_->fox_clients) c->close();
  impl_->fox_clients.clear();
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
