// Hung-loop detection against the real teamscan-onboard ("a hung loop is detected"): the
// notify harness plays systemd (NOTIFY_SOCKET, WATCHDOG_USEC, WATCHDOG_PID) for the daemon running
// against emulated devices on ptys; once READY=1 and the periodic WATCHDOG=1 flow, the daemon is
// SIGSTOPped (its loop stops as a hung loop would, as systemd sees it) and the harness must notice the
// missing keep-alive within WATCHDOG_USEC (+ margin) and kill it as systemd does: SIGABRT (+ SIGCONT),
// then SIGKILL after TimeoutAbortSec. No test hook in the daemon: SIGSTOP is the hang.
#include <gtest/gtest.h>

#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "common/clock.hpp"
#include "drivers/arcos/emulator.hpp"
#include "drivers/lms200/emulator.hpp"
#include "drivers/serial/pty_runner.hpp"
#include "tests/support/notify_harness.hpp"
#include "tests/support/test_domain.hpp"

namespace teamscan {
namespace {

namespace fs = std::filesystem;
using namespace std::chrono_literals;

class FlatRanges final : public lms200::RangeSource {
 public:
  void measure(const lms200::SweepTiming& sweep, std::span<lms200::BeamReading> beams) override {
    for (std::size_t i = 0; i < sweep.variant.beams() && i < beams.size(); ++i) beams[i] = {2500, 0, lms200::BeamInvalid::none};
  }
};

std::string daemon_path() {
  const char* b = std::getenv("TEAMSCAN_BINARY_DIR");
  return std::string(b != nullptr ? b : ".") + "/onboard/daemon/teamscan-onboard";
}

// The emulated Pioneer + LMS-200 on ptys and a config for the daemon naming them.
struct Robot {
  fs::path dir;
  arcos::PioneerEmulator pioneer;
  FlatRanges ranges;
  lms200::LmsEmulator scanner{[] {
                                lms200::LmsEmulatorOptions o;
                                o.variant = LaserVariant{180, 100};
                                return o;
                              }(),
                              &ranges};
  std::unique_ptr<serial::PtyRunner> arcos_runner, lms_runner;
  fs::path config;

  Robot() {
    std::string tmpl = (fs::temp_directory_path() / "teamscan-wd-XXXXXX").string();
    dir = ::mkdtemp(tmpl.data());
    scanner.power_up(now_monotonic());
    auto a = serial::PtyRunner::create(pioneer, serial::PtyRunnerOptions{.link_path = (dir / "arcos").string()});
    auto l = serial::PtyRunner::create(scanner, serial::PtyRunnerOptions{.link_path = (dir / "lms").string()});
    if (a.ok()) arcos_runner = std::move(a.value());
    if (l.ok()) lms_runner = std::move(l.value());
    config = dir / "onboard.toml";
    std::ofstream(config) << "[robot]\nid = 7\n[arcos]\ndevice = \"" << (dir / "arcos").string() << "\"\nbaud = 9600\n"
                          << "[lms]\ndevice = \"" << (dir / "lms").string() << "\"\nbaud = 500000\nfov_deg = 180\n"
                          << "resolution_deg = 1\n[mount]\nx_m = 0.16\ny_m = 0\nz_m = 0.45\npitch_deg = 15\n"
                          << "[dds]\ndomain = " << test::test_domain_arg() << "\n";
  }
  bool start() { return arcos_runner && lms_runner && arcos_runner->start().ok() && lms_runner->start().ok(); }
  ~Robot() {
    if (arcos_runner) arcos_runner->stop();
    if (lms_runner) lms_runner->stop();
    std::error_code ec;
    fs::remove_all(dir, ec);
  }
};

// The largest gap between consecutive pings.
Duration max_gap(const std::vector<Duration>& t) {
  Duration g{};
  for (std::size_t i = 1; i < t.size(); ++i) g = std::max(g, t[i] - t[i - 1]);
  return g;
}

// Runs the daemon until READY and three periodic pings; returns false (with a message) otherwise.
::testing::AssertionResult bring_up(test::NotifyHarness& h, Robot& robot, Duration watchdog) {
  if (!robot.start()) return ::testing::AssertionFailure() << "emulators did not start";
  if (h.spawn({daemon_path(), "--config", robot.config.string()}, watchdog) <= 0)
    return ::testing::AssertionFailure() << "spawn failed";
  // READY=1 only once the Pioneer is connected and the LMS streams (bring-up incl. the 500 kBd switch).
  if (!h.wait_for("READY", 30s)) return ::testing::AssertionFailure() << "no READY=1 within 30 s";
  h.collect_for(watchdog * 2);
  const auto pings = h.times_of("WATCHDOG");
  if (pings.size() < 3) return ::testing::AssertionFailure() << pings.size() << " pings in 2 watchdog periods";
  // Pinged at half of WATCHDOG_USEC from the loop; a ping later than the timeout would be a miss.
  if (max_gap(pings) > watchdog) return ::testing::AssertionFailure() << "ping gap above the watchdog timeout";
  if (h.foreign_messages() != 0) return ::testing::AssertionFailure() << "notifications from another pid";
  return ::testing::AssertionSuccess();
}

constexpr Duration kWatchdog = 1s;
// Scheduling margin for noticing the miss on a loaded 2-core machine (the harness polls every 10 ms).
constexpr Duration kMargin = 500ms;

TEST(OnboardWatchdogHil, StoppedLoopIsDetectedAndAbortedLikeSystemd) {
  Robot robot;
  test::NotifyHarness h;
  ASSERT_TRUE(bring_up(h, robot, kWatchdog));
  const auto last_ping_before = h.times_of("WATCHDOG").back();

  ASSERT_EQ(::kill(h.pid(), SIGSTOP), 0);
  const auto missed = h.supervise(5 * kWatchdog);
  ASSERT_TRUE(missed.has_value()) << "the stopped daemon kept the watchdog fed";
  const auto last_ping = h.times_of("WATCHDOG").back();
  std::printf("SIGSTOP -> watchdog miss seen %lld ms after the last ping (WATCHDOG_USEC %lld ms)\n",
              static_cast<long long>((*missed - last_ping).count() / 1'000'000), static_cast<long long>(kWatchdog.count() / 1'000'000));
  // No ping from the stopped process: the miss is seen one watchdog timeout after the last ping.
  EXPECT_GE(*missed - last_ping, kWatchdog);
  EXPECT_LE(*missed - last_ping, kWatchdog + kMargin) << "last ping before SIGSTOP at " << last_ping_before.count() << " ns";

  // systemd: SIGABRT (sent by supervise), SIGCONT, and SIGKILL only if TimeoutAbortSec passes.
  const auto kill = h.finish_watchdog_kill(3s);
  ASSERT_TRUE(kill.has_value());
  EXPECT_FALSE(kill->escalated_to_sigkill);
  ASSERT_TRUE(WIFSIGNALED(kill->wait_status));
  EXPECT_EQ(WTERMSIG(kill->wait_status), SIGABRT);  // the daemon does not catch SIGABRT: a core for the post-mortem
}

TEST(OnboardWatchdogHil, DaemonThatDoesNotDieOnAbortIsKilled) {
  Robot robot;
  test::NotifyHarness h;
  ASSERT_TRUE(bring_up(h, robot, kWatchdog));
  ASSERT_EQ(::kill(h.pid(), SIGSTOP), 0);
  const auto missed = h.supervise(5 * kWatchdog);
  ASSERT_TRUE(missed.has_value());
  EXPECT_LE(*missed - h.times_of("WATCHDOG").back(), kWatchdog + kMargin);
  // Without SIGCONT the stopped process cannot act on SIGABRT (it stays pending): after the abort
  // timeout the service manager's SIGKILL, which no stopped process can ignore, ends it.
  const auto kill = h.finish_watchdog_kill(500ms, /*send_sigcont=*/false);
  ASSERT_TRUE(kill.has_value());
  EXPECT_TRUE(kill->escalated_to_sigkill);
  ASSERT_TRUE(WIFSIGNALED(kill->wait_status));
  EXPECT_EQ(WTERMSIG(kill->wait_status), SIGKILL);
}

}  // namespace
}  // namespace teamscan
