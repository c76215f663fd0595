// Scoring pieces of the demo (tools/demo/scoring.hpp): the station's model against labelled points,
// the latency files by name, quantiles, and the kill report from a session the station's store wrote.
#include <gtest/gtest.h>

#include <cstdio>

#include "common/dataset/pcd.hpp"
#include "common/point_flags.hpp"
#include "groundstation/station/session_store.hpp"
#include "tests/unit/demo/temp_dir.hpp"
#include "tools/demo/scoring.hpp"

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
    station::StoredScan s{};
    s.robot_id = 1;
    s.count = 2;
    s.points[0].flags = kPointTeamStale;
    s.points[1].flags = kPointDirectionFiltered;
    s.stamp_ns = kill - 1;  // before: one stale point counted before
    store->append_scan(s);
    s.stamp_ns = kill + 1'500'000'000;  // after (from 1 s after the kill)
    store->append_scan(s);
    s.robot_id = 2;  // the killed robot's own scans do not count
    store->append_scan(s);
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

}  // namespace
}  // namespace teamscan::demo
