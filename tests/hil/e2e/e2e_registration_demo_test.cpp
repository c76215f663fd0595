// End to end with drifting odometry: 20 s of lap2-drift (both robots 0.25°/m, 2 % slip) through the full
// live system. The demo turns the registration on by itself (the scenario's robots drift), the station
// runs it live, and its corrected model is better than the odometry alone against the live world's
// truth (pose and point error), its best model agrees with offline `teamscan eval --registration` of the
// same scenario within the demo's tolerance, and every model the station wrote (best and the compared
// position) is identical, decision and position of every row, to its own fusion core replaying the
// session in arrival order (docs/demo.md "Registration"). And the loop back to the robots over DDS
// (docs/registration.md "Back on the robots"): each teamscan-onboard daemon takes its correction from
// teamscan/team (its status counts them, none refused), the scans it publishes say which one they carry,
// more corrections than matches reach it (the drift rates' extrapolation between matches), and the
// drifting robot's scans as it placed them are closer to the truth than its odometry. The pose graph as the
// station's back end (--pose-graph): its trajectories are the replay's, its poses better than odometry's.
#include <gtest/gtest.h>

#include <cmath>

#include "tests/hil/e2e/e2e_support.hpp"

namespace teamscan::e2e {
namespace {

TEST(E2eRegistrationDemo, DriftingLap2IsCorrectedLiveAndTheModelIsItsSessionReplayed) {
  const std::string dir =
      std::filesystem::temp_directory_path().string() + "/teamscan-e2e-registration-" + std::to_string(::getpid());
  const int rc = run_demo(dir, "--scenario lap2-drift --duration 20 --bringup 4 --method best --station-compare position --pose-graph");
  const std::string log = demo_log(dir);
  const std::string s = read_file(dir + "/summary.json");
  ASSERT_FALSE(s.empty()) << log;
  EXPECT_EQ(rc, 0) << log;
  EXPECT_EQ(json_value(s, "none_lost"), "true") << s;
  EXPECT_EQ(json_value(s, "clean_exit"), "true") << s;
  EXPECT_EQ(json_value(s, "agree"), "true") << log;

  // On by default for a drifting scenario; the station config has the section.
  const std::size_t reg = s.find("\"registration\": {\"enabled\"");
  ASSERT_NE(reg, std::string::npos) << s;
  EXPECT_EQ(json_value(s, "enabled", reg), "true") << s;
  EXPECT_NE(json_value(s, "why", reg).find("drift"), std::string::npos) << s;
  EXPECT_EQ(json_value(s, "error", reg), "\"\"") << s;
  EXPECT_NE(read_file(dir + "/config/groundstation.toml").find("[registration]"), std::string::npos);

  // It ran live: matches accepted, the session's points moved by the corrections.
  double accepted = 0;
  for (int id : {1, 2}) {
    const std::size_t r = s.find("{\"robot\": " + std::to_string(id) + ", \"matches\"", reg);
    ASSERT_NE(r, std::string::npos) << id << "\n" << s;
    accepted += json_number(s, "accepted", r);
  }
  EXPECT_GT(accepted, 10) << s;
  EXPECT_GT(json_number(s, "points_moved", reg), 0) << s;

  // The corrected model against the truth, better than the odometry alone (20 s of lap2-drift: odometry
  // p99 about 16 cm and 2°, corrected about 10 cm and 1.6°).
  auto stat = [&](const char* what, const char* q) { return json_number(s, q, s.find(std::string("\"") + what + "\":", reg)); };
  // Every scan of the run window with a truth sweep is measured (how many the starved feeder of a loaded
  // machine sent is e2e_demo_test's business).
  const double with_truth = json_number(s, "truth_matched", robot_entry(s, 1)) + json_number(s, "truth_matched", robot_entry(s, 2));
  EXPECT_GT(with_truth, 1000) << s;
  EXPECT_GE(json_number(s, "scans", reg), 0.99 * with_truth) << s;
  EXPECT_LT(stat("pose_m_corrected", "p50"), stat("pose_m_odometry", "p50")) << s;
  EXPECT_LT(stat("pose_m_corrected", "p99"), stat("pose_m_odometry", "p99")) << s;
  EXPECT_LT(stat("pose_deg_corrected", "p50"), stat("pose_deg_odometry", "p50")) << s;
  // Rotation p99 is robot 1's (the down-laser, few features: 0–4 of ~31 matches accepted in 20 s).
  EXPECT_LE(stat("pose_deg_corrected", "p99"), stat("pose_deg_odometry", "p99")) << s;
  EXPECT_LT(stat("point_m_corrected", "p50"), stat("point_m_odometry", "p50")) << s;
  EXPECT_LT(stat("point_m_corrected", "p99"), stat("point_m_odometry", "p99")) << s;

  // Back on the robots. Robot 2 (the side laser: most matches) gets a correction away from the identity
  // and applies it; the scans it published carry it, and as the robot placed them they are better than
  // its odometry (20 s: about 1.3 / 2.5 cm against 9 / 17 cm). Robot 1 (the down laser, few matches)
  // is held to refusing nothing.
  const std::size_t corr = s.find("\"robot_corrections\":");
  ASSERT_NE(corr, std::string::npos) << s;
  EXPECT_EQ(json_value(s, "error", corr), "\"\"") << s;
  for (int id : {1, 2}) {
    const std::size_t r = s.find("{\"robot\": " + std::to_string(id) + ", \"corrections_applied\"", corr);
    ASSERT_NE(r, std::string::npos) << id << "\n" << s;
    EXPECT_EQ(json_number(s, "corrections_rejected", r), 0) << id << "\n" << s;
  }
  const std::size_t r2 = s.find("{\"robot\": 2, \"corrections_applied\"", corr);
  const double accepted2 = json_number(s, "accepted", s.find("{\"robot\": 2, \"matches\"", reg));
  EXPECT_GT(json_number(s, "corrections_applied", r2), 0) << s;
  // A quarter of its stored scans at least (20 s: ~70 %; the first match waits for the first lap's map).
  EXPECT_GT(json_number(s, "scans_corrected", r2), 0.25 * json_number(s, "scans", r2)) << s;
  EXPECT_GT(json_number(s, "corrections_carried", r2), accepted2) << s;  // the extrapolation between matches too
  EXPECT_GT(std::abs(json_number(s, "last_x_mm", r2)) + std::abs(json_number(s, "last_y_mm", r2)), 20) << s;
  auto robot_stat = [&](const char* what, const char* q) { return json_number(s, q, s.find(std::string("\"") + what + "\":", r2)); };
  EXPECT_GT(robot_stat("pose_m_robot", "count"), 500) << s;
  EXPECT_LT(robot_stat("pose_m_robot", "p50"), robot_stat("pose_m_odometry", "p50")) << s;
  EXPECT_LT(robot_stat("pose_m_robot", "p99"), robot_stat("pose_m_odometry", "p99")) << s;
  EXPECT_LT(robot_stat("pose_deg_robot", "p50"), robot_stat("pose_deg_odometry", "p50")) << s;

  // The station's model (best, scored against the truth) agrees with offline `teamscan eval --registration`.
  const std::size_t sm = s.find("\"station_model\":");
  ASSERT_NE(sm, std::string::npos) << s;
  EXPECT_EQ(json_value(s, "within_tolerance", sm), "true") << log;
  EXPECT_GT(json_number(s, "da", sm), 95.0) << s;
  EXPECT_GT(json_number(s, "sa", sm), 99.5) << s;

  // The identity: every row of every model the station wrote, decided and placed as its own core does on
  // the session replayed in arrival order.
  const std::size_t by_method = s.find("\"station_vs_session_replay_by_method\":");
  ASSERT_NE(by_method, std::string::npos) << s;
  for (const char* m : {"best", "position"}) {
    const std::size_t at = s.find("{\"method\": \"" + std::string(m) + "\"", by_method);
    ASSERT_NE(at, std::string::npos) << m << "\n" << s;
    EXPECT_EQ(json_value(s, "identical", at), "true") << m << "\n" << log;
    EXPECT_EQ(json_number(s, "decisions_differ", at), 0) << m;
    EXPECT_EQ(json_number(s, "placed_differ", at), 0) << m;
    EXPECT_GT(json_number(s, "compared", at), 100000) << m;
    EXPECT_EQ(json_number(s, "compared", at), json_number(s, "model_points", at)) << m;
  }

  // The pose graph as the station's back end (--pose-graph): its robot<N>.graph.tum are those of the
  // back end fed the replay's releases, to the byte (part of `agree` above), and its poses beat the
  // odometry alone against the truth.
  EXPECT_NE(read_file(dir + "/config/groundstation.toml").find("[pose_graph]"), std::string::npos);
  const std::size_t graph = s.find("\"pose_graph\": {");
  ASSERT_NE(graph, std::string::npos) << s;
  EXPECT_EQ(json_number(s, "files", graph), 2) << s;
  EXPECT_EQ(json_number(s, "files_differ", graph), 0) << s;
  EXPECT_EQ(json_value(s, "error", graph), "\"\"") << s;
  EXPECT_GT(json_number(s, "nodes", graph), 100) << s;
  auto graph_stat = [&](const char* what, const char* q) { return json_number(s, q, s.find(std::string("\"") + what + "\":", graph)); };
  EXPECT_GE(graph_stat("pose_m", "count"), 0.99 * with_truth) << s;
  EXPECT_LT(graph_stat("pose_m", "p99"), stat("pose_m_odometry", "p99")) << s;
  EXPECT_LT(graph_stat("pose_deg", "p99"), stat("pose_deg_odometry", "p99")) << s;
  if (!HasFailure()) std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace teamscan::e2e
