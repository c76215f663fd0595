// SessionStore files and the last-pose TeamSource.
#include <gtest/gtest.h>

#include <sys/wait.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <sstream>

#include "groundstation/station/session_store.hpp"
#include "groundstation/station/team_source.hpp"
#include "teamscan.h"

namespace teamscan::station {
namespace {

std::string temp_dir() {
  char tmpl[] = "/tmp/teamscan-store-XXXXXX";
  return ::mkdtemp(tmpl);
}

std::string slurp(const std::string& path) {
  std::ifstream in(path);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

TEST(SessionStore, CreatesATimestampedSessionFolderWithAllFiles) {
  const std::string root = temp_dir() + "/nested/root";
  auto s = SessionStore::create(root);
  ASSERT_TRUE(s.ok()) << s.error().what;
  const std::filesystem::path dir(s->dir());
  EXPECT_EQ(dir.parent_path(), std::filesystem::path(root));
  EXPECT_EQ(dir.filename().string().rfind("session-", 0), 0u);
  for (const char* f : {"scans.bin", "poses.csv", "status.csv", "events.log"}) {
    EXPECT_TRUE(std::filesystem::exists(dir / f)) << f;
  }
  EXPECT_EQ(std::filesystem::file_size(dir / "scans.bin"), kScanFileHeaderBytes);
  std::filesystem::remove_all(root);
}

// A root or a session folder that cannot be made (a file stands in the way), or a session file that
// cannot be opened: the error names the path, so the operator knows which one.
TEST(SessionStore, ErrorsNameThePathThatFailed) {
  const std::string base = temp_dir();
  { std::ofstream(base + "/a-file") << "x"; }
  auto root = SessionStore::create(base + "/a-file/root");
  ASSERT_FALSE(root.ok());
  EXPECT_NE(std::string(root.error().what).find(base + "/a-file/root"), std::string::npos) << root.error().what;
  EXPECT_NE(root.error().sys_errno, 0);
  auto dir = SessionStore::open(base + "/a-file/session");
  ASSERT_FALSE(dir.ok());
  EXPECT_NE(std::string(dir.error().what).find(base + "/a-file/session"), std::string::npos) << dir.error().what;
  std::filesystem::create_directories(base + "/s/poses.csv");  // a folder where a session file goes
  auto files = SessionStore::open(base + "/s");
  ASSERT_FALSE(files.ok());
  EXPECT_NE(std::string(files.error().what).find(base + "/s/poses.csv"), std::string::npos) << files.error().what;
  std::filesystem::remove_all(base);
}

// A child process stores and then dies by SIGKILL without any cleanup: every record is in the files.
TEST(SessionStore, NothingIsLostWhenTheProcessIsKilled) {
  const std::string dir = temp_dir() + "/s";
  const pid_t pid = ::fork();
  ASSERT_GE(pid, 0);
  if (pid == 0) {
    auto s = SessionStore::open(dir);
    if (!s) ::_exit(3);
    static ScanPoints scan;
    scan.robot_id = 2;
    scan.count = 10;
    teamscan_msg_RobotPose p{};
    p.robot_id = 2;
    for (std::uint32_t i = 1; i <= 500; ++i) {
      scan.seq = i;
      s->append_scan(scan, Receipt{});
      p.seq = i;
      s->append_pose(p, ReceiveTime{Time::from_ns(i), Time::from_ns(i)});
    }
    s->log_event(Time::from_ns(1'700'000'000'000'000'000), "last words");
    ::kill(::getpid(), SIGKILL);  // no destructor, no sync
    ::_exit(4);
  }
  int st = 0;
  ASSERT_EQ(::waitpid(pid, &st, 0), pid);
  ASSERT_TRUE(WIFSIGNALED(st));
  std::uint32_t n = 0;
  std::uint32_t expected_seq = 1;
  ScanDecodeStats stats;
  std::string err;
  ASSERT_TRUE(read_scan_file(dir + "/scans.bin", [&](const ScanPoints& s, const Receipt&) {
    EXPECT_EQ(s.seq, expected_seq++);
    ++n;
  }, stats, err)) << err;
  EXPECT_EQ(n, 500u);
  EXPECT_FALSE(stats.truncated_tail);
  const std::string poses = slurp(dir + "/poses.csv");
  EXPECT_EQ(std::count(poses.begin(), poses.end(), '\n'), 501);  // header + 500
  EXPECT_NE(poses.find("\n500,500,2,500,"), std::string::npos);
  EXPECT_NE(slurp(dir + "/events.log").find("1700000000000000000 2023-11-14T22:13:20.000Z last words\n"),
            std::string::npos);
  std::filesystem::remove_all(std::filesystem::path(dir).parent_path());
}

TEST(SessionStore, ReopeningAppendsWithoutASecondHeader) {
  const std::string dir = temp_dir() + "/s";
  static ScanPoints scan;
  scan.count = 1;
  {
    auto s = SessionStore::open(dir);
    ASSERT_TRUE(s.ok());
    scan.seq = 1;
    s->append_scan(scan, Receipt{});
  }
  {
    auto s = SessionStore::open(dir);
    ASSERT_TRUE(s.ok());
    scan.seq = 2;
    s->append_scan(scan, Receipt{});
  }
  std::vector<std::uint32_t> seqs;
  ScanDecodeStats stats;
  std::string err;
  ASSERT_TRUE(read_scan_file(dir + "/scans.bin", [&](const ScanPoints& s, const Receipt&) { seqs.push_back(s.seq); }, stats, err));
  EXPECT_EQ(seqs, (std::vector<std::uint32_t>{1, 2}));
  EXPECT_EQ(stats.bytes_skipped, 0u);
  const std::string poses = slurp(dir + "/poses.csv");
  EXPECT_EQ(std::count(poses.begin(), poses.end(), '\n'), 1);
  std::filesystem::remove_all(std::filesystem::path(dir).parent_path());
}

TEST(SessionStore, StatusLineHasEveryFieldInHeaderOrder) {
  const std::string dir = temp_dir() + "/s";
  {
    auto s = SessionStore::open(dir);
    ASSERT_TRUE(s.ok());
    teamscan_msg_RobotStatus st{};
    st.robot_id = 3;
    st.seq = 4;
    st.stamp_ns = 5;
    st.arcos_state = 6;
    st.lms_state = 7;
    st.team_fresh = 1;
    st.sip_rate_mhz = 10000;
    st.scan_rate_mhz = 75000;
    st.arcos_bad_packets = 11;
    st.lms_bad_telegrams = 12;
    st.lms_resyncs = 13;
    st.scans_published = 14;
    st.points_direction_filtered = 15;
    st.dds_write_errors = 16;
    st.uptime_s = 17;
    st.arcos_reopens = 18;
    st.lms_reopens = 19;
    st.points_team_stale = 20;
    st.points_no_pose = 21;
    st.loop_max_us = 22;
    st.clock_sync = 1;
    st.teams_rejected = 23;
    st.last_team_reject = 4;
    st.corrections_applied = 24;
    st.corrections_rejected = 25;
    st.ring_unconfirmed = 26;
    st.ring_dropped = 27;
    st.shadow_ms = 28;
    st.last_shadow_ms = 29;
    st.backfill_total = 30;
    st.backfill_remaining = 31;
    s->append_status(st, ReceiveTime{Time::from_ns(1), Time::from_ns(2)}, 7);
    teamscan_msg_RobotPose p{};
    p.robot_id = 999999;
    s->append_pose(p, ReceiveTime{Time::from_ns(1), Time::from_ns(2)}, 1);
    s->append_rejected(ReceiveTime{Time::from_ns(1), Time::from_ns(2)}, "pose", 999999, 0, -5, "robot_id", 999999);
  }
  EXPECT_EQ(slurp(dir + "/rejected.csv"),
            "recv_realtime_ns,topic,robot_id,seq,stamp_ns,reason,value\n1,pose,999999,0,-5,robot_id,999999\n");
  EXPECT_NE(slurp(dir + "/poses.csv").find("yaw_rate_mradps,rejected\n1,2,999999,0,0,0,0,0,0,0,0,1\n"), std::string::npos);
  const std::string text = slurp(dir + "/status.csv");
  const std::string header = text.substr(0, text.find('\n'));
  EXPECT_EQ(std::count(header.begin(), header.end(), ','), 33);
  EXPECT_EQ(header.substr(header.rfind("loop_max_us")),
            "loop_max_us,clock_sync,teams_rejected,last_team_reject,corrections_applied,corrections_rejected,"
            "ring_unconfirmed,ring_dropped,shadow_ms,last_shadow_ms,backfill_total,backfill_remaining,rejected");
  EXPECT_EQ(text.substr(text.find('\n') + 1),
            "1,2,3,4,5,6,7,1,10000,75000,11,12,13,14,15,16,17,18,19,20,21,22,1,23,4,24,25,26,27,28,29,30,31,7\n");
  std::filesystem::remove_all(std::filesystem::path(dir).parent_path());
}

TEST(SessionStore, UnwritableRootIsAnErrorNotACrash) {
  auto s = SessionStore::create("/proc/teamscan-cannot-be-here");
  EXPECT_FALSE(s.ok());
}

PoseObservation pose(std::uint32_t id, double t_s, double x, double y, double vx, double vy) {
  PoseObservation p;
  p.robot_id = id;
  p.stamp = Time::from_seconds(t_s);
  p.x_m = x;
  p.y_m = y;
  p.vx_mps = vx;
  p.vy_mps = vy;
  return p;
}

TEST(LastPoseTeamSource, ExtrapolatesWithVelocityUpToTheLimitAndGrowsTheCovariance) {
  LastPoseOptions o;
  o.sigma0_m = 0.1;
  o.sigma_velocity_mps = 0.5;
  o.max_extrapolation_s = 0.5;
  LastPoseTeamSource src(o);
  src.add_pose(pose(3, 100.0, 1.0, 2.0, 1.0, -2.0));
  std::array<TeamMemberEstimate, kMaxRobots> out{};
  ASSERT_EQ(src.estimate(Time::from_seconds(100.2), out), 1u);
  EXPECT_EQ(out[0].robot_id, 3u);
  EXPECT_NEAR(out[0].x_m, 1.2, 1e-9);
  EXPECT_NEAR(out[0].y_m, 1.6, 1e-9);
  EXPECT_NEAR(out[0].cov_xx_m2, 0.2 * 0.2, 1e-9);  // (0.1 + 0.5 * 0.2)^2
  EXPECT_NEAR(out[0].cov_yy_m2, 0.04, 1e-9);
  EXPECT_EQ(out[0].cov_xy_m2, 0.0);
  // 2 s old: extrapolation capped at 0.5 s, sigma keeps growing with the full age.
  ASSERT_EQ(src.estimate(Time::from_seconds(102.0), out), 1u);
  EXPECT_NEAR(out[0].x_m, 1.5, 1e-9);
  EXPECT_NEAR(out[0].cov_xx_m2, 1.1 * 1.1, 1e-9);
}

TEST(LastPoseTeamSource, OrderedByIdOlderPoseIgnoredLostHoldsPosition) {
  LastPoseTeamSource src;
  src.add_pose(pose(7, 10.0, 7.0, 0.0, 1.0, 0.0));
  src.add_pose(pose(2, 10.0, 2.0, 0.0, 0.0, 0.0));
  src.add_pose(pose(2, 9.0, 99.0, 0.0, 0.0, 0.0));  // older: ignored
  src.add_pose(pose(0, 10.0, 0.0, 0.0, 0.0, 0.0));  // id out of range: ignored
  src.add_pose(pose(33, 10.0, 0.0, 0.0, 0.0, 0.0));
  src.set_lost(7, true);
  std::array<TeamMemberEstimate, kMaxRobots> out{};
  ASSERT_EQ(src.estimate(Time::from_seconds(10.4), out), 2u);
  EXPECT_EQ(out[0].robot_id, 2u);
  EXPECT_NEAR(out[0].x_m, 2.0, 1e-12);
  EXPECT_EQ(out[1].robot_id, 7u);
  EXPECT_TRUE(out[1].lost);
  EXPECT_NEAR(out[1].x_m, 7.0, 1e-12);  // not extrapolated
  EXPECT_EQ(out[1].vx_mps, 0.0);
  // Output span smaller than the team: no overrun.
  std::array<TeamMemberEstimate, 1> one{};
  EXPECT_EQ(src.estimate(Time::from_seconds(10.4), one), 1u);
}

}  // namespace
}  // namespace teamscan::station
