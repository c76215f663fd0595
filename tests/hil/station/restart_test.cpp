// A ground station killed and restarted within the robots' scan-history window receives
// every scan it missed. A robot (DdsBridge in this process) publishes 50 scans to a running
// teamscan-groundstation, the station is SIGKILLed, 200 more scans are published while it is down, and
// the restarted station's session holds every seq 1..250 (transient-local history of depth 300).
#include <gtest/gtest.h>

#include <dds/dds.h>

#include <filesystem>
#include <set>
#include <string>
#include <thread>

#include "groundstation/station/scan_record.hpp"
#include "onboard/bridge/bridge.hpp"
#include "tests/hil/station/process.hpp"
#include "tests/support/test_domain.hpp"

namespace teamscan {
namespace {

using namespace std::chrono_literals;

std::vector<std::uint32_t> seqs_in(const std::string& session, std::uint32_t robot) {
  std::vector<std::uint32_t> out;
  station::ScanDecodeStats stats;
  std::string err;
  (void)station::read_scan_file(session + "/scans.bin", [&](const ScanPoints& s, const station::Receipt&) {
    if (s.robot_id == robot) out.push_back(s.seq);
  }, stats, err);
  return out;
}

bool wait_for_subscribers(const onboard::DdsBridge& b, std::uint32_t n, std::chrono::milliseconds timeout) {
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  while (b.scan_subscribers() < n) {
    if (std::chrono::steady_clock::now() > deadline) return false;
    std::this_thread::sleep_for(10ms);
  }
  return true;
}

TEST(StationRestart, EveryScanMissedWhileDownArrivesAfterRestart) {
  char tmpl[] = "/tmp/teamscan-restart-XXXXXX";
  const std::string root = ::mkdtemp(tmpl);
  const std::string first = root + "/first";
  const std::string second = root + "/second";
  constexpr std::uint32_t kRobot = 9;

  onboard::DdsBridgeOptions o;
  o.robot_id = kRobot;
  o.scan_history_depth = 300;
  o.domain_id = test::test_domain_id();
  auto bridge = onboard::DdsBridge::create(o);
  ASSERT_TRUE(bridge.ok()) << bridge.error().what;
  static ScanPoints scan;
  scan.robot_id = kRobot;
  scan.count = 401;
  auto publish = [&](std::uint32_t from, std::uint32_t to) {
    for (std::uint32_t seq = from; seq <= to; ++seq) {
      scan.seq = seq;
      scan.stamp = Time::from_ns(seq);
      for (std::uint16_t b = 0; b < 401; ++b) scan.points[b] = ScanPoint{static_cast<std::int32_t>(seq), b, 0, b, 0};
      ASSERT_TRUE(bridge->publish_scan(scan).ok());
      std::this_thread::sleep_for(2ms);
    }
  };

  {
    test::ChildProcess gs({TEAMSCAN_GROUNDSTATION, "--session-dir", first, "--domain", test::test_domain_arg()});
    ASSERT_TRUE(wait_for_subscribers(*bridge, 1, 15s));
    publish(1, 50);
    ASSERT_TRUE(bridge->wait_for_scan_acks(10s).ok());
    // An acknowledgement means the station's DDS reader holds the sample, not that its loop stored it
    // yet: the crash comes once the 50 are in its session (the restart below must recover the rest anyway).
    const auto stored_by = std::chrono::steady_clock::now() + 20s;
    while (seqs_in(first, kRobot).size() < 50 && std::chrono::steady_clock::now() < stored_by) std::this_thread::sleep_for(20ms);
    gs.signal(SIGKILL);  // a crash: no orderly shutdown
    ASSERT_TRUE(gs.wait(5s).has_value());
  }
  publish(51, 250);  // nobody is listening now (or only a dead, still-matched reader)

  test::ChildProcess gs({TEAMSCAN_GROUNDSTATION, "--session-dir", second, "--domain", test::test_domain_arg()});
  const auto deadline = std::chrono::steady_clock::now() + 30s;
  std::vector<std::uint32_t> got;
  while (std::chrono::steady_clock::now() < deadline) {
    got = seqs_in(second, kRobot);
    if (!got.empty() && got.back() >= 250) break;
    std::this_thread::sleep_for(100ms);
  }
  gs.signal(SIGTERM);
  const auto st = gs.wait(10s);
  ASSERT_TRUE(st.has_value());
  EXPECT_TRUE(WIFEXITED(*st) && WEXITSTATUS(*st) == 0);

  // The first session has everything acknowledged before the crash.
  const auto before = seqs_in(first, kRobot);
  ASSERT_EQ(before.size(), 50u);
  for (std::uint32_t i = 0; i < 50; ++i) EXPECT_EQ(before[i], i + 1);
  // The restarted one has the whole history: 1..250, in order, each once.
  got = seqs_in(second, kRobot);
  ASSERT_EQ(got.size(), 250u);
  for (std::uint32_t i = 0; i < 250; ++i) ASSERT_EQ(got[i], i + 1) << "at " << i;
  std::filesystem::remove_all(root);
}

}  // namespace
}  // namespace teamscan
