// Session CSV files by column name (tools/demo/session_csv.hpp), against files the station's own
// SessionStore writes.
#include <gtest/gtest.h>

#include "groundstation/station/session_store.hpp"
#include "teamscan.h"
#include "tests/unit/demo/temp_dir.hpp"
#include "tools/demo/scoring.hpp"
#include "tools/demo/session_csv.hpp"

namespace teamscan::demo {
namespace {

TEST(CsvTable, ColumnsByNameInAnyOrder) {
  const CsvTable a = CsvTable::parse("a,b,c\n1,2,3\n");
  const CsvTable b = CsvTable::parse("c,a,b\n3,1,2\n");
  for (const CsvTable* t : {&a, &b}) {
    ASSERT_EQ(t->rows(), 1u);
    EXPECT_EQ(t->integer(0, *t->column("a")), 1);
    EXPECT_EQ(t->integer(0, *t->column("b")), 2);
    EXPECT_EQ(t->integer(0, *t->column("c")), 3);
  }
  EXPECT_FALSE(a.column("d").has_value());
  EXPECT_TRUE(a.has_columns({"a", "c"}));
  EXPECT_FALSE(a.has_columns({"a", "d"}));
}

TEST(CsvTable, RowsOfAnotherWidthAreCountedAndDropped) {
  const CsvTable t = CsvTable::parse("a,b\n1,2\n1,2,3\n\n4\n5,6\r\n");
  EXPECT_EQ(t.rows(), 2u);
  EXPECT_EQ(t.bad_rows(), 2u);
  EXPECT_EQ(t.integer(1, 1), 6);  // CRLF line end
}

TEST(CsvTable, NumbersThatDoNotParseAreNullopt) {
  const CsvTable t = CsvTable::parse("a,b,c\nx,2.5,\n");
  EXPECT_FALSE(t.integer(0, 0).has_value());
  EXPECT_FALSE(t.integer(0, 1).has_value());
  EXPECT_EQ(t.number(0, 1), 2.5);
  EXPECT_FALSE(t.number(0, 2).has_value());
}

TEST(CsvTable, MissingFileIsAnError) { EXPECT_FALSE(CsvTable::read("/nonexistent/teamscan/status.csv").ok()); }

// The station's status.csv as it writes it; lms_reopens and points_team_stale are neighbours, and the
// demo's fault report once read the latter as the former (by column number).
TEST(SessionCsv, StatusRowsByNameFromTheStationsOwnFile) {
  test::TempDir dir;
  {
    auto store = station::SessionStore::open(dir.path() + "/session");
    ASSERT_TRUE(store.ok()) << store.error().what;
    teamscan_msg_RobotStatus s{};
    s.robot_id = 2;
    s.stamp_ns = 123;
    s.lms_state = 4;
    s.scans_published = 900;
    s.lms_reopens = 3;
    s.points_team_stale = 77;
    s.ring_unconfirmed = 1500;
    s.shadow_ms = 0;
    s.last_shadow_ms = 12000;
    s.backfill_total = 1200;
    s.backfill_remaining = 300;
    store->append_status(s, {Time::from_ns(1), Time::from_ns(2)});
    s.lms_state = 5;
    s.lms_reopens = 1;  // a lower count later (a restarted daemon): the report keeps the highest
    store->append_status(s, {Time::from_ns(3), Time::from_ns(4)});
    s.robot_id = 3;
    s.lms_reopens = 9;
    store->append_status(s, {Time::from_ns(5), Time::from_ns(6)});
    store->sync();
  }
  std::size_t bad = 99;
  auto rows = read_status_csv(dir.path() + "/session/status.csv", &bad);
  ASSERT_TRUE(rows.ok()) << rows.error().what;
  EXPECT_EQ(bad, 0u);
  ASSERT_EQ(rows->size(), 3u);
  EXPECT_EQ((*rows)[0].robot_id, 2u);
  EXPECT_EQ((*rows)[0].stamp_ns, 123);
  EXPECT_EQ((*rows)[0].lms_state, 4u);
  EXPECT_EQ((*rows)[0].scans_published, 900u);
  EXPECT_EQ((*rows)[0].lms_reopens, 3u);
  EXPECT_EQ((*rows)[0].points_team_stale, 77u);
  EXPECT_EQ((*rows)[0].ring_unconfirmed, 1500u);
  EXPECT_EQ((*rows)[0].shadow_ms, 0u);
  EXPECT_EQ((*rows)[0].last_shadow_ms, 12000u);
  EXPECT_EQ((*rows)[0].backfill_total, 1200u);
  EXPECT_EQ((*rows)[0].backfill_remaining, 300u);

  const UnplugReport u = unplug_report(rows.value(), 2);
  EXPECT_EQ(u.lms_reopens, 3u);  // not 77 (points_team_stale)
  EXPECT_EQ(u.lms_states, (std::vector<unsigned>{4, 5}));
  EXPECT_EQ(unplug_report(rows.value(), 3).lms_reopens, 9u);
  EXPECT_TRUE(unplug_report(rows.value(), 7).lms_states.empty());
}

TEST(SessionCsv, PoseRowsByNameFromTheStationsOwnFile) {
  test::TempDir dir;
  {
    auto store = station::SessionStore::open(dir.path() + "/session");
    ASSERT_TRUE(store.ok());
    teamscan_msg_RobotPose p{};
    p.robot_id = 4;
    p.seq = 17;
    p.stamp_ns = 5'000'000'000;
    p.x_mm = -1200;
    p.y_mm = 3400;
    p.yaw_urad = 1570796;
    p.vx_mmps = -5;
    p.vy_mmps = 300;
    p.yaw_rate_mradps = -12;
    store->append_pose(p, {Time::from_ns(1), Time::from_ns(2)});
    store->sync();
  }
  auto rows = read_poses_csv(dir.path() + "/session/poses.csv");
  ASSERT_TRUE(rows.ok());
  ASSERT_EQ(rows->size(), 1u);
  const PoseRow& r = (*rows)[0];
  EXPECT_EQ(r.robot_id, 4u);
  EXPECT_EQ(r.seq, 17u);
  EXPECT_EQ(r.stamp_ns, 5'000'000'000);
  EXPECT_EQ(r.x_mm, -1200);
  EXPECT_EQ(r.y_mm, 3400);
  EXPECT_EQ(r.yaw_urad, 1570796);
  EXPECT_EQ(r.vx_mmps, -5);
  EXPECT_EQ(r.vy_mmps, 300);
  EXPECT_EQ(r.yaw_rate_mradps, -12);
}

TEST(SessionCsv, AMissingColumnIsNamedInTheError) {
  test::TempDir dir;
  const std::string path = dir.path() + "/status.csv";
  std::FILE* f = std::fopen(path.c_str(), "w");
  ASSERT_NE(f, nullptr);
  std::fputs("robot_id,stamp_ns,lms_state,scans_published,points_team_stale\n1,2,3,4,5\n", f);
  std::fclose(f);
  auto rows = read_status_csv(path);
  ASSERT_FALSE(rows.ok());
  EXPECT_STREQ(rows.error().what, "status.csv lacks the column lms_reopens");
}

// A renamed column (here x_mm written as x) is an error naming the columns expected, never a silent
// read of whatever sits at the old position.
TEST(SessionCsv, ARenamedPoseColumnIsAnError) {
  test::TempDir dir;
  const std::string path = dir.path() + "/poses.csv";
  std::FILE* f = std::fopen(path.c_str(), "w");
  ASSERT_NE(f, nullptr);
  std::fputs("recv_realtime_ns,recv_monotonic_ns,robot_id,seq,stamp_ns,x,y_mm,yaw_urad,vx_mmps,vy_mmps,yaw_rate_mradps\n"
             "1,2,1,1,5,100,200,0,0,0,0\n",
             f);
  std::fclose(f);
  auto rows = read_poses_csv(path);
  ASSERT_FALSE(rows.ok());
  EXPECT_STREQ(rows.error().what, "poses.csv lacks the column x_mm");
  EXPECT_FALSE(read_poses_csv(dir.path() + "/none.csv").ok());
}

TEST(SessionCsv, RowsThatDoNotParseAreSkippedAndCounted) {
  test::TempDir dir;
  const std::string path = dir.path() + "/status.csv";
  std::FILE* f = std::fopen(path.c_str(), "w");
  ASSERT_NE(f, nullptr);
  std::fputs("lms_reopens,robot_id,stamp_ns,lms_state,scans_published,points_team_stale,corrections_rejected,corrections_applied,"
             "ring_unconfirmed,shadow_ms,last_shadow_ms,backfill_total,backfill_remaining\n"
             "2,1,10,3,4,5,1,9,0,0,0,0,0\nx,1,11,3,4,5,0,0,0,0,0,0,0\n7,1,12,3,4,0,0\n",
             f);
  std::fclose(f);
  std::size_t bad = 0;
  auto rows = read_status_csv(path, &bad);
  ASSERT_TRUE(rows.ok());
  ASSERT_EQ(rows->size(), 1u);
  EXPECT_EQ((*rows)[0].lms_reopens, 2u);
  EXPECT_EQ((*rows)[0].corrections_applied, 9u);
  EXPECT_EQ((*rows)[0].corrections_rejected, 1u);
  EXPECT_EQ(bad, 2u);
}

}  // namespace
}  // namespace teamscan::demo
