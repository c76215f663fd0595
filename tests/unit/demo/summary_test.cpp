// The demo's stdout summary (at most 15 lines, each figure it names), its progress on stderr (a bar on
// a terminal, plain lines at a bounded rate otherwise, nothing when quiet but events), and the JSON
// reports' layout (values escaped by nlohmann-json, one row per line).
#include "tools/demo/summary.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <functional>
#include <limits>
#include <string>

#include "tools/demo/progress.hpp"
#include "tools/demo/report_json.hpp"

namespace teamscan::demo {
namespace {

int lines(const std::string& text) {
  int n = 0;
  for (char c : text) n += c == '\n';
  return n;
}

// Every optional line present: the longest summary there is.
DemoSummary full() {
  DemoSummary s;
  s.scenario = "lap2-drift";
  s.robots = 2;
  s.duration_s = 60;
  s.speed = 1;
  s.registration_why = "on: the scenario's robots drift";
  s.network = "on loopback (/usr/share/teamscan/cyclonedds-lo.xml)";
  s.scans_stored = 9000;
  s.none_lost = true;
  s.model_present = true;
  s.station_method = "best";
  s.model_da = 97.25;
  s.model_sa = 99.875;
  s.offline_da = 97.5;
  s.offline_sa = 99.9;
  s.onboard_da = 88.0;
  s.identity_what = "its core replaying the session in arrival order";
  s.identity = true;
  s.pose_p99_odometry_m = 0.412;
  s.pose_p99_corrected_m = 0.051;
  s.pose_graph = true;
  s.pose_p99_graph_m = 0.009;
  s.pose_p99_graph_deg = 0.21;
  s.graph_closures = 1336;
  s.fused_latency_p50_ms = 70;
  s.fused_latency_p99_ms = 112;
  s.out = "/tmp/demo-out";
  s.agree = s.clean = true;
  return s;
}

TEST(DemoSummary, AtMostFifteenLinesWithEveryHeadlineFigure) {
  const std::string t = summary_text(full());
  EXPECT_LE(lines(t), kSummaryLines) << t;
  EXPECT_EQ(t.back(), '\n');
  for (const char* part :
       {"lap2-drift, 2 robots, 60 s", "registration on: the scenario's robots drift", "9000 scans stored",
        "nothing lost", "removed 97.2 % of the ghost", "kept 99.88 % of the scene", "DA 97.2 % vs 97.5 %",
        "direction filter removed 88.0 %", "yes, point by point", "p99 41.2 cm with odometry alone, 5.1 cm corrected",
        "p50 70 ms, p99 112 ms", "/tmp/demo-out/", "report.md", "verdict: PASS", "pose graph on",
        "pose graph: pose error p99 0.9 cm / 0.21 deg, 1336 loop closures",
        "DDS on loopback (/usr/share/teamscan/cyclonedds-lo.xml)"})
    EXPECT_NE(t.find(part), std::string::npos) << part << "\n" << t;
}

TEST(DemoSummary, AFailureSaysWhich) {
  DemoSummary s = full();
  s.none_lost = false;
  s.scans_missing = 3;
  s.poses_missing = 2;
  s.model_present = false;
  s.model_error = "no fused_all.pcd";
  const std::string t = summary_text(s);
  EXPECT_LE(lines(t), kSummaryLines);
  EXPECT_NE(t.find("3 missing from their sequence numbers, 2 poses missing: SCANS OR POSES LOST"), std::string::npos) << t;
  EXPECT_NE(t.find("no usable model (no fused_all.pcd)"), std::string::npos) << t;
  EXPECT_NE(t.find("verdict: FAIL (nothing lost: NO"), std::string::npos) << t;
}

std::string captured(const std::function<void(std::FILE*)>& write) {
  std::FILE* f = std::tmpfile();
  write(f);
  std::fflush(f);
  std::rewind(f);
  std::string s;
  for (int c; (c = std::fgetc(f)) != EOF;) s += static_cast<char>(c);
  std::fclose(f);
  return s;
}

TEST(DemoProgress, PlainLinesAtMostOncePerPeriodOffATerminal) {
  const std::string s = captured([](std::FILE* f) {
    Progress p(false, f, false, 5.0);
    p.stage("stage one");
    for (int i = 0; i <= 100; ++i) p.update(i / 100.0, i * 0.1, "t = " + std::to_string(i));  // 10 s
    p.event("fault");
  });
  EXPECT_EQ(s.find('\r'), std::string::npos) << s;
  EXPECT_EQ(lines(s), 1 + 3 + 1) << s;  // the stage, updates at 0, 5 and 10 s, the event
  EXPECT_NE(s.find("stage one\n"), std::string::npos);
  EXPECT_NE(s.find("100 %  t = 100\n"), std::string::npos) << s;
}

TEST(DemoProgress, ABarRedrawnInPlaceOnATerminal) {
  const std::string s = captured([](std::FILE* f) {
    Progress p(false, f, true);
    p.update(0.5, 0, "half");
    p.update(1.0, 0.1, "done");
    p.event("next");
  });
  EXPECT_EQ(s.find("\r[###############               ]  50 %  half"), 0u) << s;
  EXPECT_NE(s.find("\r[##############################] 100 %  done"), std::string::npos) << s;
  EXPECT_NE(s.find("\nnext\n"), std::string::npos) << s;  // the bar ended before the event
}

TEST(DemoProgress, QuietShowsOnlyEvents) {
  const std::string s = captured([](std::FILE* f) {
    Progress p(true, f, false);
    p.stage("stage");
    p.update(0.5, 0, "half");
    p.event("live view at http://127.0.0.1:1/");
  });
  EXPECT_EQ(s, "live view at http://127.0.0.1:1/\n");
}

TEST(ReportJson, EscapesNamesAndPutsOneRowPerLine) {
  ReportJson j = {{"name", "a \"quoted\"\\path\n\x01"},
                  {"nan", std::numeric_limits<double>::quiet_NaN()},
                  {"n", 3},
                  {"rows", {{{"id", 1}, {"v", 2.5}}, {{"id", 2}, {"v", 0.0}}}},
                  {"plain", {1, 2}}};
  const std::string s = json_report(j);
  EXPECT_EQ(s,
            "{\n  \"name\": \"a \\\"quoted\\\"\\\\path\\n\\u0001\",\n  \"nan\": null,\n  \"n\": 3,\n  \"rows\": [\n"
            "    {\"id\": 1, \"v\": 2.5},\n    {\"id\": 2, \"v\": 0.0}\n  ],\n  \"plain\": [1, 2]\n}\n");
  // It reads back as the same values (NaN as null).
  const ReportJson back = ReportJson::parse(s);
  EXPECT_EQ(back["name"], j["name"]);
  EXPECT_TRUE(back["nan"].is_null());
  EXPECT_EQ(back["rows"], j["rows"]);
}

}  // namespace
}  // namespace teamscan::demo
