// "Validate at the edge", against the real teamscan-groundstation process over loopback DDS: a
// participant publishes scans, poses and status with robot ids 0, 33 and 999999, count 65535 and 402,
// stamps 0, INT64_MIN and INT64_MAX, coordinates at ±2^31 mm, yaw 2^31 µrad and wrapping / jumping
// sequence numbers, beside good samples of the same robots. Checked from the outside: every reason is
// counted (validation.csv, rejected.csv), the raw samples are stored (scans.bin records marked refused,
// the `rejected` column of poses.csv), the team state the station publishes has only sane positions
// (the good ones), and the scan -> fused-map statistics hold the good scans only.
#include <gtest/gtest.h>

#include <dds/dds.h>

#include <climits>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <set>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "common/clock.hpp"
#include "groundstation/station/scan_record.hpp"
#include "dds/qos.hpp"
#include "tests/support/robot_writers.hpp"
#include "dds/topics.hpp"
#include "teamscan.h"
#include "tests/hil/station/process.hpp"
#include "tests/support/test_domain.hpp"

namespace teamscan {
namespace {

using namespace std::chrono_literals;

std::string slurp(const std::string& path) {
  std::ifstream in(path);
  return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

std::vector<std::vector<std::string>> csv(const std::string& path) {
  std::vector<std::vector<std::string>> rows;
  std::istringstream in(slurp(path));
  std::string line;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#') continue;
    std::vector<std::string> f;
    std::stringstream ss(line);
    std::string cell;
    while (std::getline(ss, cell, ',')) f.push_back(cell);
    rows.push_back(f);
  }
  return rows;
}

// The bad participant: keep-all reliable writers with the robots' durability, so every sample it sends
// reaches the station (the counts below are exact).
struct BadPublisher {
  dds_entity_t participant = 0, team_reader = 0;
  std::unique_ptr<test::RobotWriters> robots;
  explicit BadPublisher(std::uint32_t domain) {
    participant = dds_create_participant(domain, nullptr, nullptr);
    robots = std::make_unique<test::RobotWriters>(participant, /*keep_all=*/true);
    const dds_entity_t tt = dds_create_topic(participant, &teamscan_msg_TeamState_desc, dds::kTopicTeam, nullptr, nullptr);
    dds_qos_t* q = dds::make_team_reader_qos();
    team_reader = dds_create_reader(participant, tt, q, nullptr);
    dds_delete_qos(q);
  }
  ~BadPublisher() {
    if (participant > 0) (void)dds_delete(participant);
  }
  [[nodiscard]] bool ok() const { return participant > 0 && robots->ok() && team_reader > 0; }
  // Robot 1's writers as the sign that the station subscribed (the others match the same reader).
  [[nodiscard]] bool matched() const {
    return robots->matched(test::RobotWriters::kPose, 1) > 0 && robots->matched(test::RobotWriters::kScan, 1) > 0 &&
           robots->matched(test::RobotWriters::kStatus, 1) > 0;
  }
};

teamscan_msg_RobotPose good_pose(std::uint32_t id, std::uint32_t seq) {
  teamscan_msg_RobotPose p{};
  p.robot_id = id;
  p.seq = seq;
  p.stamp_ns = now_realtime().ns();
  p.x_mm = 1000 * static_cast<std::int32_t>(id);
  p.y_mm = 2000;
  p.yaw_urad = 500000;
  p.vx_mmps = 100;
  return p;
}

teamscan_msg_ScanPoints& good_scan(std::uint32_t id, std::uint32_t seq) {
  static teamscan_msg_ScanPoints s;
  s = teamscan_msg_ScanPoints{};
  s.robot_id = id;
  s.seq = seq;
  s.stamp_ns = now_realtime().ns();
  s.origin_x_mm = 1000 * static_cast<std::int32_t>(id);
  s.origin_y_mm = 2000;
  s.origin_z_mm = 450;
  s.count = 181;
  for (std::uint16_t b = 0; b < 181; ++b) s.points[b] = teamscan_msg_ScanPoint{s.origin_x_mm + 3000, b * 20, 0, b, 0};
  return s;
}

TEST(StationBadSamples, EveryReasonCountedRawStoredTeamAndStatisticsUntouched) {
  char tmpl[] = "/tmp/teamscan-bad-samples-XXXXXX";
  const std::string root = ::mkdtemp(tmpl);
  const std::string session = root + "/session";
  const std::string config = root + "/gs.toml";
  std::ofstream(config) << "[station]\nstatus_interval_s = 0.2\n[fusion]\nmethod = \"direction\"\nlatency_log = true\n";
  const std::uint32_t domain = test::test_domain_id();
  BadPublisher pub(domain);
  ASSERT_TRUE(pub.ok());
  test::ChildProcess gs({TEAMSCAN_GROUNDSTATION, "--config", config, "--session-dir", session, "--domain",
                         test::test_domain_arg()});
  const auto deadline = std::chrono::steady_clock::now() + 20s;
  while (!pub.matched() && std::chrono::steady_clock::now() < deadline) std::this_thread::sleep_for(20ms);
  ASSERT_TRUE(pub.matched()) << "the station did not subscribe";

  std::map<std::string, int> sent;  // reason -> samples sent with it
  int bad_poses = 0, bad_scans = 0;
  auto write_pose = [&](const teamscan_msg_RobotPose& p, const char* reason) {
    ASSERT_EQ(dds_write(pub.robots->writer(test::RobotWriters::kPose, p.robot_id), &p), 0);
    if (reason) {
      ++sent[reason];
      ++bad_poses;
    }
  };
  auto write_scan = [&](const teamscan_msg_ScanPoints& s, const char* reason) {
    ASSERT_EQ(dds_write(pub.robots->writer(test::RobotWriters::kScan, s.robot_id), &s), 0);
    if (reason) {
      ++sent[reason];
      ++bad_scans;
    }
  };
  // Good data of robots 1, 2, 4, 5 and 7 interleaved with the bad samples (robots 1, 2 and 7 are the
  // ones the issue saw tracked at 2147 km).
  std::uint32_t good_scans = 0;
  for (std::uint32_t round = 1; round <= 10; ++round) {
    for (std::uint32_t id : {1u, 2u, 4u, 7u}) {
      write_pose(good_pose(id, round), nullptr);
      write_scan(good_scan(id, round), nullptr);
      ++good_scans;
    }
    std::this_thread::sleep_for(20ms);
  }
  for (std::uint32_t id : {0u, 33u, 999999u}) {
    write_pose(good_pose(id, 1), "robot_id");
    write_scan(good_scan(id, 1), "robot_id");
  }
  for (std::uint16_t count : {std::uint16_t{65535}, std::uint16_t{402}}) {
    auto& s = good_scan(1, 11);
    s.count = count;
    write_scan(s, "beam_count");
  }
  for (std::int64_t stamp : {std::int64_t{0}, INT64_MIN}) {
    auto p = good_pose(2, 11);
    p.stamp_ns = stamp;
    write_pose(p, "clock_unset");
    auto& s = good_scan(2, 11);
    s.stamp_ns = stamp;
    write_scan(s, "clock_unset");
  }
  {
    auto p = good_pose(2, 11);
    p.stamp_ns = INT64_MAX;
    write_pose(p, "stamp_ahead");
    auto& s = good_scan(2, 11);
    s.stamp_ns = INT64_MAX;
    write_scan(s, "stamp_ahead");
  }
  for (std::int32_t c : {INT32_MAX, INT32_MIN}) {  // ±2^31 mm
    auto p = good_pose(7, 11);
    p.x_mm = c;
    write_pose(p, "outside_site");
    p = good_pose(7, 11);
    p.y_mm = c;
    write_pose(p, "outside_site");
    auto& s = good_scan(7, 11);
    s.origin_x_mm = c;
    write_scan(s, "outside_site");
  }
  for (std::int32_t yaw : {INT32_MAX, INT32_MIN}) {  // 2^31 µrad does not fit an int32: its extremes
    auto p = good_pose(7, 11);
    p.yaw_urad = yaw;
    write_pose(p, "yaw");
  }
  // Robot 5 counts across the wrap (progress, accepted), then jumps by 2^31 (refused).
  for (std::uint32_t seq : {0xFFFFFFFEu, 0xFFFFFFFFu, 0u, 1u}) {
    write_pose(good_pose(5, seq), nullptr);
    write_scan(good_scan(5, seq), nullptr);
    ++good_scans;
  }
  // Status: robot 4 says its clock is not synchronised (accepted, reported); robot 3's clock was never set.
  {
    teamscan_msg_RobotStatus st{};
    st.robot_id = 4;
    st.seq = 1;
    st.stamp_ns = now_realtime().ns();
    st.clock_sync = 2;
    ASSERT_EQ(dds_write(pub.robots->writer(test::RobotWriters::kStatus, st.robot_id), &st), 0);
    st.robot_id = 3;
    st.stamp_ns = 1'000'000'000;  // 1970-01-01T00:00:01Z
    ASSERT_EQ(dds_write(pub.robots->writer(test::RobotWriters::kStatus, st.robot_id), &st), 0);
    ++sent["clock_unset"];
  }
  write_pose(good_pose(5, 0x80000001u), "seq_jump");
  write_scan(good_scan(5, 0x80000001u), "seq_jump");
  ASSERT_TRUE(pub.robots->wait_for_acks(DDS_SECS(10)));

  // The team state the station publishes after all of it: only sane positions (the good ones).
  std::this_thread::sleep_for(600ms);
  static teamscan_msg_TeamState team;
  bool have_team = false;
  const auto team_deadline = std::chrono::steady_clock::now() + 5s;
  while (std::chrono::steady_clock::now() < team_deadline) {
    void* buf[1] = {&team};
    dds_sample_info_t info;
    while (dds_take(pub.team_reader, buf, &info, 1, 1) > 0) have_team = have_team || info.valid_data;
    if (have_team && team.count >= 5) break;
    std::this_thread::sleep_for(100ms);
  }
  ASSERT_TRUE(have_team);
  std::set<std::uint32_t> ids;
  for (std::uint8_t i = 0; i < team.count; ++i) {
    const teamscan_msg_TeamMember& m = team.members[i];
    ids.insert(m.robot_id);
    EXPECT_NEAR(m.x_mm, 1000.0 * m.robot_id, 500.0) << "robot " << m.robot_id;  // 2 147 km in the issue
    EXPECT_NEAR(m.y_mm, 2000.0, 500.0) << "robot " << m.robot_id;
  }
  EXPECT_EQ(ids, (std::set<std::uint32_t>{1, 2, 4, 5, 7}));

  gs.signal(SIGTERM);
  const auto st = gs.wait(60s);
  ASSERT_TRUE(st.has_value());
  EXPECT_TRUE(WIFEXITED(*st) && WEXITSTATUS(*st) == 0);

  // Every reason counted exactly (validation.csv: robot,reason,count).
  std::map<std::string, int> counted;
  for (const auto& f : csv(session + "/validation.csv")) {
    if (f[0] == "clock_robot") break;  // the clock section follows the counters
    if (f.size() == 3 && f[0] != "robot" && f[1] != "accepted") counted[f[1]] += std::stoi(f[2]);
  }
  EXPECT_EQ(counted, sent);
  // One rejected.csv line per refused sample, with the raw values.
  int rejected_lines = 0, total_sent = 0;
  bool saw_count = false, saw_999999 = false;
  for (const auto& f : csv(session + "/rejected.csv")) {
    if (f[0] == "recv_realtime_ns") continue;
    ++rejected_lines;
    saw_count = saw_count || (f[5] == "beam_count" && f[6] == "65535");
    saw_999999 = saw_999999 || f[2] == "999999";
  }
  for (const auto& [r, n] : sent) total_sent += n;
  EXPECT_EQ(rejected_lines, total_sent);
  EXPECT_TRUE(saw_count);
  EXPECT_TRUE(saw_999999);
  // Each reason logged (rate-limited: once here).
  const std::string events = slurp(session + "/events.log");
  for (const auto& [r, n] : sent) EXPECT_NE(events.find(": " + r + " (value"), std::string::npos) << r;
  EXPECT_NE(events.find("robot 4 reports its clock NOT synchronised"), std::string::npos);
  EXPECT_NE(events.find("robot 3 clock off: clock never set"), std::string::npos);

  // Raw storage: every scan sent is in scans.bin, the refused ones marked; the poses alike.
  std::uint64_t stored_good = 0, stored_refused = 0;
  std::set<std::uint32_t> refused_ids;
  station::ScanDecodeStats stats;
  std::string err;
  ASSERT_TRUE(station::read_scan_file(session + "/scans.bin", [&](const ScanPoints& s, const station::Receipt& receipt) {
    if (receipt.rejected == 0) {
      ++stored_good;
    } else {
      ++stored_refused;
      refused_ids.insert(s.robot_id);
    }
  }, stats, err)) << err;
  EXPECT_EQ(stored_good, good_scans);
  EXPECT_EQ(stored_refused, static_cast<std::uint64_t>(bad_scans));
  EXPECT_TRUE(refused_ids.count(999999) && refused_ids.count(0) && refused_ids.count(33));
  int poses_refused = 0;
  for (const auto& f : csv(session + "/poses.csv")) {
    if (f[0] != "recv_realtime_ns" && f.size() == 12 && f[11] != "0") ++poses_refused;
  }
  EXPECT_EQ(poses_refused, bad_poses);
  int statuses_refused = 0;
  for (const auto& f : csv(session + "/status.csv")) {
    if (f[0] != "recv_realtime_ns" && f.back() != "0") ++statuses_refused;
  }
  EXPECT_EQ(statuses_refused, 1);

  // The statistics hold the good scans only: every fused scan is a good one, none 57 years late.
  int fused = 0;
  for (const auto& f : csv(session + "/fused_latency.csv")) {
    if (f[0] == "robot") continue;
    ++fused;
    const double latency_s = (std::stod(f[4]) - std::stod(f[2])) * 1e-9;
    EXPECT_LT(latency_s, 30.0);
    EXPECT_GE(latency_s, 0.0);
  }
  EXPECT_EQ(fused, static_cast<int>(good_scans));
  std::filesystem::remove_all(root);
}

}  // namespace
}  // namespace teamscan
