// ViewServer over loopback sockets: files and API answered; malformed, oversized and unknown requests get
// an error and are counted; a WebSocket client gets the whole map first, then changes; what a client sends
// is refused (read-only) and counted; a client that does not read skips to the whole state, and what the
// server queues for it stays within the bound.
#include "groundstation/view/server.hpp"

#include <arpa/inet.h>
#include <dirent.h>
#include <sched.h>
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <pthread.h>
#include <sys/socket.h>
#include <unistd.h>

#include <boost/asio/connect.hpp>
#include <boost/asio/ip/tcp.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/websocket.hpp>
#include <cerrno>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <thread>
#include <vector>

namespace teamscan::view {
namespace {

namespace fs = std::filesystem;
namespace beast = boost::beast;
namespace websocket = beast::websocket;
namespace net = boost::asio;
using tcp = net::ip::tcp;

class ViewServerTest : public ::testing::Test {
 protected:
  void SetUp() override {
    root_ = fs::temp_directory_path() / ("teamscan-view-test-" + std::to_string(::getpid()));
    fs::create_directories(root_);
    std::ofstream(root_ / "index.html") << "<html>teamscan</html>";
    std::ofstream(root_ / "app.js") << "console.log(1)";
  }
  void TearDown() override {
    server_.reset();
    fs::remove_all(root_);
  }
  void start(ServerOptions o = {}) {
    o.listen = {"127.0.0.1", 0};
    o.web_root = root_.string();
    if (o.tick == ServerOptions{}.tick) o.tick = std::chrono::milliseconds(20);
    auto s = ViewServer::start(o, feed_);
    ASSERT_TRUE(s.ok()) << s.error().what;
    server_ = std::move(s.value());
  }
  // Sends raw bytes, returns everything the server answers until it closes (or 3 s).
  std::string raw(const std::string& request) {
    const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_port = htons(server_->port());
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    EXPECT_EQ(::connect(fd, reinterpret_cast<sockaddr*>(&a), sizeof a), 0);
    timeval tv{3, 0};
    ::setsockopt(fd, SOL_SOCKET, SO_RCVTIMEO, &tv, sizeof tv);
    std::size_t sent = 0;
    while (sent < request.size()) {
      const ssize_t n = ::send(fd, request.data() + sent, request.size() - sent, MSG_NOSIGNAL);
      if (n <= 0) break;
      sent += static_cast<std::size_t>(n);
    }
    std::string out;
    char buf[4096];
    for (;;) {
      const ssize_t n = ::recv(fd, buf, sizeof buf, 0);
      if (n <= 0) break;
      out.append(buf, static_cast<std::size_t>(n));
    }
    ::close(fd);
    return out;
  }
  static int status_of(const std::string& response) {
    return response.size() > 12 ? std::stoi(response.substr(9, 3)) : 0;
  }
  void wait_for(const std::function<bool()>& cond) {
    for (int i = 0; i < 300 && !cond(); ++i) std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }

  fs::path root_;
  ViewFeed feed_;
  std::unique_ptr<ViewServer> server_;
};

TEST_F(ViewServerTest, ServesTheFilesAndTheApi) {
  start();
  EXPECT_EQ(server_->files(), 2u);
  const std::string r = raw("GET / HTTP/1.1\r\nHost: x\r\nConnection: close\r\n\r\n");
  EXPECT_EQ(status_of(r), 200);
  EXPECT_NE(r.find("<html>teamscan</html>"), std::string::npos);
  EXPECT_NE(r.find("text/html"), std::string::npos);
  EXPECT_EQ(status_of(raw("GET /app.js HTTP/1.1\r\nHost: x\r\nConnection: close\r\n\r\n")), 200);
  EXPECT_EQ(status_of(raw("GET /api/state HTTP/1.1\r\nHost: x\r\nConnection: close\r\n\r\n")), 404);  // no state yet
  TeamSnapshot t;
  t.count = 1;
  t.robots[0].robot_id = 4;
  t.robots[0].x_m = 1.5;
  feed_.offer_snapshot(t);
  wait_for([&] { return status_of(raw("GET /api/state HTTP/1.1\r\nHost: x\r\nConnection: close\r\n\r\n")) == 200; });
  const std::string s = raw("GET /api/state?seq=1 HTTP/1.1\r\nHost: x\r\nConnection: close\r\n\r\n");
  EXPECT_EQ(status_of(s), 200);
  EXPECT_NE(s.find("\"x_m\":1.5"), std::string::npos);
  EXPECT_EQ(status_of(raw("GET /api/stats HTTP/1.1\r\nHost: x\r\nConnection: close\r\n\r\n")), 200);
  EXPECT_EQ(server_->counters().malformed.load() + server_->counters().oversized.load(), 0u);
}

// The view's thread never preempts the station's loop on wakeup: the kernel reports it SCHED_BATCH,
// while the caller's thread (the loop) keeps its policy.
TEST_F(ViewServerTest, TheServerThreadRunsBatchClassTheCallerKeepsItsPolicy) {
  const int caller_policy = ::sched_getscheduler(0);
  start();
  int view_threads = 0, view_policy = -1;
  wait_for([&] {
    view_threads = 0;
    DIR* d = ::opendir("/proc/self/task");
    if (d == nullptr) return false;
    while (const dirent* e = ::readdir(d)) {
      if (e->d_name[0] == '.') continue;
      std::ifstream comm(std::string("/proc/self/task/") + e->d_name + "/comm");
      std::string name;
      std::getline(comm, name);
      if (name != "teamscan-view") continue;
      ++view_threads;
      view_policy = ::sched_getscheduler(std::stoi(e->d_name));
    }
    ::closedir(d);
    return view_threads == 1 && view_policy == SCHED_BATCH;
  });
  EXPECT_EQ(view_threads, 1);
  EXPECT_EQ(view_policy, SCHED_BATCH);
  EXPECT_EQ(::sched_getscheduler(0), caller_policy);
  EXPECT_NE(caller_policy, SCHED_BATCH);
}

// [view] cpus: the server thread runs on the CPUs asked for (here the last one this process may use),
// still SCHED_BATCH; the caller keeps its whole affinity. A set with no usable CPU is refused, reported
// (the station logs it as a warning) and leaves the thread where it was.
TEST_F(ViewServerTest, TheServerThreadRunsOnItsCpusTheCallerKeepsItsOwn) {
  const std::vector<int> allowed = current_thread_cpus();
  ASSERT_FALSE(allowed.empty());
  ServerOptions o;
  o.cpus = {allowed.back()};
  start(o);
  const ThreadScheduling placed = server_->scheduling();
  EXPECT_EQ(placed.affinity_error, 0);
  EXPECT_EQ(placed.cpus, o.cpus);
  EXPECT_EQ(placed.policy, SCHED_BATCH);
  EXPECT_EQ(current_thread_cpus(), allowed);
  server_.reset();

  ServerOptions none;
  none.cpus = {CPU_SETSIZE - 1};  // in range, not a CPU of this machine
  start(none);
  const ThreadScheduling refused = server_->scheduling();
  EXPECT_EQ(refused.affinity_error, EINVAL);
  EXPECT_EQ(refused.cpus, allowed);
}

TEST_F(ViewServerTest, MalformedOversizedAndUnknownRequestsGetAnErrorAndAreCounted) {
  start();
  const ViewCounters& c = server_->counters();
  EXPECT_EQ(status_of(raw("GARBAGE\r\n\r\n")), 400);
  EXPECT_EQ(c.malformed.load(), 1u);
  EXPECT_EQ(status_of(raw("GET / HTTP/1.1\r\nHost: x\r\nBad Header Line\r\n\r\n")), 400);
  EXPECT_EQ(c.malformed.load(), 2u);
  EXPECT_EQ(status_of(raw("GET / HTTP/1.1\r\nHost: x\r\nX-Big: " + std::string(20000, 'a') + "\r\n\r\n")), 431);
  EXPECT_EQ(c.oversized.load(), 1u);
  EXPECT_EQ(status_of(raw("POST / HTTP/1.1\r\nHost: x\r\nContent-Length: 5\r\n\r\nhello")), 413);
  EXPECT_EQ(c.oversized.load(), 2u);
  EXPECT_EQ(status_of(raw("GET /" + std::string(2000, 'a') + " HTTP/1.1\r\nHost: x\r\nConnection: close\r\n\r\n")),
            414);
  EXPECT_EQ(c.oversized.load(), 3u);
  const std::string nf = raw("GET /secret.txt HTTP/1.1\r\nHost: x\r\nConnection: close\r\n\r\n");
  EXPECT_EQ(status_of(nf), 404);
  EXPECT_NE(nf.find("\"error\":\"not found\""), std::string::npos);
  EXPECT_EQ(c.not_found.load(), 1u);
  EXPECT_EQ(status_of(raw("DELETE /api/state HTTP/1.1\r\nHost: x\r\nConnection: close\r\n\r\n")), 405);
  EXPECT_EQ(c.bad_method.load(), 1u);
  // The server is still serving.
  EXPECT_EQ(status_of(raw("GET / HTTP/1.1\r\nHost: x\r\nConnection: close\r\n\r\n")), 200);
}

struct WsClient {
  net::io_context ioc;
  websocket::stream<tcp::socket> ws{ioc};
  beast::flat_buffer buffer;
  explicit WsClient(std::uint16_t port) {
    ws.next_layer().connect(tcp::endpoint(net::ip::make_address("127.0.0.1"), port));
    ws.handshake("127.0.0.1", "/ws");
  }
  std::pair<bool, std::string> read() {
    buffer.clear();
    ws.read(buffer);
    return {ws.got_binary(), beast::buffers_to_string(buffer.data())};
  }
};

TEST_F(ViewServerTest, WebSocketClientGetsTheWholeMapFirstThenChanges) {
  start();
  const VoxelUpdate v1[] = {{50, 50, 50, 1, 0}, {150, 50, 50, 2, 1}};
  feed_.offer_voxels(v1);
  TeamSnapshot t;
  t.count = 1;
  t.robots[0].robot_id = 1;
  feed_.offer_snapshot(t);
  std::this_thread::sleep_for(std::chrono::milliseconds(200));
  WsClient c(server_->port());
  auto [bin, bytes] = c.read();
  ASSERT_TRUE(bin);
  auto whole = decode_voxels(bytes);
  ASSERT_TRUE(whole.ok());
  EXPECT_EQ(whole.value().kind, VoxelKind::kWholeMap);
  EXPECT_EQ(whole.value().voxels.size(), 2u);
  auto [bin2, state] = c.read();
  EXPECT_FALSE(bin2);
  EXPECT_NE(state.find("\"whole\":true"), std::string::npos);
  const VoxelUpdate v2[] = {{250, 50, 50, 1, 0}};
  feed_.offer_voxels(v2);
  for (;;) {
    auto [b, m] = c.read();
    if (!b) continue;
    auto changed = decode_voxels(m);
    ASSERT_TRUE(changed.ok());
    EXPECT_EQ(changed.value().kind, VoxelKind::kChanged);
    ASSERT_EQ(changed.value().voxels.size(), 1u);
    EXPECT_EQ(changed.value().voxels[0].x_mm, 250);
    break;
  }
  EXPECT_EQ(server_->counters().ws_opened.load(), 1u);
}

// The station's shutdown: its last map and state, offered just before the server stops, reach an open
// page. With a tick that never comes, only flush() drains the feed; it returns once the messages are on
// the socket, so the client reads them after the server is gone.
TEST_F(ViewServerTest, FlushSendsTheLastOffersToOpenPagesBeforeTheServerStops) {
  ServerOptions o;
  o.tick = std::chrono::hours(1);
  start(o);
  WsClient c(server_->port());
  auto [bin, bytes] = c.read();  // the whole map (empty)
  ASSERT_TRUE(bin);
  wait_for([&] { return server_->counters().ws_open.load() == 1; });
  const VoxelUpdate v[] = {{250, 50, 50, 3, 1, 2}};
  feed_.offer_voxels(v);
  TeamSnapshot t;
  t.count = 1;
  t.robots[0].robot_id = 2;
  t.map_release = 4242;
  feed_.offer_snapshot(t);
  EXPECT_TRUE(server_->flush(std::chrono::seconds(2)));
  server_.reset();
  auto [bin2, voxels] = c.read();
  ASSERT_TRUE(bin2);
  auto changed = decode_voxels(voxels);
  ASSERT_TRUE(changed.ok());
  ASSERT_EQ(changed.value().voxels.size(), 1u);
  EXPECT_EQ(changed.value().voxels[0].x_mm, 250);
  EXPECT_EQ(changed.value().voxels[0].flags, 1u);
  auto [bin3, state] = c.read();
  EXPECT_FALSE(bin3);
  EXPECT_NE(state.find("\"map_release\":4242"), std::string::npos) << state;
}

TEST_F(ViewServerTest, TheViewIsReadOnlyAndRefusesOversizedClientMessages) {
  ServerOptions o;
  o.requests.max_ws_message_bytes = 1024;
  start(o);
  WsClient c(server_->port());
  c.read();  // the whole map (empty)
  c.ws.text(true);
  c.ws.write(net::buffer(std::string("{\"cmd\":\"stop\"}")));
  auto [bin, reply] = c.read();
  EXPECT_FALSE(bin);
  EXPECT_NE(reply.find("\"type\":\"error\""), std::string::npos);
  EXPECT_EQ(server_->counters().ws_rejected.load(), 1u);
  c.ws.write(net::buffer(std::string(4096, 'x')));
  beast::error_code ec;
  for (int i = 0; i < 10 && !ec; ++i) c.ws.read(c.buffer, ec);  // the server closes the connection (1009)
  EXPECT_TRUE(ec);
  wait_for([&] { return server_->counters().oversized.load() == 1; });
  EXPECT_EQ(server_->counters().oversized.load(), 1u);
  wait_for([&] { return server_->counters().ws_open.load() == 0; });
  EXPECT_EQ(server_->counters().ws_open.load(), 0u);
}

TEST_F(ViewServerTest, AClientThatDoesNotReadSkipsToTheWholeStateWithinTheBound) {
  ServerOptions o;
  o.queue = {.max_bytes = 1u << 20, .max_messages = 8};
  start(o);
  WsClient c(server_->port());
  c.read();  // the whole map (empty); then the client stops reading
  std::vector<VoxelUpdate> batch(20000);
  std::size_t peak = 0;
  for (int i = 0; i < 80 && server_->counters().skips.load() == 0; ++i) {
    for (std::size_t k = 0; k < batch.size(); ++k) {
      batch[k] = VoxelUpdate{static_cast<std::int32_t>(k) * 100 + 50, i * 100 + 50, 50, 1, 0};
    }
    feed_.offer_voxels(batch);
    std::this_thread::sleep_for(std::chrono::milliseconds(40));
    peak = std::max<std::size_t>(peak, server_->counters().queued_bytes.load());
  }
  EXPECT_GE(server_->counters().skips.load(), 1u);
  EXPECT_LE(peak, o.queue.max_bytes);
  // Reading again, the client gets a whole map with everything so far.
  bool got_whole = false;
  for (int i = 0; i < 200 && !got_whole; ++i) {
    auto [bin, bytes] = c.read();
    if (!bin) continue;
    auto m = decode_voxels(bytes);
    ASSERT_TRUE(m.ok());
    if (m.value().kind == VoxelKind::kWholeMap) {
      got_whole = true;
      EXPECT_GE(m.value().voxels.size(), 20000u);
    }
  }
  EXPECT_TRUE(got_whole);
}

}  // namespace
}  // namespace teamscan::view

namespace teamscan::view {
namespace {

// A Foxglove client over loopback: offers foxglove.websocket.v1 on "/".
struct FoxgloveWsClient {
  net::io_context ioc;
  websocket::stream<tcp::socket> ws{ioc};
  beast::flat_buffer buffer;
  std::string selected;
  explicit FoxgloveWsClient(std::uint16_t port) {
    ws.next_layer().connect(tcp::endpoint(net::ip::make_address("127.0.0.1"), port));
    ws.set_option(websocket::stream_base::decorator([](websocket::request_type& req) {
      req.set(beast::http::field::sec_websocket_protocol, "foxglove.websocket.v1");
    }));
    websocket::response_type res;
    ws.handshake(res, "127.0.0.1", "/");
    selected = std::string(res[beast::http::field::sec_websocket_protocol]);
  }
  std::pair<bool, std::string> read() {
    buffer.clear();
    ws.read(buffer);
    return {ws.got_binary(), beast::buffers_to_string(buffer.data())};
  }
  void send(const std::string& text) {
    ws.text(true);
    ws.write(net::buffer(text));
  }
};

TEST_F(ViewServerTest, FoxgloveClientSubscribesReceivesAndIsRefusedWritesCounted) {
  start();
  TeamSnapshot t;
  t.stamp_ns = 1'700'000'000'000'000'000;
  t.count = 1;
  t.robots[0].robot_id = 1;
  t.robots[0].x_m = 2.0;
  feed_.offer_snapshot(t);
  wait_for([&] { return server_->counters().hub_bytes.load() > 0; });
  std::this_thread::sleep_for(std::chrono::milliseconds(100));
  FoxgloveWsClient c(server_->port());
  EXPECT_EQ(c.selected, "foxglove.websocket.v1");
  auto [b1, info] = c.read();
  EXPECT_FALSE(b1);
  EXPECT_NE(info.find("\"op\":\"serverInfo\""), std::string::npos);
  auto [b2, adv] = c.read();
  EXPECT_FALSE(b2);
  EXPECT_NE(adv.find("\"op\":\"advertise\""), std::string::npos);
  EXPECT_NE(adv.find("\"/robot1/odom\""), std::string::npos);
  // Channel 2 is /tf: its newest message comes at once, under our subscription id.
  c.send(R"({"op":"subscribe","subscriptions":[{"id":42,"channelId":2}]})");
  auto [b3, data] = c.read();
  ASSERT_TRUE(b3);
  ASSERT_GT(data.size(), 13u);
  EXPECT_EQ(data[0], '\x01');
  EXPECT_EQ(data.substr(1, 4), std::string("\x2a\x00\x00\x00", 4));
  EXPECT_EQ(data.substr(13, 4), std::string("\x00\x01\x00\x00", 4));  // CDR_LE encapsulation
  c.send(R"({"op":"setParameters","parameters":[{"name":"/a","value":1}]})");
  c.send(R"({"op":"advertise","channels":[{"id":1,"topic":"/cmd_vel","encoding":"json","schemaName":"x"}]})");
  c.ws.binary(true);
  c.ws.write(net::buffer(std::string("\x01\x01\x00\x00\x00{}", 7)));
  c.send("{nonsense");
  int errors = 0;
  while (errors < 4) {
    auto [bin, m] = c.read();
    if (bin) continue;  // /tf keeps coming only with new snapshots; none are offered here
    if (m.find("\"op\":\"status\"") != std::string::npos && m.find("\"level\":2") != std::string::npos) ++errors;
  }
  EXPECT_EQ(server_->counters().foxglove_refused.load(), 3u);
  EXPECT_EQ(server_->counters().foxglove_malformed.load(), 1u);
  EXPECT_EQ(server_->counters().foxglove_opened.load(), 1u);
  EXPECT_EQ(server_->counters().ws_opened.load(), 0u);  // not a browser-view client
}

TEST(FoxgloveUpgrade, OnlyAnUpgradeOfferingTheSubprotocolOnTheViewsPaths) {
  EXPECT_TRUE(is_foxglove_upgrade("GET", "/", true, "foxglove.websocket.v1", "foxglove.websocket.v1"));
  EXPECT_TRUE(is_foxglove_upgrade("GET", "/ws?x=1", true, "other, foxglove.websocket.v1 ", "foxglove.websocket.v1"));
  EXPECT_TRUE(is_foxglove_upgrade("GET", "/foxglove", true, "foxglove.websocket.v1,x", "foxglove.websocket.v1"));
  EXPECT_FALSE(is_foxglove_upgrade("GET", "/", false, "foxglove.websocket.v1", "foxglove.websocket.v1"));
  EXPECT_FALSE(is_foxglove_upgrade("GET", "/ws", true, "", "foxglove.websocket.v1"));
  EXPECT_FALSE(is_foxglove_upgrade("GET", "/ws", true, "foxglove.websocket.v1x", "foxglove.websocket.v1"));
  EXPECT_FALSE(is_foxglove_upgrade("GET", "/api/state", true, "foxglove.websocket.v1", "foxglove.websocket.v1"));
  EXPECT_FALSE(is_foxglove_upgrade("POST", "/", true, "foxglove.websocket.v1", "foxglove.websocket.v1"));
}

}  // namespace
}  // namespace teamscan::view
