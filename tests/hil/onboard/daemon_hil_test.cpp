// Hardware-in-loop test of teamscan-onboard: the real daemon process against an emulated Pioneer 3-AT
// and an emulated LMS-200 on pseudo-terminals (PtyRunner), observed through a NOTIFY_SOCKET harness
// (READY=1, STATUS=, WATCHDOG=1, STOPPING=1). Covers reaching the streaming state, unplugging and
// replugging each device while the other keeps running, a Pioneer that stops answering, a scanner
// reset, and a clean SIGTERM.
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
#include <regex>
#include <sstream>
#include <string>
#include <vector>

#include "common/clock.hpp"
#include "drivers/arcos/emulator.hpp"
#include "drivers/lms200/emulator.hpp"
#include "drivers/serial/pty_runner.hpp"
#include "onboard/dds/bridge.hpp"
#include "onboard/dds/qos.hpp"
#include "teamscan.h"
#include "tests/support/dds_test_subscriber.hpp"

namespace teamscan {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

struct TempDir {
  fs::path path;
  TempDir() {
    std::string tmpl = (fs::temp_directory_path() / "teamscan-onboard-XXXXXX").string();
    path = ::mkdtemp(tmpl.data());
  }
  ~TempDir() {
    std::error_code ec;
    fs::remove_all(path, ec);
  }
};

// Every beam 3 m (a wall all round).
class FlatRanges final : public lms200::RangeSource {
 public:
  void measure(const lms200::SweepTiming& sweep, std::span<lms200::BeamReading> beams) override {
    for (std::size_t i = 0; i < sweep.variant.beams() && i < beams.size(); ++i) beams[i] = {3000, 0, lms200::BeamInvalid::none};
  }
};

// A device that can stop answering: while muted it neither hears nor speaks (a Pioneer whose
// controller hangs, a cut cable), but keeps running.
class Muteable final : public serial::SerialEndpoint {
 public:
  explicit Muteable(serial::SerialEndpoint& inner) : inner_{inner} {}
  void on_rx(std::span<const std::uint8_t> bytes, Time now) override {
    if (!muted) inner_.on_rx(bytes, now);
  }
  void on_tick(Time now) override { inner_.on_tick(now); }
  std::size_t take_tx(std::span<std::uint8_t> out) override {
    const std::size_t n = inner_.take_tx(out);
    return muted ? 0 : n;
  }
  std::uint32_t baud() const override { return inner_.baud(); }
  Time next_deadline() const override { return inner_.next_deadline(); }
  std::atomic<bool> muted{false};

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

std::string daemon_path() {
  const char* b = std::getenv("TEAMSCAN_BINARY_DIR");
  return std::string(b != nullptr ? b : ".") + "/onboard/daemon/teamscan-onboard";
}

std::string source_dir() {
  const char* d = std::getenv("TEAMSCAN_SOURCE_DIR");
  return d != nullptr ? d : ".";
}

pid_t spawn(const std::vector<std::string>& args, const std::vector<std::string>& env_add, const fs::path& log_file) {
  const pid_t pid = ::fork();
  if (pid != 0) return pid;
  const int fd = ::open(log_file.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  if (fd >= 0) {
    ::dup2(fd, 1);
    ::dup2(fd, 2);
  }
  for (const auto& e : env_add) ::putenv(const_cast<char*>(e.c_str()));
  std::vector<char*> argv;
  for (const auto& a : args) argv.push_back(const_cast<char*>(a.c_str()));
  argv.push_back(nullptr);
  ::execv(argv[0], argv.data());
  ::_exit(127);
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

std::string file_text(const fs::path& p) {
  std::ifstream in(p);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
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
  scanner.power_up(now_monotonic());

  auto arcos_runner = serial::PtyRunner::create(pioneer_line, serial::PtyRunnerOptions{.link_path = arcos_link.string()});
  ASSERT_TRUE(arcos_runner.ok()) << arcos_runner.error().what;
  auto lms_runner = serial::PtyRunner::create(scanner, serial::PtyRunnerOptions{.link_path = lms_link.string()});
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
  dds_qos_t* scan_qos = onboard::make_scan_reader_qos();
  test::DdsTestSubscriber<teamscan_msg_ScanPoints> scans_sub{&teamscan_msg_ScanPoints_desc, onboard::kTopicScan, scan_qos,
                                                             64, domain};
  dds_delete_qos(scan_qos);
  ASSERT_TRUE(scans_sub.ok());
  NotifySocket notify{dir.path / "notify.sock"};
  ASSERT_TRUE(notify.bound());
  const pid_t pid = spawn({daemon_path(), "--config", (dir.path / "onboard.toml").string()},
                          {"NOTIFY_SOCKET=" + (dir.path / "notify.sock").string(), "WATCHDOG_USEC=1000000"},
                          dir.path / "daemon.log");
  ASSERT_GT(pid, 0);
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

  // Unplug the LMS: the daemon keeps running and keeps the Pioneer; after the replug the scans resume.
  (*lms_runner)->unplug();
  ASSERT_TRUE(notify.wait_for([](const std::string& m) { return has(m, "lms closed") && has(m, "arcos connected"); },
                              std::chrono::seconds(5)))
      << log_text();
  ::usleep(700'000);  // at least one failed reopen attempt (every 500 ms)
  ASSERT_TRUE(alive(pid)) << log_text();
  ASSERT_TRUE((*lms_runner)->replug().ok());
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
  ASSERT_TRUE((*arcos_runner)->replug().ok());
  ASSERT_TRUE(notify.wait_for([](const std::string& m) { return has(m, "arcos connected") && has(m, "lms streaming"); },
                              std::chrono::seconds(10)))
      << log_text();

  // The Pioneer stops answering for 2.5 s: the client notices (no SIP for 1 s), the LMS streams on,
  // and after the Pioneer answers again it is connected again (the time is printed, not asserted:
  // no timed pass/fail tests on a shared machine; the wait is bounded at 5 s).
  pioneer_line.muted = true;
  ASSERT_TRUE(notify.wait_for([](const std::string& m) { return has(m, "STATUS=") && !has(m, "arcos connected"); },
                              std::chrono::seconds(5)))
      << log_text();
  ::usleep(1'500'000);
  ASSERT_TRUE(alive(pid)) << log_text();
  pioneer_line.muted = false;
  const auto unmuted = Clock::now();
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
