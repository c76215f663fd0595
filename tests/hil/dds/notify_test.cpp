// sd_notify protocol of our daemons, with the harness standing in for systemd (DDS_SYSTEMD.md 5.2):
// the tiny daemon (notify_test_daemon) and the real teamscan-groundstation.
#include <gtest/gtest.h>

#include <sys/wait.h>

#include <algorithm>
#include <csignal>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>

#include "tests/support/notify_harness.hpp"
#include "tests/support/test_domain.hpp"

namespace teamscan::test {
namespace {

using namespace std::chrono_literals;

Duration max_gap(const std::vector<Duration>& t) {
  Duration g{0};
  for (std::size_t i = 1; i < t.size(); ++i) g = std::max(g, t[i] - t[i - 1]);
  return g;
}

TEST(NotifyHarness, ReadyPeriodicWatchdogAndStoppingOnSigterm) {
  NotifyHarness h;
  const Duration wd = 400ms;
  ASSERT_GT(h.spawn({TEAMSCAN_NOTIFY_DAEMON}, wd), 0);
  const auto ready = h.wait_for("READY", 5s);
  ASSERT_TRUE(ready.has_value());
  EXPECT_EQ(ready->value, "1");
  EXPECT_FALSE(h.supervise(2500ms).has_value()) << "the daemon stopped pinging";
  h.signal(SIGTERM);
  const auto st = h.wait_exit(5s);
  ASSERT_TRUE(st.has_value());
  EXPECT_TRUE(WIFEXITED(*st));
  EXPECT_EQ(WEXITSTATUS(*st), 0);
  EXPECT_TRUE(h.wait_for("STOPPING", 1s).has_value());
  const auto pings = h.times_of("WATCHDOG");
  EXPECT_GE(pings.size(), 5u);
  EXPECT_LE(max_gap(pings), wd);
  ASSERT_FALSE(h.times_of("STATUS").empty());
  EXPECT_LE(h.times_of("STATUS").front(), ready->since_spawn);
  EXPECT_EQ(h.foreign_messages(), 0u);
}

TEST(NotifyHarness, HungLoopIsDetectedAndTheDaemonAborted) {
  NotifyHarness h;
  const Duration wd = 300ms;
  ASSERT_GT(h.spawn({TEAMSCAN_NOTIFY_DAEMON, "--hang-after-ms", "600"}, wd), 0);
  ASSERT_TRUE(h.wait_for("READY", 5s).has_value());
  const auto missed = h.supervise(5s);
  ASSERT_TRUE(missed.has_value());
  // The last ping came before the hang (<= 600 ms + one period); the miss is seen one timeout later.
  EXPECT_GE(*missed, 600ms);
  EXPECT_LE(*missed, 600ms + wd + wd + 200ms);
  const auto st = h.wait_exit(5s);
  ASSERT_TRUE(st.has_value());
  EXPECT_TRUE(WIFSIGNALED(*st));
  EXPECT_EQ(WTERMSIG(*st), SIGABRT);
}

TEST(NotifyHarness, WatchdogForAnotherPidIsIgnoredByTheDaemon) {
  NotifyHarness h;
  // WATCHDOG_PID names another process (sd_watchdog_enabled returns 0): the daemon must not ping.
  ASSERT_GT(h.spawn({"/usr/bin/env", "WATCHDOG_PID=1", TEAMSCAN_NOTIFY_DAEMON}, 300ms), 0);
  h.collect_for(1s);
  EXPECT_TRUE(h.times_of("WATCHDOG").empty());
}

TEST(NotifyHarness, GroundStationSpeaksTheProtocol) {
  char tmpl[] = "/tmp/teamscan-gs-notify-XXXXXX";
  const std::string dir = ::mkdtemp(tmpl);
  NotifyHarness h;
  const Duration wd = 1s;
  ASSERT_GT(h.spawn({TEAMSCAN_GROUNDSTATION, "--session-dir", dir + "/session", "--domain", test_domain_arg()}, wd), 0);
  const auto ready = h.wait_for("READY", 15s);
  ASSERT_TRUE(ready.has_value());
  EXPECT_FALSE(h.supervise(3s).has_value());
  h.signal(SIGTERM);
  const auto st = h.wait_exit(10s);
  ASSERT_TRUE(st.has_value());
  EXPECT_TRUE(WIFEXITED(*st) && WEXITSTATUS(*st) == 0);
  EXPECT_TRUE(h.wait_for("STOPPING", 1s).has_value());
  const auto pings = h.times_of("WATCHDOG");
  EXPECT_GE(pings.size(), 5u);
  EXPECT_LE(max_gap(pings), wd);
  EXPECT_TRUE(std::filesystem::exists(dir + "/session/events.log"));
  std::filesystem::remove_all(dir);
}

// Reading the session folder back at the start (a restart on it) and, with the pose graph, the
// shutdown's work (the catch-up, the graph's last optimisation, the final model on its poses, the writes)
// ask systemd for more time at each step (EXTEND_TIMEOUT_USEC), so a long session is not cut short by
// TimeoutStartSec or TimeoutStopSec, and say what they are doing (STATUS).
TEST(NotifyHarness, GroundStationAsksForTimeAsItReadsItsSessionAndFinishesItsModel) {
  char tmpl[] = "/tmp/teamscan-gs-notify-XXXXXX";
  const std::string dir = ::mkdtemp(tmpl);
  {
    std::ofstream cfg(dir + "/groundstation.toml");
    cfg << "[pose_graph]\n";
  }
  NotifyHarness h;
  ASSERT_GT(h.spawn({TEAMSCAN_GROUNDSTATION, "--config", dir + "/groundstation.toml", "--session-dir", dir + "/session", "--domain",
                     test_domain_arg()},
                    1s),
            0);
  const auto ready = h.wait_for("READY", 15s);
  ASSERT_TRUE(ready.has_value());
  bool start_extended = false, start_step = false;
  for (const NotifyMessage& x : h.messages()) {
    if (x.since_spawn > ready->since_spawn) break;
    if (x.key == "EXTEND_TIMEOUT_USEC" && x.value == "30000000") start_extended = true;
    if (x.key == "STATUS" && x.value == "starting: reading the session folder back into the fusion core") start_step = true;
  }
  EXPECT_TRUE(start_extended) << "no EXTEND_TIMEOUT_USEC before READY";
  EXPECT_TRUE(start_step);
  h.signal(SIGTERM);
  const auto st = h.wait_exit(20s);
  ASSERT_TRUE(st.has_value());
  EXPECT_TRUE(WIFEXITED(*st) && WEXITSTATUS(*st) == 0);
  h.collect_for(500ms);
  const auto& m = h.messages();
  const auto stopping = std::find_if(m.begin(), m.end(), [](const NotifyMessage& x) { return x.key == "STOPPING"; });
  ASSERT_NE(stopping, m.end());
  std::size_t extensions = 0;
  bool graph_step = false;
  for (auto it = stopping; it != m.end(); ++it) {
    if (it->key == "EXTEND_TIMEOUT_USEC") {
      ++extensions;
      EXPECT_EQ(it->value, "30000000");
    }
    if (it->key == "STATUS" && it->value == "stopping: the model on the pose graph's poses") graph_step = true;
  }
  EXPECT_GE(extensions, 5u) << "one per step: the held scans, the model, the graph, the model on its poses, its write";
  EXPECT_TRUE(graph_step);
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace teamscan::test
