// export_session_mcap on sessions written by SessionStore: what lands in the file (messages per topic
// from the Statistics and Channel records of the summary, found through the Footer), and what a
// malformed session gets (an error that names the file, exit path without a crash, no output left).
#include "tools/mcap_export/session_mcap.hpp"

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <map>
#include <string>

#include "common/mcap/records.hpp"
#include "groundstation/station/session_store.hpp"
#include "teamscan.h"

namespace teamscan::mcap_export {
namespace {

namespace fs = std::filesystem;
using station::ReceiveTime;
using station::SessionStore;
using station::Receipt;

std::string temp_dir() {
  const fs::path p = fs::temp_directory_path() / ("mcap_export_test_" + std::to_string(::getpid()));
  fs::remove_all(p);
  fs::create_directories(p);
  return p.string();
}

std::uint64_t le(const std::string& b, std::size_t at, int n) {
  std::uint64_t v = 0;
  for (int i = 0; i < n; ++i)
    v |= static_cast<std::uint64_t>(static_cast<std::uint8_t>(b.at(at + static_cast<std::size_t>(i)))) << (8 * i);
  return v;
}
std::string str(const std::string& b, std::size_t& at) {
  const std::size_t n = le(b, at, 4);
  std::string s = b.substr(at + 4, n);
  at += 4 + n;
  return s;
}

// Messages per topic, from the summary section (Channel records and the Statistics record).
std::map<std::string, std::uint64_t> messages_per_topic(const std::string& file) {
  std::ifstream in(file, std::ios::binary);
  const std::string b((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const std::size_t footer = b.size() - 8 - 29;
  std::size_t at = le(b, footer + 9, 8);
  const std::size_t end = le(b, footer + 17, 8);
  std::map<std::uint16_t, std::string> topics;
  std::map<std::string, std::uint64_t> out;
  while (at < end) {
    const std::uint8_t op = static_cast<std::uint8_t>(b[at]);
    const std::size_t content = at + 9, len = le(b, at + 1, 8);
    if (op == static_cast<std::uint8_t>(mcap::Op::kChannel)) {
      std::size_t p = content + 4;
      topics[static_cast<std::uint16_t>(le(b, content, 2))] = str(b, p);
    } else if (op == static_cast<std::uint8_t>(mcap::Op::kStatistics)) {
      const std::size_t map_bytes = le(b, content + 42, 4);
      for (std::size_t p = content + 46; p < content + 46 + map_bytes; p += 10) {
        out[topics.at(static_cast<std::uint16_t>(le(b, p, 2)))] = le(b, p + 2, 8);
      }
    }
    at = content + len;
  }
  return out;
}

// Robot 1 and 2: three poses each, four scans each (robot 2's last refused at receipt), two status rows.
void write_session(const std::string& dir) {
  auto store = SessionStore::open(dir);
  ASSERT_TRUE(store.ok());
  static ScanPoints scan;
  std::int64_t t = 1'700'000'000'000'000'000;
  for (std::uint32_t i = 1; i <= 4; ++i) {
    for (std::uint32_t robot = 1; robot <= 2; ++robot) {
      if (i <= 3) {
        teamscan_msg_RobotPose p{};
        p.robot_id = robot;
        p.seq = i;
        p.stamp_ns = t;
        p.x_mm = static_cast<std::int32_t>(100 * i);
        p.yaw_urad = 500'000;
        store->append_pose(p, ReceiveTime{Time::from_ns(t + 1), Time::from_ns(t + 1)});
      }
      scan = ScanPoints{};
      Receipt receipt;
      receipt.recv_realtime_ns = t + 2;
      scan.robot_id = robot;
      scan.seq = i;
      scan.stamp = Time::from_ns(t);
      scan.count = 3;
      scan.points[0] = {1000, 0, 10, 0, 0};
      scan.points[1] = {0, 0, 0, 1, kPointInvalid};  // no position: NaN in the cloud
      scan.points[2] = {2000, 500, 20, 2, kPointDirectionFiltered};
      receipt.rejected = (robot == 2 && i == 4) ? 1 : 0;
      store->append_scan(scan, receipt);
      if (i <= 2) {
        teamscan_msg_RobotStatus st{};
        st.robot_id = robot;
        st.seq = i;
        st.stamp_ns = t;
        store->append_status(st, ReceiveTime{Time::from_ns(t + 3), Time::from_ns(t + 3)});
      }
    }
    t += 100'000'000;
  }
}

class SessionExport : public ::testing::Test {
 protected:
  void SetUp() override {
    root_ = temp_dir();
    session_ = root_ + "/session";
    write_session(session_);
    out_ = root_ + "/out.mcap";
  }
  void TearDown() override { fs::remove_all(root_); }
  Result<SessionExportSummary> run(const SessionExportOptions& o = {}) {
    message_.clear();
    return export_session_mcap(session_, out_, o, message_);
  }
  void expect_refused(const std::string& about) {
    auto r = run();
    ASSERT_FALSE(r.ok());
    EXPECT_NE(message_.find(about), std::string::npos) << message_;
    EXPECT_FALSE(fs::exists(out_));
    EXPECT_FALSE(fs::exists(out_ + ".partial"));
  }
  std::string root_, session_, out_, message_;
};

TEST_F(SessionExport, EveryAcceptedSampleIsOneMessageOnItsTopic) {
  auto r = run();
  ASSERT_TRUE(r.ok()) << message_;
  EXPECT_EQ(r->scans, 7u);
  EXPECT_EQ(r->refused_scans, 1u);
  EXPECT_EQ(r->poses, 6u);
  EXPECT_EQ(r->statuses, 4u);
  EXPECT_EQ(r->tf_messages, 6u);
  EXPECT_EQ(r->tracks, 6u) << "a track after every pose";
  EXPECT_EQ(r->laser_frames, 0u) << "no robot config given";
  EXPECT_EQ(r->bytes, fs::file_size(out_));
  const auto topics = messages_per_topic(out_);
  EXPECT_EQ(topics.at("/robot1/scan"), 4u);
  EXPECT_EQ(topics.at("/robot2/scan"), 3u);
  EXPECT_EQ(topics.at("/robot1/odom"), 3u);
  EXPECT_EQ(topics.at("/robot2/odom"), 3u);
  EXPECT_EQ(topics.at("/robot1/status"), 2u);
  EXPECT_EQ(topics.at("/tf"), 6u);
  EXPECT_EQ(topics.at("/robot1/track"), 3u);
  EXPECT_EQ(topics.count("/tf_static"), 0u);
  EXPECT_EQ(r->messages, 7u + 6u + 4u + 6u + 6u);
}

TEST_F(SessionExport, RobotConfigsPutTheLasersOnTfStatic) {
  const std::string cfg = root_ + "/robot1.toml";
  std::ofstream(cfg) << "[robot]\nid = 1\n[arcos]\ndevice = \"/dev/null\"\n[lms]\ndevice = \"/dev/zero\"\n"
                        "[mount]\nx_m = 0.1\ny_m = 0.0\nz_m = 0.4\nroll_deg = 0\npitch_deg = 15\nyaw_deg = 0\n";
  SessionExportOptions o;
  o.robot_configs = {cfg};
  auto r = run(o);
  ASSERT_TRUE(r.ok()) << message_;
  EXPECT_EQ(r->laser_frames, 1u);
  EXPECT_EQ(messages_per_topic(out_).at("/tf_static"), 1u);
}

TEST_F(SessionExport, DamagedScanRecordsAreSkippedAndCounted) {
  {
    std::fstream f(session_ + "/scans.bin", std::ios::in | std::ios::out | std::ios::binary);
    f.seekp(static_cast<std::streamoff>(station::kScanFileHeaderBytes + 30));  // inside the first record
    f.put('\x7f');
  }
  auto r = run();
  ASSERT_TRUE(r.ok()) << message_;
  EXPECT_EQ(r->scans, 6u);
  EXPECT_EQ(r->damaged_scan_records, 1u);
}

TEST_F(SessionExport, MissingFolderIsRefused) {
  session_ = root_ + "/nowhere";
  expect_refused("no such folder");
}

TEST_F(SessionExport, FolderWithoutSessionFilesIsRefused) {
  session_ = root_ + "/empty";
  fs::create_directories(session_);
  expect_refused("not a ground-station session folder");
}

TEST_F(SessionExport, ScansFileWithoutHeaderIsRefused) {
  std::ofstream(session_ + "/scans.bin", std::ios::trunc) << "not a scans file at all";
  expect_refused("scans.bin");
}

TEST_F(SessionExport, StatusFileWithAForeignHeaderIsRefused) {
  std::ofstream(session_ + "/status.csv", std::ios::trunc) << "a,b,c\n1,2,3\n";
  expect_refused("status.csv");
}

TEST_F(SessionExport, UnreadableModelIsRefused) {
  std::ofstream(session_ + "/fused.pcd") << "# .PCD v0.7\nVERSION 0.7\nFIELDS x\n";
  expect_refused("fused.pcd");
}

TEST_F(SessionExport, BadRobotConfigIsRefused) {
  SessionExportOptions o;
  o.robot_configs = {root_ + "/missing.toml"};
  auto r = run(o);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(message_.find("missing.toml"), std::string::npos) << message_;
}

TEST_F(SessionExport, UnwritableOutputIsRefused) {
  out_ = root_ + "/no/such/dir/out.mcap";
  expect_refused("cannot create");
}

}  // namespace
}  // namespace teamscan::mcap_export
