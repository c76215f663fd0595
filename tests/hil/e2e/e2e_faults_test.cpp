// Live faults through the full system (teamscan demo's fault options, docs/demo.md "Faults"):
//  - the ground station is SIGKILLed at t = 3 s and restarted 2 s later: no scan is lost and none is
//    stored twice (the robots' DDS history and rings cover the gap);
//  - robot 2's laser pty is unplugged at t = 4 s for 2 s: its daemon reopens it, and the station's
//    status.csv shows the laser state leave streaming and come back;
//  - robot 2's daemon is SIGKILLed at t = 10 s: the station marks it lost within 3 s, and robot 1's
//    published scans flag the points its direction filter ran on the stale teammate (kTeamStale);
//  - faults keep the decisions: the station's model (`best`) and its decisions at release remove
//    ≥ 99 % of the ghosts and keep ≥ 99.5 % of the static points (the killed robot is held where its
//    firmware stopped it, with an uncertainty that does not take the walls around it), and the demo's
//    exit status is its verdict (a station killed by the fault is not a process that died).
#include <gtest/gtest.h>

#include "tests/hil/e2e/e2e_support.hpp"

namespace teamscan::e2e {
namespace {

TEST(E2eFaults, StationRestartLaserUnplugAndDaemonKill) {
  const std::string dir = std::filesystem::temp_directory_path().string() + "/teamscan-e2e-faults-" + std::to_string(::getpid());
  const int rc = run_demo(dir,
                 "--scenario lap2 --duration 16 --bringup 4 --method direction --kill-station-at 3 --station-down 2 "
                 "--unplug-robot 2 --unplug-at 4 --unplug-for 2 --kill-robot 2 --kill-robot-at 10");
  const std::string log = demo_log(dir);
  const std::string s = read_file(dir + "/summary.json");
  ASSERT_FALSE(s.empty()) << log;

  // Station restart: robot 1 lost nothing; its stored scans include the re-delivered history.
  const std::size_t r1 = robot_entry(s, 1);
  ASSERT_NE(r1, std::string::npos) << s;
  EXPECT_EQ(json_number(s, "missing", r1), 0) << s;
  EXPECT_GE(json_number(s, "seq_last", r1), json_number(s, "last_status_published", r1)) << s;
  // The restarted station got the history again and knew it held those scans (store and forward,
  // docs/onboard.md "The ring"): each stored once.
  EXPECT_EQ(json_number(s, "duplicates", r1), 0) << s;
  // Robot 2 lost nothing before it was killed either.
  const std::size_t r2 = robot_entry(s, 2);
  ASSERT_NE(r2, std::string::npos) << s;
  EXPECT_EQ(json_number(s, "missing", r2), 0) << s;

  // Unplug: the laser state went down (0) and came back to the state it had before.
  const std::string states = json_value(s, "lms_states", s.find("\"unplug\""));
  ASSERT_GE(states.size(), 2u) << s;
  const std::string inner = states.substr(1, states.size() - 2);
  const std::string first = inner.substr(0, inner.find(','));
  EXPECT_NE(first, "0") << s;
  EXPECT_NE(inner.find(", 0,"), std::string::npos) << "laser state never went down: " << states;
  EXPECT_EQ(inner.substr(inner.rfind(' ') + 1), first) << "laser did not come back: " << states;
  EXPECT_GE(json_number(s, "lms_reopens", s.find("\"unplug\"")), 1) << s;

  // Daemon kill: lost within 3 s, and robot 1's filter flagged points on the stale teammate.
  const std::size_t k = s.find("\"kill_robot\"");
  ASSERT_NE(k, std::string::npos) << s;
  const double lost_after = json_number(s, "lost_after_s", k);
  EXPECT_GE(lost_after, 0.0) << "never marked lost\n" << s;
  EXPECT_LE(lost_after, 3.0) << s;
  EXPECT_GT(json_number(s, "others_scans_after", k), 0) << s;
  EXPECT_GT(json_number(s, "others_team_stale_points_after", k), 0) << s;

  // Every process stopped: exit 0, or SIGKILL for the two the test killed.
  EXPECT_EQ(json_value(s, "clean_exit"), "true") << s;

  // Faults keep the decisions (what the fault runs must show).
  const std::size_t sm = s.find("\"station_model\":");
  ASSERT_NE(sm, std::string::npos) << s;
  EXPECT_GE(json_number(s, "da", sm), 99.0) << log;
  EXPECT_GE(json_number(s, "sa", sm), 99.5) << log;
  EXPECT_GE(json_number(s, "live_da", sm), 99.0) << log;
  EXPECT_GE(json_number(s, "live_sa", sm), 99.5) << log;
  EXPECT_EQ(json_value(s, "agree"), "true") << log;
  EXPECT_EQ(json_value(s, "none_lost"), "true") << log;
  EXPECT_EQ(rc, 0) << "the demo's exit status is its verdict\n" << log;
  if (!HasFailure()) std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace teamscan::e2e
