// Scoring pieces of the demo (tools/demo/scoring.hpp): the station's model against labelled points,
// the latency files by name, quantiles, and the kill report from a session the station's store wrote.
#include <gtest/gtest.h>

#include <cstdio>
#include <cstdlib>

#include "common/dataset/pcd.hpp"
#include "common/point_flags.hpp"
#include "groundstation/station/config.hpp"
#include "groundstation/station/fusion.hpp"
#include "groundstation/station/session_store.hpp"
#include "tests/unit/demo/temp_dir.hpp"
#include "groundstation/mapping/filter.hpp"
#include "tools/demo/demo.hpp"
#include "tools/demo/scoring.hpp"
#include "teamscan.h"

namespace teamscan::demo {
namespace {

void write_file(const std::string& path, const char* text) {
  std::FILE* f = std::fopen(path.c_str(), "w");
  ASSERT_NE(f, nullptr);
  std::fputs(text, f);
  std::fclose(f);
}

LabelledPoint point(std::uint8_t robot, std::uint16_t beam, PointClass label) {
  LabelledPoint p;
  p.robot = robot;
  p.beam = beam;
  p.label = label;
  p.hit_robot = label == PointClass::robot ? 2 : 0;
  return p;
}

TEST(DemoScoring, StationModelMatchedByRobotSeqBeam) {
  test::TempDir dir;
  // The station's model: robot 1 seq 40 beams 0..2; beam 1 (a ghost) removed by the model, beam 2
  // (a wall) removed only by the live decision.
  PcdCloud c;
  c.fields = {"x", "y", "z", "robot", "scan", "beam", "keep", "live_keep"};
  c.columns.assign(c.fields.size(), {});
  const double rows[3][8] = {{0, 0, 0, 1, 40, 0, 1, 1}, {0, 0, 0, 1, 40, 1, 0, 0}, {0, 0, 0, 1, 40, 2, 1, 0}};
  for (const auto& r : rows) {
    for (std::size_t f = 0; f < 8; ++f) c.columns[f].push_back(r[f]);
    c.xyz.insert(c.xyz.end(), {0.f, 0.f, 0.f});
  }
  c.width = 3;
  c.height = 1;
  std::vector<PcdField> layout = {{"x"}, {"y"}, {"z"}, {"robot", 1, 'U'}, {"scan", 4, 'U'}, {"beam", 2, 'U'},
                                  {"keep", 1, 'U'}, {"live_keep", 1, 'U'}};
  ASSERT_TRUE(write_pcd(dir.path() + "/fused_all.pcd", c, layout).ok());

  const std::vector<LabelledPoint> pts = {point(1, 0, PointClass::wall), point(1, 1, PointClass::robot),
                                          point(1, 2, PointClass::wall), point(1, 3, PointClass::wall)};
  const std::vector<std::uint32_t> seq = {40, 40, 40, 40};  // beam 3 is not in the model
  const StationScore s = score_station_model(dir.path() + "/fused_all.pcd", pts, seq);
  ASSERT_TRUE(s.present) << s.error;
  EXPECT_EQ(s.model_points, 3u);
  EXPECT_EQ(s.matched, 3u);
  EXPECT_EQ(s.unmatched, 1u);
  EXPECT_EQ(s.removed, (std::vector<std::uint8_t>{0, 1, 0, 0}));
  EXPECT_DOUBLE_EQ(s.model.da, 100.0);  // the one ghost removed
  EXPECT_DOUBLE_EQ(s.model.sa, 100.0);  // no wall removed
  EXPECT_DOUBLE_EQ(s.live.da, 100.0);
  EXPECT_NEAR(s.live.sa, 50.0, 1e-9);   // one of two matched walls removed live

  const StationScore wrong_seq = score_station_model(dir.path() + "/fused_all.pcd", pts, {41, 41, 41, 41});
  EXPECT_FALSE(wrong_seq.present);
  EXPECT_EQ(wrong_seq.unmatched, 4u);
  EXPECT_FALSE(score_station_model(dir.path() + "/none.pcd", pts, seq).error.empty());
}

// The identity check (station model vs `teamscan eval` of its session) never passes on what it could
// not read: a missing station config or an empty session is an error, not "identical".
TEST(DemoScoring, SessionEvalCheckFailsOnWhatItCannotRead) {
  test::TempDir dir;
  const SessionEvalCheck no_config =
      check_station_against_session_eval(dir.path() + "/session", dir.path() + "/none.toml", {}, {});
  EXPECT_FALSE(no_config.identical);
  EXPECT_NE(no_config.error.find("cannot read the station config"), std::string::npos) << no_config.error;

  write_file(dir.path() + "/groundstation.toml", "[station]\nsession_root = \"/tmp\"\n[fusion]\nenabled = true\nmethod = \"best\"\n");
  const SessionEvalCheck no_session =
      check_station_against_session_eval(dir.path() + "/session", dir.path() + "/groundstation.toml", {}, {});
  EXPECT_FALSE(no_session.identical);
  EXPECT_FALSE(no_session.error.empty());
  EXPECT_EQ(no_session.method, "best");
  EXPECT_TRUE(no_session.primary);

  // Every model the station wrote, its method first: none of them passes on an empty session.
  write_file(dir.path() + "/groundstation.toml",
             "[station]\nsession_root = \"/tmp\"\n[fusion]\nenabled = true\nmethod = \"best\"\ncompare_methods = [\"position\"]\n");
  const std::vector<SessionEvalCheck> all =
      check_station_models_against_session_eval(dir.path() + "/session", dir.path() + "/groundstation.toml", {}, {});
  ASSERT_EQ(all.size(), 2u);
  EXPECT_EQ(all[0].method, "best");
  EXPECT_TRUE(all[0].primary);
  EXPECT_EQ(all[1].method, "position");
  EXPECT_FALSE(all[1].primary);
  for (const SessionEvalCheck& c : all) EXPECT_FALSE(c.identical);
  const std::vector<SessionEvalCheck> none =
      check_station_models_against_session_eval(dir.path() + "/session", dir.path() + "/none.toml", {}, {});
  ASSERT_EQ(none.size(), 1u);
  EXPECT_FALSE(none[0].identical);
}

TEST(DemoOptions, StationCompareMethods) {
  DemoOptions a;
  a.station_method = "best";
  std::vector<std::string> paper = mapping::known_methods();
  EXPECT_EQ(station_compare_methods(a), paper);  // "paper": the paper's five, best is the station's own
  a.station_method = "position";
  std::vector<std::string> expected = mapping::known_methods();
  std::erase(expected, std::string("position"));
  expected.push_back("best");
  EXPECT_EQ(station_compare_methods(a), expected);
  a.station_compare = "none";
  EXPECT_TRUE(station_compare_methods(a).empty());
  a.station_compare = "tracked,,freespace";
  EXPECT_EQ(station_compare_methods(a), (std::vector<std::string>{"tracked", "freespace"}));
}

TEST(DemoScoring, LatencyHistogramSummaries) {
  test::TempDir dir;
  write_file(dir.path() + "/latency.csv",
             "# scan -> stored\ncount,10\np50,1.5\np90,2\np99,3\nmax,4\n# scan -> fused map\ncount,9\np50,15\np99,30\nmax,x\n");
  const auto s = read_latency_csv(dir.path() + "/latency.csv");
  ASSERT_EQ(s.size(), 2u);
  EXPECT_DOUBLE_EQ(s[0].count, 10);
  EXPECT_DOUBLE_EQ(s[0].p50_ms, 1.5);
  EXPECT_DOUBLE_EQ(s[0].p90_ms, 2);
  EXPECT_DOUBLE_EQ(s[0].p99_ms, 3);
  EXPECT_DOUBLE_EQ(s[0].max_ms, 4);
  EXPECT_DOUBLE_EQ(s[1].p99_ms, 30);
  EXPECT_DOUBLE_EQ(s[1].max_ms, 0);  // "x" is not a number
  EXPECT_TRUE(read_latency_csv(dir.path() + "/none.csv").empty());
}

TEST(DemoScoring, FusedLatencyLogInTheWindowByColumnName) {
  test::TempDir dir;
  write_file(dir.path() + "/fused_latency.csv",
             "robot,seq,stamp_ns,received_ns,fused_ns\n1,1,1000000000,1001000000,1005000000\n"
             "1,2,2000000000,2001000000,2002000000\n1,3,9000000000,9001000000,9100000000\nbad,row\n");
  const auto v = read_fused_latency_log(dir.path() + "/fused_latency.csv", 1'000'000'000, 5'000'000'000);
  EXPECT_EQ(v, (std::vector<double>{2.0, 5.0}));  // sorted; the third scan is outside the window
}

TEST(DemoScoring, SortedQuantiles) {
  EXPECT_EQ(sorted_pct({}, 0.5), 0.0);
  const std::vector<double> v = {1, 2, 3, 4};
  EXPECT_EQ(sorted_pct(v, 0.0), 1);
  EXPECT_EQ(sorted_pct(v, 0.5), 3);
  EXPECT_EQ(sorted_pct(v, 0.99), 4);
  EXPECT_EQ(sorted_pct(v, 1.0), 4);
}

TEST(DemoScoring, KillReportFromTheSession) {
  test::TempDir dir;
  const std::string session = dir.path() + "/session";
  const std::int64_t kill = 10'000'000'000;
  {
    auto store = station::SessionStore::open(session);
    ASSERT_TRUE(store.ok());
    store->log_event(Time::from_ns(kill - 5'000'000'000), "robot 2 LOST: earlier, before the kill");
    store->log_event(Time::from_ns(kill + 2'500'000'000), "robot 2 LOST: DDS liveliness lapsed");
    ScanPoints s{};
    s.robot_id = 1;
    s.count = 2;
    s.points[0].flags = kPointTeamStale;
    s.points[1].flags = kPointDirectionFiltered;
    s.stamp = Time::from_ns(kill - 1);  // before: one stale point counted before
    store->append_scan(s, station::Receipt{});
    s.stamp = Time::from_ns(kill + 1'500'000'000);  // after (from 1 s after the kill)
    store->append_scan(s, station::Receipt{});
    s.robot_id = 2;  // the killed robot's own scans do not count
    store->append_scan(s, station::Receipt{});
    store->sync();
  }
  const KillReport k = kill_report(session, 2, kill);
  EXPECT_NEAR(k.lost_after_s, 2.5, 1e-9);
  EXPECT_EQ(k.others_scans_after, 1u);
  EXPECT_EQ(k.team_stale_before, 1u);
  EXPECT_EQ(k.team_stale_after, 1u);
  EXPECT_EQ(k.direction_filtered_after, 1u);
  EXPECT_EQ(kill_report(session, 3, kill).lost_after_s, -1);
}

// A small session as the station stores it: two robots driving along a corridor (poses at 10 Hz, scans
// at 20 Hz with points on both walls), received in stamp order.
void write_corridor_session(const std::string& session) {
  auto store = station::SessionStore::open(session);
  ASSERT_TRUE(store.ok());
  const std::int64_t t0 = 1'000'000'000'000;
  for (int k = 0; k <= 60; ++k) {
    const std::int64_t t = t0 + static_cast<std::int64_t>(k) * 50'000'000;
    for (std::uint32_t id = 1; id <= 2; ++id) {
      const double x = 0.015 * k + (id == 2 ? 1.5 : 0.0);
      const station::ReceiveTime at{Time::from_ns(t + 5'000'000), Time::from_ns(t + 5'000'000)};
      if (k % 2 == 0) {
        teamscan_msg_RobotPose p{};
        p.robot_id = id;
        p.seq = static_cast<std::uint32_t>(k / 2);
        p.stamp_ns = t;
        p.x_mm = static_cast<std::int32_t>(x * 1000);
        p.vx_mmps = 300;
        store->append_pose(p, at);
      }
      ScanPoints s{};
      const station::Receipt receipt{t + 6'000'000, t + 6'000'000, 0};
      s.robot_id = id;
      s.seq = static_cast<std::uint32_t>(k);
      s.stamp = Time::from_ns(t);
      s.origin_x_mm = static_cast<std::int32_t>(x * 1000);
      s.origin_z_mm = 400;
      s.count = 20;
      for (std::uint16_t b = 0; b < 20; ++b) {
        s.points[b].x_mm = static_cast<std::int32_t>((x + 0.1 * (b % 10)) * 1000);
        s.points[b].y_mm = b < 10 ? -1200 : 1200;
        s.points[b].z_mm = 300 + 20 * b;
        s.points[b].beam = b;
      }
      store->append_scan(s, receipt);
    }
  }
  store->sync();
}

// The station's model of `session` under the config `cfg` (read into `g`), as its shutdown writes it:
// its fusion stage rebuilt from the session (its restart path) and flushed; with the pose graph, the
// graph's trajectories and every core fed the session again on its poses; then written.
void write_station_model(const std::string& cfg, const std::string& session, station::GroundStationConfig& g) {
  station::ConfigError e;
  g = station::GroundStationConfig{};
  ASSERT_TRUE(station::load_groundstation_config(cfg, g, e)) << e.message;
  auto stage = station::FusionStage::create(g.fusion, session);
  ASSERT_TRUE(stage.ok());
  ASSERT_TRUE(stage.value()->replay_session(session).ok());
  stage.value()->flush();
  if (g.fusion.pose_graph) {
    ASSERT_TRUE(stage.value()->write_graph_trajectories().ok());
    ASSERT_TRUE(stage.value()->rebuild_on_graph().ok());
  }
  ASSERT_TRUE(stage.value()->write_model().ok());
}

// The station's models against its own core replaying the session in arrival order: the model the
// station's FusionStage wrote is identical, row by row (decision and position), for its method and a
// compared one; a flipped decision and a moved point are found and counted.
TEST(DemoScoring, StationModelsAgainstTheReplayInArrivalOrder) {
  test::TempDir dir;
  const std::string session = dir.path() + "/session";
  write_corridor_session(session);
  const std::string cfg = dir.path() + "/groundstation.toml";
  write_file(cfg, "[station]\nsession_root = \"/tmp\"\n[fusion]\nenabled = true\nmethod = \"position\"\nwrite_all_points = true\n"
                  "compare_methods = [\"direction\"]\n[pose_graph]\nenabled = false\n[view]\nlisten = \"\"\n");
  station::GroundStationConfig g;
  ASSERT_NO_FATAL_FAILURE(write_station_model(cfg, session, g));  // the station's model
  ASSERT_FALSE(g.fusion.pose_graph.has_value());
  const SessionReplay same = replay_station_session(session, cfg, dir.path() + "/replay");
  ASSERT_TRUE(same.error.empty()) << same.error;
  ASSERT_EQ(same.models.size(), 2u);
  EXPECT_EQ(same.models[0].method, "position");
  EXPECT_TRUE(same.models[0].primary);
  EXPECT_EQ(same.models[1].method, "direction");
  for (const ReplayModelCheck& m : same.models) {
    EXPECT_TRUE(m.error.empty()) << m.error;
    EXPECT_GT(m.compared, 1000u);
    EXPECT_EQ(m.compared, m.model_points);
    EXPECT_EQ(m.decisions_differ, 0u);
    EXPECT_EQ(m.placed_differ, 0u);
    EXPECT_TRUE(m.identical) << m.method;
  }
  // Registration off: no placement kept (the robots' own poses and points stand), no counters.
  EXPECT_TRUE(same.scan_pose.empty());
  EXPECT_TRUE(same.placed.empty());
  EXPECT_TRUE(same.robots.empty());

  // The station's model with one decision flipped and one point moved by 5 cm.
  auto cloud = read_pcd(session + "/fused_all.pcd");
  ASSERT_TRUE(cloud.ok());
  PcdCloud c = cloud.value();
  const auto keep = static_cast<std::size_t>(c.field("keep"));
  c.columns[keep][0] = c.columns[keep][0] != 0 ? 0 : 1;
  c.xyz[3 * 1] += 0.05f;
  c.columns[0][1] += 0.05;
  const std::vector<PcdField> layout = {{"x"}, {"y"}, {"z"}, {"robot", 1, 'U'}, {"scan", 4, 'U'}, {"beam", 2, 'U'},
                                        {"keep", 1, 'U'}, {"live_keep", 1, 'U'}};
  ASSERT_TRUE(write_pcd(session + "/fused_all.pcd", c, layout).ok());
  const SessionReplay changed = replay_station_session(session, cfg, dir.path() + "/replay2");
  ASSERT_EQ(changed.models.size(), 2u);
  EXPECT_EQ(changed.models[0].decisions_differ, 1u);
  EXPECT_EQ(changed.models[0].placed_differ, 1u);
  EXPECT_NEAR(changed.models[0].placed_differ_max_m, 0.05, 1e-3);
  EXPECT_FALSE(changed.models[0].identical);
  EXPECT_TRUE(changed.models[1].identical);  // the compared model's file is untouched

  // With the registration on: the station's model (rewritten by its fusion stage) is again identical, and
  // the primary core's placement of every scan and point is kept, with the registration's counters.
  const std::string reg_cfg = dir.path() + "/groundstation-registration.toml";
  write_file(reg_cfg, "[station]\nsession_root = \"/tmp\"\n[fusion]\nenabled = true\nmethod = \"position\"\nwrite_all_points = true\n"
                      "[registration]\nenabled = true\n[pose_graph]\nenabled = false\n[view]\nlisten = \"\"\n");
  ASSERT_NO_FATAL_FAILURE(write_station_model(reg_cfg, session, g));
  ASSERT_TRUE(g.fusion.core.registration);
  const SessionReplay registered = replay_station_session(session, reg_cfg, dir.path() + "/replay-registered");
  ASSERT_TRUE(registered.error.empty()) << registered.error;
  ASSERT_EQ(registered.models.size(), 1u);
  EXPECT_TRUE(registered.models[0].identical);
  EXPECT_EQ(registered.scan_pose.size(), 2u * 61u);
  EXPECT_EQ(registered.placed.size(), 2u * 61u * 20u);
  EXPECT_EQ(registered.robots.size(), 2u);
  // No truth for this session: the registration is on, nothing measured.
  const LiveRegistrationScore score = score_live_registration(session, reg_cfg, registered, LiveDataset{});
  EXPECT_TRUE(score.error.empty()) << score.error;
  EXPECT_TRUE(score.enabled);
  EXPECT_EQ(score.scans, 0u);
  EXPECT_EQ(score.points, 0u);

  // At the station's defaults (the pose graph on, no [pose_graph] section): the station's shutdown (the
  // graph's last optimisation, its trajectories, the cores fed the session again on its poses) writes the
  // model the replay decides on the graph, row for row.
  const std::string graph_cfg = dir.path() + "/groundstation-graph.toml";
  write_file(graph_cfg, "[station]\nsession_root = \"/tmp\"\n[fusion]\nenabled = true\nmethod = \"position\"\nwrite_all_points = true\n"
                        "[view]\nlisten = \"\"\n");
  ASSERT_NO_FATAL_FAILURE(write_station_model(graph_cfg, session, g));
  ASSERT_TRUE(g.fusion.pose_graph.has_value());
  const SessionReplay on_graph = replay_station_session(session, graph_cfg, dir.path() + "/replay-graph");
  ASSERT_TRUE(on_graph.error.empty()) << on_graph.error;
  EXPECT_TRUE(on_graph.pose_graph);
  ASSERT_EQ(on_graph.models.size(), 1u);
  EXPECT_EQ(on_graph.models[0].compared, on_graph.models[0].model_points);
  EXPECT_GT(on_graph.models[0].compared, 1000u);
  EXPECT_TRUE(on_graph.models[0].identical);

  // A config that cannot be read: an error, nothing compared.
  const SessionReplay none = replay_station_session(session, dir.path() + "/none.toml", dir.path() + "/replay3");
  EXPECT_FALSE(none.error.empty());
  EXPECT_TRUE(none.models.empty());
}

// Registration on by default exactly when a robot's odometry has a skid-steer drift term; the per-cycle
// jitter every scenario has is not drift. The shipped scenarios: the three drift ones, and team3 (its robot 3
// turns 0.5°/m) and tables4 (0.1°/m); lap2, fig8, parked3 and convoy3 only have the jitter.
TEST(DemoOptions, RegistrationOnWhenTheScenarioDrifts) {
  sim::Scenario s;
  s.robots.resize(2);
  s.robots[0].odometry.slip_sigma = 0.01;
  s.robots[0].odometry.heading_sigma = 0.01;
  EXPECT_FALSE(scenario_drifts(s));
  for (int term = 0; term < 4; ++term) {
    sim::Scenario d = s;
    sim::OdometryNoise& o = d.robots[1].odometry;
    (term == 0 ? o.slip : term == 1 ? o.turn_slip : term == 2 ? o.drift_rad_per_m : o.heading_walk_rad_per_sqrt_m) = 0.01;
    EXPECT_TRUE(scenario_drifts(d)) << term;
  }
  const char* src = std::getenv("TEAMSCAN_SOURCE_DIR");
  const std::string dir = std::string{src ? src : "."} + "/sim/scenarios/";
  for (const char* name : {"lap2-drift", "corridor2", "team3-drift", "lap2", "fig8", "team3", "tables4", "parked3", "convoy3"}) {
    const sim::ScenarioLoad l = sim::load_scenario_file(dir + name + ".toml");
    ASSERT_TRUE(l.scenario) << name << ": " << l.error;
    const std::string n = name;
    const bool drift = n == "lap2-drift" || n == "corridor2" || n == "team3-drift" || n == "team3" || n == "tables4";
    EXPECT_EQ(scenario_drifts(*l.scenario), drift) << name;
  }
}

}  // namespace
}  // namespace teamscan::demo
