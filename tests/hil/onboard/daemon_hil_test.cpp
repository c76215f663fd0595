// Hardware-in-loop test of teamscan-onboard: the real daemon process against an emulated Pioneer 3-AT
// and an emulated LMS-200 on pseudo-terminals (PtyRunner), observed through a NOTIFY_SOCKET harness
// (READY=1, STATUS=, WATCHDOG=1, STOPPING=1) and, as a ground-station operator sees it, through
// teamscan/status on loopback DDS. Covers reaching the streaming state, unplugging and replugging each
// device while the other keeps running, a corrupted line on each device, a Pioneer that stops
// answering, a scanner reset, and a clean SIGTERM.
#include <gtest/gtest.h>

#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <sys/wait.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <optional>
#include <regex>
#include <sstream>
#include <string>
#include <vector>

#include "common/clock.hpp"
#include "drivers/arcos/client.hpp"
#include "drivers/arcos/emulator.hpp"
#include "drivers/lms200/client.hpp"
#include "drivers/lms200/emulator.hpp"
#include "drivers/serial/pty_runner.hpp"
#include "onboard/bridge/bridge.hpp"
#include "dds/qos.hpp"
#include "teamscan.h"
#include "tests/hil/onboard/daemon_process.hpp"
#include "tests/support/dds_test_subscriber.hpp"

namespace teamscan {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

using test::daemon_path;
using test::file_text;
using test::source_dir;
using test::spawn;
using test::TempDir;

// Every beam 3 m (a wall all round).
class FlatRanges final : public lms200::RangeSource {
 public:
  void measure(const lms200::SweepTiming& sweep, std::span<lms200::BeamReading> beams) override {
    for (std::size_t i = 0; i < sweep.variant.beams() && i < beams.size(); ++i) beams[i] = {3000, 0, lms200::BeamInvalid::none};
  }
};

// A device that can stop answering: while muted it neither hears nor speaks (a Pioneer whose
// controller hangs, a cut cable), but keeps running. `corrupt_chunks` > 0 flips one byte in each of
// that many of its next transmissions (a noisy line).
class Muteable final : public serial::SerialEndpoint {
 public:
  explicit Muteable(serial::SerialEndpoint& inner) : inner_{inner} {}
  void on_rx(std::span<const std::uint8_t> bytes, Time now) override {
    if (!muted) inner_.on_rx(bytes, now);
  }
  void on_tick(Time now) override { inner_.on_tick(now); }
  std::size_t take_tx(std::span<std::uint8_t> out) override {
    const std::size_t n = inner_.take_tx(out);
    if (n > 0 && !muted && corrupt_chunks.load() > 0) {
      --corrupt_chunks;
      out[n / 2] ^= 0x5A;
    }
    return muted ? 0 : n;
  }
  std::uint32_t baud() const override { return inner_.baud(); }
  Time next_deadline() const override { return inner_.next_deadline(); }
  std::atomic<bool> muted{false};
  std::atomic<int> corrupt_chunks{0};

 private:
  serial::SerialEndpoint& inner_;
};

// The systemd side of sd_notify: a datagram socket the daemon writes to.
class NotifySocket {
 public:
  explicit NotifySocket(const fs::path& path) : path_{path} {
    fd_ = ::socket(AF_UNIX, SOCK_DGRAM | SOCK_CLOEXEC | SOCK_NONBLOCK, 0);
    sockaddr_un addr{};
    addr.sun_family = AF_UNIX;
    std::strncpy(addr.sun_path, path.c_str(), sizeof addr.sun_path - 1);
    bound_ = ::bind(fd_, reinterpret_cast<sockaddr*>(&addr), sizeof addr) == 0;
  }
  ~NotifySocket() { ::close(fd_); }
  bool bound() const { return bound_; }

  // Receives datagrams until `pred(message)` is true for one of them, or `timeout` passes.
  bool wait_for(const std::function<bool(const std::string&)>& pred, std::chrono::milliseconds timeout) {
    const auto deadline = Clock::now() + timeout;
    while (Clock::now() < deadline) {
      pollfd pfd{fd_, POLLIN, 0};
      const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - Clock::now());
      if (::poll(&pfd, 1, static_cast<int>(std::max<long>(1, left.count()))) <= 0) continue;
      char buf[4096];
      const ssize_t n = ::recv(fd_, buf, sizeof buf - 1, 0);
      if (n <= 0) continue;
      const std::string msg(buf, static_cast<std::size_t>(n));
      log_.push_back(msg);
      if (pred(msg)) return true;
    }
    return false;
  }
  const std::vector<std::string>& log() const { return log_; }
  // Reads whatever is queued, without matching. The daemon's sd_notify blocks once the socket holds
  // net.unix.max_dgram_qlen (10) unread datagrams, so a test that waits on DDS for seconds must keep
  // draining, as systemd always reads.
  void drain() {
    char buf[4096];
    for (;;) {
      const ssize_t n = ::recv(fd_, buf, sizeof buf - 1, MSG_DONTWAIT);
      if (n <= 0) return;
      log_.emplace_back(buf, static_cast<std::size_t>(n));
    }
  }

 private:
  fs::path path_;
  int fd_ = -1;
  bool bound_ = false;
  std::vector<std::string> log_;
};

// Scans published so far, from a STATUS= line; -1 if it is not a status line.
long scans_in(const std::string& msg) {
  static const std::regex re{"scans ([0-9]+),"};
  std::smatch m;
  if (msg.rfind("STATUS=", 0) != 0 || !std::regex_search(msg, m, re)) return -1;
  return std::stol(m[1]);
}
bool has(const std::string& msg, const char* what) { return msg.find(what) != std::string::npos; }

// teamscan/status as the ground station's operator sees it: every sample with its arrival time.
constexpr std::uint8_t kArcosUp = 1 + static_cast<std::uint8_t>(arcos::ArcosClientState::kConnected);  // daemon.cpp state_byte
constexpr std::uint8_t kLmsUp = 1 + static_cast<std::uint8_t>(lms200::LmsClientState::streaming);
constexpr std::uint8_t kPortClosed = 0;

class StatusWatch {
 public:
  struct Seen {
    teamscan_msg_RobotStatus status;
    Clock::time_point arrival;
  };
  explicit StatusWatch(dds_domainid_t domain) : sub_{&teamscan_msg_RobotStatus_desc, dds::kTopicStatus, qos(), 16, domain} {}
  bool ok() const { return sub_.ok(); }
  // Called on every poll (the test drains the notify socket there).
  std::function<void()> on_poll;

  // Waits for a status (newer than any returned before) for which `pred` is true.
  std::optional<Seen> wait_for(const std::function<bool(const teamscan_msg_RobotStatus&)>& pred, std::chrono::milliseconds timeout) {
    const auto deadline = Clock::now() + timeout;
    for (;;) {
      for (; next_ < all_.size(); ++next_)
        if (pred(all_[next_].status)) return all_[next_++];
      if (Clock::now() >= deadline) return std::nullopt;
      poll(std::chrono::milliseconds(20));
    }
  }
  // Every status received so far (the test checks properties over the whole run).
  const std::vector<Seen>& all() {
    poll(std::chrono::milliseconds(0));
    return all_;
  }

 private:
  static const dds_qos_t* qos() {
    static dds_qos_t* q = dds::make_state_reader_qos();
    return q;
  }
  void poll(std::chrono::milliseconds wait) {
    if (on_poll) on_poll();
    std::vector<teamscan_msg_RobotStatus> got;
    if (wait.count() > 0) (void)sub_.take_until(got, 1, wait); else (void)sub_.take_available(got);
    const auto now = Clock::now();
    for (const auto& g : got) all_.push_back({g, now});
  }
  test::DdsTestSubscriber<teamscan_msg_RobotStatus> sub_;
  std::vector<Seen> all_;
  std::size_t next_ = 0;
};

long long ms_between(Clock::time_point a, Clock::time_point b) {
  return static_cast<long long>(std::chrono::duration_cast<std::chrono::milliseconds>(b - a).count());
}

// The states of the last `n` statuses received, for failure messages.
std::string recent_states(StatusWatch& w, std::size_t n = 40) {
  const auto& all = w.all();
  std::string out = "statuses (seq arcos lms):";
  for (std::size_t i = all.size() > n ? all.size() - n : 0; i < all.size(); ++i) {
    // Appended piece by piece (GCC 12 at -O3 warns on `" " + std::string` here: a false -Wrestrict).
    out += ' ';
    out += std::to_string(all[i].status.seq);
    out += ':';
    out += std::to_string(all[i].status.arcos_state);
    out += '/';
    out += std::to_string(all[i].status.lms_state);
  }
  return out;
}

// Waits for the child to exit; its status, or -1 after `timeout` (then it is killed).
int wait_exit(pid_t pid, std::chrono::milliseconds timeout) {
  const auto deadline = Clock::now() + timeout;
  int status = 0;
  while (Clock::now() < deadline) {
    if (::waitpid(pid, &status, WNOHANG) == pid) return status;
    ::usleep(10'000);
  }
  ::kill(pid, SIGKILL);
  ::waitpid(pid, &status, 0);
  return -1;
}

bool alive(pid_t pid) {
  int status = 0;
  return ::waitpid(pid, &status, WNOHANG) == 0;
}

TEST(OnboardDaemonProcess, CheckConfigAcceptsTheExamplesAndRefusesBadFiles) {
  TempDir dir;
  for (const char* example : {"deploy/onboard-down-laser.toml", "deploy/onboard-up-laser.toml"}) {
    const pid_t pid = spawn({daemon_path(), "--config", source_dir() + "/" + example, "--check-config"}, {},
                            dir.path / "check.log");
    const int st = wait_exit(pid, std::chrono::seconds(10));
    ASSERT_TRUE(WIFEXITED(st)) << example;
    EXPECT_EQ(WEXITSTATUS(st), 0) << file_text(dir.path / "check.log");
  }
  std::ofstream(dir.path / "bad.toml") << "[robot]\nid = 1\n[arcos]\ndevice = \"/dev/x\"\nbaud = 1234\n";
  const pid_t pid = spawn({daemon_path(), "--config", (dir.path / "bad.toml").string(), "--check-config"}, {},
                          dir.path / "bad.log");
  const int st = wait_exit(pid, std::chrono::seconds(10));
  ASSERT_TRUE(WIFEXITED(st));
  EXPECT_EQ(WEXITSTATUS(st), 2);
  EXPECT_NE(file_text(dir.path / "bad.log").find("arcos.baud"), std::string::npos) << file_text(dir.path / "bad.log");
}

TEST(OnboardDaemonHil, StreamsSurvivesUnplugOfEachDeviceAndStopsCleanly) {
  TempDir dir;
  const fs::path arcos_link = dir.path / "ttyArcos", lms_link = dir.path / "ttyLms";
  // A DDS domain of its own: other tests on this host publish teamscan/team.
  const auto domain = static_cast<dds_domainid_t>(100 + ::getpid() % 100);

  arcos::PioneerEmulator pioneer;
  Muteable pioneer_line{pioneer};
  FlatRanges ranges;
  lms200::LmsEmulatorOptions lms_options;
  lms_options.variant = LaserVariant{180, 50};
  lms200::LmsEmulator scanner{lms_options, &ranges};
  Muteable scanner_line{scanner};
  scanner.power_up(now_monotonic());

  auto arcos_runner = serial::PtyRunner::create(pioneer_line, serial::PtyRunnerOptions{.link_path = arcos_link.string()});
  ASSERT_TRUE(arcos_runner.ok()) << arcos_runner.error().what;
  auto lms_runner = serial::PtyRunner::create(scanner_line, serial::PtyRunnerOptions{.link_path = lms_link.string()});
  ASSERT_TRUE(lms_runner.ok()) << lms_runner.error().what;
  ASSERT_TRUE((*arcos_runner)->start().ok());
  ASSERT_TRUE((*lms_runner)->start().ok());

  std::ofstream(dir.path / "onboard.toml") << "[robot]\nid = 4\n"
                                           << "[arcos]\ndevice = \"" << arcos_link.string() << "\"\nbaud = 9600\n"
                                           << "[lms]\ndevice = \"" << lms_link.string() << "\"\nbaud = 500000\n"
                                           << "fov_deg = 180\nresolution_deg = 0.5\n"
                                           << "[mount]\nx_m = 0.16\ny_m = 0\nz_m = 0.45\npitch_deg = 15\n"
                                           << "[status]\nperiod_s = 0.2\n"
                                           << "[dds]\ndomain = " << domain << "\n";
  // A ground station's scan reader on the daemon's domain (loopback config from ctest).
  dds_qos_t* scan_qos = dds::make_scan_reader_qos();
  test::DdsTestSubscriber<teamscan_msg_ScanPoints> scans_sub{&teamscan_msg_ScanPoints_desc, dds::kTopicScan, scan_qos,
                                                             64, domain};
  dds_delete_qos(scan_qos);
  ASSERT_TRUE(scans_sub.ok());
  StatusWatch status{domain};
  ASSERT_TRUE(status.ok());
  NotifySocket notify{dir.path / "notify.sock"};
  ASSERT_TRUE(notify.bound());
  status.on_poll = [&notify] { notify.drain(); };
  const pid_t pid = spawn({daemon_path(), "--config", (dir.path / "onboard.toml").string()},
                          {"NOTIFY_SOCKET=" + (dir.path / "notify.sock").string(), "WATCHDOG_USEC=1000000"},
                          dir.path / "daemon.log");
  ASSERT_GT(pid, 0);
  // A failed ASSERT returns early: the daemon must not outlive the test.
  struct KillOnExit {
    pid_t pid;
    ~KillOnExit() {
      int st = 0;
      if (::waitpid(pid, &st, WNOHANG) == 0) {
        ::kill(pid, SIGKILL);
        ::waitpid(pid, &st, 0);
      }
    }
  } kill_on_exit{pid};
  auto log_text = [&] { return file_text(dir.path / "daemon.log"); };

  // READY=1 once the Pioneer is connected and the LMS streams (bring-up at 9600, switch to 500 kBd).
  ASSERT_TRUE(notify.wait_for([](const std::string& m) { return m == "READY=1"; }, std::chrono::seconds(30))) << log_text();
  long scans = 0;
  ASSERT_TRUE(notify.wait_for([&](const std::string& m) { return (scans = scans_in(m)) > 20; }, std::chrono::seconds(10)))
      << log_text();
  // The scans reach a DDS reader: this robot, full 0.5° sweeps, the laser 0.45 m up, in order.
  {
    std::vector<teamscan_msg_ScanPoints> got;
    ASSERT_TRUE(scans_sub.wait_matched(1, std::chrono::seconds(10)));
    ASSERT_TRUE(scans_sub.take_until(got, 10, std::chrono::seconds(10))) << got.size();
    for (std::size_t i = 0; i < got.size(); ++i) {
      EXPECT_EQ(got[i].robot_id, 4u);
      EXPECT_EQ(got[i].count, 361);
      EXPECT_EQ(got[i].origin_z_mm, 450);
      if (i > 0) {
        EXPECT_GT(got[i].seq, got[i - 1].seq);
      }
    }
  }
  // The watchdog is pinged from the loop at half of WATCHDOG_USEC.
  int pings = 0;
  notify.wait_for([&](const std::string& m) { return m == "WATCHDOG=1" && ++pings >= 3; }, std::chrono::seconds(3));
  EXPECT_GE(pings, 3);

  // teamscan/status arrives periodically (status.period_s = 0.2), in order, and says both devices are
  // up with their rates, counters moving and no errors on clean lines.
  const auto healthy = [](const teamscan_msg_RobotStatus& st) { return st.arcos_state == kArcosUp && st.lms_state == kLmsUp; };
  ASSERT_TRUE(status.wait_for(healthy, std::chrono::seconds(5))) << log_text();
  {
    std::vector<teamscan_msg_RobotStatus> period;
    for (int i = 0; i < 5; ++i) {
      auto st = status.wait_for([](const teamscan_msg_RobotStatus&) { return true; }, std::chrono::seconds(2));
      ASSERT_TRUE(st.has_value()) << "status " << i << " of 5 did not arrive within 2 s (period 0.2 s)";
      period.push_back(st->status);
    }
    for (std::size_t i = 0; i < period.size(); ++i) {
      const auto& st = period[i];
      EXPECT_EQ(st.robot_id, 4u);
      EXPECT_EQ(st.arcos_state, kArcosUp);
      EXPECT_EQ(st.lms_state, kLmsUp);
      EXPECT_GT(st.scan_rate_mhz, 0u);  // the emulator sends 75 sweeps/s; the rate itself is not asserted
      EXPECT_GT(st.sip_rate_mhz, 0u);
      EXPECT_EQ(st.arcos_bad_packets, 0u);
      EXPECT_EQ(st.lms_bad_telegrams, 0u);
      EXPECT_EQ(st.dds_write_errors, 0u);
      EXPECT_EQ(st.arcos_reopens, 1u);
      EXPECT_EQ(st.lms_reopens, 1u);
      if (i > 0) {
        const auto& prev = period[i - 1];
        // Keep-last 1: a slow reader may skip one, never sees one twice or out of order.
        EXPECT_GT(st.seq, prev.seq);
        // The daemon's own stamps: one status per period, never sooner.
        EXPECT_GE(st.stamp_ns - prev.stamp_ns, static_cast<std::int64_t>(st.seq - prev.seq) * 199'000'000);
        EXPECT_GT(st.scans_published, prev.scans_published);
        EXPECT_GE(st.uptime_s, prev.uptime_s);
      }
    }
  }

  // A noisy laser line: corrupted telegrams are counted (bad CRC / resync), the stream goes on.
  {
    const std::uint32_t published = status.all().back().status.scans_published;
    scanner_line.corrupt_chunks = 20;
    auto st = status.wait_for([&](const teamscan_msg_RobotStatus& x) {
      return x.lms_bad_telegrams > 0 && x.lms_state == kLmsUp && x.scans_published > published + 10;
    }, std::chrono::seconds(5));
    ASSERT_TRUE(st.has_value()) << log_text();
    EXPECT_EQ(st->status.dds_write_errors, 0u);
    EXPECT_EQ(st->status.lms_reopens, 1u);  // errors on the line are not a lost device
  }
  // And on the Pioneer's line: bad packets counted, the connection kept.
  {
    pioneer_line.corrupt_chunks = 5;
    auto st = status.wait_for([](const teamscan_msg_RobotStatus& x) { return x.arcos_bad_packets > 0; }, std::chrono::seconds(5));
    ASSERT_TRUE(st.has_value()) << log_text();
    EXPECT_EQ(st->status.arcos_reopens, 1u);
  }

  // Unplug the LMS: the daemon keeps running and keeps the Pioneer; after the replug the scans resume.
  (*lms_runner)->unplug();
  ASSERT_TRUE(notify.wait_for([](const std::string& m) { return has(m, "lms closed") && has(m, "arcos connected"); },
                              std::chrono::seconds(5)))
      << log_text();
  {
    // On DDS: the laser down (port closed), the Pioneer up, no scans counted while the laser is away.
    auto down = status.wait_for([](const teamscan_msg_RobotStatus& x) { return x.lms_state == kPortClosed; }, std::chrono::seconds(5));
    ASSERT_TRUE(down.has_value()) << log_text();
    EXPECT_EQ(down->status.arcos_state, kArcosUp);
    auto later = status.wait_for([](const teamscan_msg_RobotStatus& x) { return x.lms_state == kPortClosed; }, std::chrono::seconds(2));
    ASSERT_TRUE(later.has_value());
    EXPECT_EQ(later->status.scans_published, down->status.scans_published);
    EXPECT_EQ(later->status.scan_rate_mhz, 0u);
    EXPECT_GT(later->status.sip_rate_mhz, 0u);
    EXPECT_EQ(later->status.arcos_state, kArcosUp);
  }
  ::usleep(700'000);  // at least one failed reopen attempt (every 500 ms)
  ASSERT_TRUE(alive(pid)) << log_text();
  const std::uint32_t lms_opens_before = status.all().back().status.lms_reopens;
  const std::uint32_t published_before = status.all().back().status.scans_published;
  ASSERT_TRUE((*lms_runner)->replug().ok());
  const auto lms_back = Clock::now();
  {
    auto up = status.wait_for([&](const teamscan_msg_RobotStatus& x) {
      return x.lms_state == kLmsUp && x.scans_published > published_before;
    }, std::chrono::seconds(10));
    ASSERT_TRUE(up.has_value()) << log_text();
    const long long ms = ms_between(lms_back, up->arrival);
    std::printf("laser replugged -> streaming on teamscan/status: %lld ms\n", ms);
    // The bound: recovered within 2 s of the device's return (reopen every 500 ms, bring-up
    // at 9600 and the switch to 500 kBd), seen by the operator one status period (0.2 s) later.
    EXPECT_LE(ms, 2000 + 200);
    EXPECT_EQ(up->status.lms_reopens, lms_opens_before + 1);
    EXPECT_EQ(up->status.arcos_state, kArcosUp);
  }
  long before = -1;
  ASSERT_TRUE(notify.wait_for([&](const std::string& m) {
    const long s = scans_in(m);
    if (s < 0 || !has(m, "lms streaming")) return false;
    if (before < 0) before = s;
    return s > before + 10;
  }, std::chrono::seconds(10))) << log_text();

  // Unplug the Pioneer: scans go on meanwhile; after the replug it is connected again.
  (*arcos_runner)->unplug();
  long at_unplug = -1;
  ASSERT_TRUE(notify.wait_for([&](const std::string& m) {
    const long s = scans_in(m);
    if (s < 0 || !has(m, "arcos closed")) return false;
    if (at_unplug < 0) at_unplug = s;
    return s > at_unplug + 10;  // the LMS keeps streaming while the Pioneer is gone
  }, std::chrono::seconds(10))) << log_text();
  ASSERT_TRUE(alive(pid)) << log_text();
  {
    // On DDS: the Pioneer down (port closed), no SIPs, the laser up and its scans still counted.
    auto down = status.wait_for([](const teamscan_msg_RobotStatus& x) { return x.arcos_state == kPortClosed; }, std::chrono::seconds(5));
    ASSERT_TRUE(down.has_value()) << log_text();
    auto later = status.wait_for([](const teamscan_msg_RobotStatus& x) { return x.arcos_state == kPortClosed; }, std::chrono::seconds(2));
    ASSERT_TRUE(later.has_value());
    EXPECT_EQ(later->status.lms_state, kLmsUp);
    EXPECT_EQ(later->status.sip_rate_mhz, 0u);
    EXPECT_GT(later->status.scans_published, down->status.scans_published);
  }
  const std::uint32_t arcos_opens_before = status.all().back().status.arcos_reopens;
  ASSERT_TRUE((*arcos_runner)->replug().ok());
  const auto arcos_back = Clock::now();
  ASSERT_TRUE(notify.wait_for([](const std::string& m) { return has(m, "arcos connected") && has(m, "lms streaming"); },
                              std::chrono::seconds(10)))
      << log_text();
  {
    auto up = status.wait_for([](const teamscan_msg_RobotStatus& x) { return x.arcos_state == kArcosUp; }, std::chrono::seconds(5));
    ASSERT_TRUE(up.has_value()) << log_text();
    const long long ms = ms_between(arcos_back, up->arrival);
    std::printf("Pioneer replugged -> connected on teamscan/status: %lld ms\n", ms);
    EXPECT_LE(ms, 2000 + 200);  // within 2 s of its return, plus one status period
    EXPECT_EQ(up->status.arcos_reopens, arcos_opens_before + 1);
    EXPECT_EQ(up->status.lms_state, kLmsUp);
  }

  // The Pioneer stops answering for 2.5 s: the client notices (no SIP for 1 s), the LMS streams on,
  // and after the Pioneer answers again it is connected again (the time is printed, not asserted:
  // no timed pass/fail tests on a shared machine; the wait is bounded at 5 s).
  pioneer_line.muted = true;
  ASSERT_TRUE(notify.wait_for([](const std::string& m) { return has(m, "STATUS=") && !has(m, "arcos connected"); },
                              std::chrono::seconds(5)))
      << log_text();
  {
    // On DDS: reported while its port is still open (state not "closed", not "connected"), no SIPs;
    // the laser streams on.
    auto silent = status.wait_for([](const teamscan_msg_RobotStatus& x) {
      return x.arcos_state != kArcosUp && x.arcos_state != kPortClosed;
    }, std::chrono::seconds(5));
    ASSERT_TRUE(silent.has_value()) << log_text();
    EXPECT_EQ(silent->status.lms_state, kLmsUp);
    auto later = status.wait_for([](const teamscan_msg_RobotStatus& x) { return x.arcos_state != kArcosUp; }, std::chrono::seconds(2));
    ASSERT_TRUE(later.has_value());
    EXPECT_EQ(later->status.sip_rate_mhz, 0u);
    EXPECT_GT(later->status.scans_published, silent->status.scans_published);
  }
  status.wait_for([](const teamscan_msg_RobotStatus&) { return false; }, std::chrono::seconds(1));  // muted 1 s more
  ASSERT_TRUE(alive(pid)) << log_text();
  const std::uint32_t opens_while_muted = status.all().back().status.arcos_reopens;
  pioneer_line.muted = false;
  const auto unmuted = Clock::now();
  {
    auto up = status.wait_for([](const teamscan_msg_RobotStatus& x) { return x.arcos_state == kArcosUp; }, std::chrono::seconds(5));
    ASSERT_TRUE(up.has_value()) << recent_states(status) << "\n" << log_text();
    const long long ms = ms_between(unmuted, up->arrival);
    std::printf("Pioneer answering again -> connected on teamscan/status: %lld ms\n", ms);
    EXPECT_LE(ms, 2000 + 200);
    EXPECT_EQ(up->status.arcos_reopens, opens_while_muted);  // recovered on the open port, no reopen
  }
  ASSERT_TRUE(notify.wait_for([](const std::string& m) { return has(m, "arcos connected") && has(m, "lms streaming"); },
                              std::chrono::seconds(5)))
      << log_text();
  const auto arcos_recovery_ms = std::chrono::duration_cast<std::chrono::milliseconds>(Clock::now() - unmuted).count();
  std::printf("Pioneer answering again -> connected: %lld ms (status period 200 ms)\n", static_cast<long long>(arcos_recovery_ms));

  // The scanner resets (0x91, then 0x90 at 9600 after its 2 s reset): the daemon brings it up again.
  (*lms_runner)->locked([&] { scanner.spontaneous_reset(now_monotonic()); });
  const auto reset_at = Clock::now();
  ASSERT_TRUE(notify.wait_for([](const std::string& m) { return has(m, "STATUS=") && !has(m, "lms streaming"); },
                              std::chrono::seconds(5)))
      << log_text();
  long after_reset = -1;
  ASSERT_TRUE(notify.wait_for([&](const std::string& m) {
    const long s = scans_in(m);
    if (s < 0 || !has(m, "lms streaming")) return false;
    if (after_reset < 0) after_reset = s;
    return s > after_reset + 5;
  }, std::chrono::seconds(15))) << log_text();
  const auto lms_recovery_ms = std::chrono::duration_cast<std::chrono::milliseconds>(Clock::now() - reset_at).count();
  std::printf("scanner reset (2 s power-on delay) -> streaming again: %lld ms\n", static_cast<long long>(lms_recovery_ms));

  // Resident memory of the running daemon (with Cyclone DDS): a figure for the report, not asserted.
  {
    std::ifstream st("/proc/" + std::to_string(pid) + "/status");
    for (std::string line; std::getline(st, line);)
      if (line.rfind("VmRSS:", 0) == 0 || line.rfind("VmHWM:", 0) == 0) std::printf("daemon %s\n", line.c_str());
  }

  // SIGTERM: STOPPING=1, the laser stream stopped, the Pioneer closed, exit 0.
  ASSERT_EQ(::kill(pid, SIGTERM), 0);
  EXPECT_TRUE(notify.wait_for([](const std::string& m) { return m == "STOPPING=1"; }, std::chrono::seconds(3)));
  const int st = wait_exit(pid, std::chrono::seconds(5));
  ASSERT_TRUE(WIFEXITED(st)) << log_text();
  EXPECT_EQ(WEXITSTATUS(st), 0) << log_text();
  ::usleep(200'000);  // let the runners deliver the last bytes
  EXPECT_FALSE((*lms_runner)->locked([&] { return scanner.streaming(); }));
  EXPECT_NE((*arcos_runner)->locked([&] { return pioneer.state(); }), arcos::PioneerState::kServerOpen);
  (*arcos_runner)->stop();
  (*lms_runner)->stop();
  if (std::getenv("TEAMSCAN_DEBUG") != nullptr) {
    std::printf("%s\n", log_text().c_str());
    for (const auto& m : notify.log())
      if (m.rfind("STATUS=", 0) == 0) std::printf("%s\n", m.c_str());
  }
}

}  // namespace
}  // namespace teamscan
