// The Station library in this process against robot processes (teamscan_dds_test_peer): a killed
// robot is reported lost within 3 s (liveliness, DDS_SYSTEMD.md 3.2) and flagged lost on teamscan/team;
// a mapping hook that throws loses no stored scan.
#include <gtest/gtest.h>

#include <dds/dds.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <thread>

#include "common/clock.hpp"
#include "groundstation/station/session_store.hpp"
#include "groundstation/station/station.hpp"
#include "onboard/bridge/bridge.hpp"
#include "dds/qos.hpp"
#include "teamscan.h"
#include "tests/hil/station/process.hpp"
#include "tests/support/dds_test_subscriber.hpp"
#include "tests/hil/station/station_fixture.hpp"
#include "tests/support/test_domain.hpp"

namespace teamscan::station {
namespace {

using namespace std::chrono_literals;

// The station's liveliness view alone must see a robot die (no silence timeout).
struct Fixture : test::StationFixture {
  Fixture() : test::StationFixture(options()) {}
  static StationOptions options() {
    StationOptions o;
    o.silence_timeout = 0s;
    return o;
  }
};

std::string slurp(const std::string& p) {
  std::ifstream in(p);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

TEST(StationLiveliness, KilledRobotIsLostWithinThreeSecondsAndFlaggedOnTeam) {
  Fixture f;
  dds_qos_t* q = dds::make_team_reader_qos();
  test::DdsTestSubscriber<teamscan_msg_TeamState> team_sub(&teamscan_msg_TeamState_desc, dds::kTopicTeam, q, 32,
                                                             test::test_domain_id());
  dds_delete_qos(q);
  test::ChildProcess robot({TEAMSCAN_TEST_PEER, "robot", "--robot", "12", "--rate", "50", "--scans", "0", "--domain", test::test_domain_arg()});
  test::ChildProcess other({TEAMSCAN_TEST_PEER, "robot", "--robot", "13", "--rate", "50", "--scans", "0", "--domain", test::test_domain_arg()});
  ASSERT_TRUE(f.run_until([&] { return f.station->robot(12).scans >= 10 && f.station->robot(13).scans >= 10; }, 15s));
  EXPECT_FALSE(f.station->robot(12).lost);

  robot.signal(SIGKILL);
  const Time killed = now_monotonic();
  ASSERT_TRUE(robot.wait(5s).has_value());
  ASSERT_TRUE(f.run_until([&] { return f.station->robot(12).lost; }, 6s)) << "robot 12 never marked lost";
  const Duration detection = now_monotonic() - killed;
  std::printf("killed robot marked lost after %.3f s\n", to_seconds(detection));
  EXPECT_LT(detection, 3s);
  // The other robot is untouched.
  EXPECT_TRUE(f.run_until([] { return false; }, 300ms) == false);
  EXPECT_FALSE(f.station->robot(13).lost);
  EXPECT_GT(f.station->robot(13).scans, f.station->robot(12).scans / 2);

  // teamscan/team now carries robot 12 as lost and robot 13 as alive.
  std::vector<teamscan_msg_TeamState> teams;
  bool seen_lost = false;
  f.run_until([&] {
    team_sub.take_available(teams);
    for (const auto& t : teams) {
      for (std::uint32_t i = 0; i < t.count; ++i) {
        if (t.members[i].robot_id == 12 && t.members[i].lost == 1) seen_lost = true;
      }
    }
    return seen_lost;
  }, 3s);
  ASSERT_TRUE(seen_lost);
  const teamscan_msg_TeamState& last = teams.back();
  ASSERT_EQ(last.count, 2);
  EXPECT_EQ(last.members[0].robot_id, 12u);
  EXPECT_EQ(last.members[1].robot_id, 13u);
  EXPECT_EQ(last.members[1].lost, 0);
  EXPECT_EQ(last.members[1].length_mm, 508);
  // The peer puts robot 13 at x = 13000 + seq % 1000 mm.
  EXPECT_GE(last.members[1].x_mm, 13000 - 50);
  EXPECT_LE(last.members[1].x_mm, 14000 + 50);

  f.store->sync();
  const std::string events = slurp(f.root + "/session/events.log");
  EXPECT_NE(events.find("robot 12 LOST"), std::string::npos) << events;
  EXPECT_EQ(events.find("robot 13 LOST"), std::string::npos) << events;
}

TEST(StationLiveliness, RestartedRobotComesBack) {
  Fixture f;
  {
    test::ChildProcess robot({TEAMSCAN_TEST_PEER, "robot", "--robot", "14", "--rate", "50", "--scans", "0", "--domain", test::test_domain_arg()});
    ASSERT_TRUE(f.run_until([&] { return f.station->robot(14).scans >= 5; }, 15s));
    robot.signal(SIGKILL);
    ASSERT_TRUE(robot.wait(5s).has_value());
    ASSERT_TRUE(f.run_until([&] { return f.station->robot(14).lost; }, 6s));
  }
  test::ChildProcess robot({TEAMSCAN_TEST_PEER, "robot", "--robot", "14", "--rate", "50", "--scans", "0", "--domain", test::test_domain_arg()});
  ASSERT_TRUE(f.run_until([&] { return !f.station->robot(14).lost; }, 15s));
  f.store->sync();
  EXPECT_NE(slurp(f.root + "/session/events.log").find("robot 14 back"), std::string::npos);
}

TEST(StationHooks, ThrowingFusionStageLosesNoScanOnDisk) {
  Fixture f;
  std::uint64_t hook_calls = 0;
  f.station->add_scan_hook([&](const ScanPoints& s, const Receipt&) {
    ++hook_calls;
    if (s.seq % 3 == 0) throw std::runtime_error("fusion stage failed");
  });
  test::ChildProcess robot({TEAMSCAN_TEST_PEER, "robot", "--robot", "15", "--rate", "200", "--scans", "120", "--domain", test::test_domain_arg()});
  ASSERT_TRUE(f.run_until([&] { return f.station->robot(15).scans >= 120; }, 20s));
  EXPECT_EQ(hook_calls, 120u);
  EXPECT_EQ(f.station->counters().hook_failures, 40u);
  std::vector<std::uint32_t> seqs;
  ScanDecodeStats stats;
  std::string err;
  ASSERT_TRUE(read_scan_file(f.root + "/session/scans.bin", [&](const ScanPoints& s, const Receipt& receipt) {
    if (s.robot_id == 15) seqs.push_back(s.seq);
    EXPECT_EQ(s.count, 401);
    EXPECT_GT(receipt.recv_realtime_ns, s.stamp.ns());  // received after it was stamped
  }, stats, err));
  ASSERT_EQ(seqs.size(), 120u);
  for (std::uint32_t i = 0; i < 120; ++i) EXPECT_EQ(seqs[i], i + 1);
  EXPECT_EQ(f.station->robot(15).scans_missing, 0u);
}

}  // namespace
}  // namespace teamscan::station
