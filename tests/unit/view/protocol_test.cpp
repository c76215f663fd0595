// The view's wire protocol: voxel messages byte by byte and round trip, decoder errors, state JSON.
#include "groundstation/view/protocol.hpp"

#include <gtest/gtest.h>

#include <limits>

#include <nlohmann/json.hpp>

namespace teamscan::view {
namespace {

TEST(ViewProtocol, VoxelMessageBytesAreTheDocumentedLayout) {
  VoxelMessage m;
  m.kind = VoxelKind::kChanged;
  m.seq = 0x01020304;
  m.resolution_mm = 100;
  m.total_voxels = 7;
  m.voxels.push_back(WireVoxel{-50, 150, 250, 0x1234, 1, 2});
  const std::string b = encode_voxels(m);
  ASSERT_EQ(b.size(), kVoxelHeaderBytes + kVoxelBytes);
  // clang-format off
  const unsigned char expected[] = {
      'T', 'S', 'V', 'X', 1, 0, 2, 0,          // magic, version 1, kind 2 (changed)
      0x04, 0x03, 0x02, 0x01, 1, 0, 0, 0,      // seq, count 1
      100, 0, 0, 0, 7, 0, 0, 0,                // resolution_mm, total_voxels
      0xCE, 0xFF, 0xFF, 0xFF, 150, 0, 0, 0,    // x_mm -50, y_mm 150
      250, 0, 0, 0, 0x34, 0x12, 1, 2};         // z_mm 250, hits, flags (removed), robot 2
  // clang-format on
  for (std::size_t i = 0; i < sizeof expected; ++i) {
    EXPECT_EQ(static_cast<unsigned char>(b[i]), expected[i]) << "byte " << i;
  }
}

TEST(ViewProtocol, VoxelMessageRoundTrip) {
  VoxelMessage m;
  m.kind = VoxelKind::kWholeMap;
  m.seq = 9;
  m.resolution_mm = 50;
  m.total_voxels = 3;
  m.voxels = {{1, 2, 3, 4, 0, 1}, {-1000000, 2000000, -3, 65535, 1, 32}, {0, 0, 0, 1, 0, 0}};
  const auto d = decode_voxels(encode_voxels(m));
  ASSERT_TRUE(d.ok()) << d.error().what;
  EXPECT_EQ(d.value().kind, VoxelKind::kWholeMap);
  EXPECT_EQ(d.value().seq, 9u);
  EXPECT_EQ(d.value().resolution_mm, 50u);
  EXPECT_EQ(d.value().total_voxels, 3u);
  EXPECT_EQ(d.value().voxels, m.voxels);
}

TEST(ViewProtocol, DecoderNamesWhatIsWrong) {
  VoxelMessage m;
  m.voxels.resize(2);
  const std::string good = encode_voxels(m);
  EXPECT_FALSE(decode_voxels(good.substr(0, 10)).ok());
  std::string bad_magic = good;
  bad_magic[0] = 'X';
  EXPECT_STREQ(decode_voxels(bad_magic).error().what, "view: voxel message: bad magic");
  std::string bad_version = good;
  bad_version[4] = 9;
  EXPECT_STREQ(decode_voxels(bad_version).error().what, "view: voxel message: unknown version");
  std::string bad_kind = good;
  bad_kind[6] = 7;
  EXPECT_STREQ(decode_voxels(bad_kind).error().what, "view: voxel message: unknown kind");
  EXPECT_STREQ(decode_voxels(good.substr(0, good.size() - 1)).error().what,
               "view: voxel message: length does not match its count");
  EXPECT_STREQ(decode_voxels(good + "x").error().what, "view: voxel message: length does not match its count");
}

TEST(ViewProtocol, StateIsJsonWithEveryRobotField) {
  RobotView r;
  r.state.robot_id = 3;
  r.state.lost = true;
  r.state.x_m = 1.25;
  r.state.y_m = -2.5;
  r.state.yaw_rad = 0.5;
  r.state.cov_xx_m2 = 0.0004;
  r.state.cov_xy_m2 = -0.0001;
  r.state.cov_yy_m2 = 0.0009;
  r.state.scans = 1000;
  r.state.scans_lost = 4;
  r.state.ghosts_removed = 77;
  r.state.latency_ms = 12.34;
  r.state.shadow_s = 43.04;
  r.state.scans_buffered = 3200;
  r.state.backfill_pct = 37.0;
  r.state.last_shadow_s = 12.5;
  r.state.whole_again_ns = 1700000000000000001;
  r.scan_rate_hz = 75.0;
  const float track[] = {0.0f, 0.0f, 1.0f, 0.5f};
  r.track_xy = track;
  r.track_whole = true;
  StateHeader h;
  h.seq = 42;
  h.stamp_ns = 1700000000123456789;
  h.whole = true;
  h.map_voxels = 1234;
  h.map_resolution_mm = 100;
  const nlohmann::json j = nlohmann::json::parse(encode_state(h, std::span<const RobotView>(&r, 1), true));
  EXPECT_EQ(j["type"], "state");
  EXPECT_EQ(j["whole"], true);
  EXPECT_EQ(j["seq"], 42);
  EXPECT_EQ(j["stamp_ns"].get<std::int64_t>(), 1700000000123456789);
  EXPECT_EQ(j["map_voxels"], 1234);
  EXPECT_DOUBLE_EQ(j["resolution_m"].get<double>(), 0.1);
  ASSERT_EQ(j["robots"].size(), 1u);
  const auto& o = j["robots"][0];
  EXPECT_EQ(o["id"], 3);
  EXPECT_EQ(o["lost"], true);
  EXPECT_DOUBLE_EQ(o["x_m"].get<double>(), 1.25);
  EXPECT_DOUBLE_EQ(o["y_m"].get<double>(), -2.5);
  EXPECT_DOUBLE_EQ(o["yaw_rad"].get<double>(), 0.5);
  EXPECT_DOUBLE_EQ(o["cov_xx_m2"].get<double>(), 0.0004);
  EXPECT_DOUBLE_EQ(o["cov_xy_m2"].get<double>(), -0.0001);
  EXPECT_DOUBLE_EQ(o["cov_yy_m2"].get<double>(), 0.0009);
  EXPECT_EQ(o["scans"], 1000);
  EXPECT_EQ(o["scans_lost"], 4);
  EXPECT_EQ(o["ghosts_removed"], 77);
  EXPECT_DOUBLE_EQ(o["latency_ms"].get<double>(), 12.3);  // one decimal
  EXPECT_DOUBLE_EQ(o["scan_rate_hz"].get<double>(), 75.0);
  EXPECT_DOUBLE_EQ(o["shadow_s"].get<double>(), 43.0);  // one decimal
  EXPECT_EQ(o["scans_buffered"], 3200);
  EXPECT_DOUBLE_EQ(o["backfill_pct"].get<double>(), 37.0);
  EXPECT_DOUBLE_EQ(o["last_shadow_s"].get<double>(), 12.5);
  EXPECT_EQ(o["whole_again_ns"].get<std::int64_t>(), 1700000000000000001);
  EXPECT_EQ(o["track"], nlohmann::json::parse("[0.0,0.0,1.0,0.5]"));
  EXPECT_FALSE(o.contains("track_add"));

  r.track_whole = false;
  const nlohmann::json k = nlohmann::json::parse(encode_state(h, std::span<const RobotView>(&r, 1), true));
  EXPECT_TRUE(k["robots"][0].contains("track_add"));
  const nlohmann::json none = nlohmann::json::parse(encode_state(h, std::span<const RobotView>(&r, 1), false));
  EXPECT_FALSE(none["robots"][0].contains("track"));
  EXPECT_FALSE(none["robots"][0].contains("track_add"));
}

TEST(ViewProtocol, AFigureThatIsNotANumberIsNullAndTheMessageStillParses) {
  RobotView r;
  r.state.robot_id = 2;
  r.state.latency_ms = std::numeric_limits<double>::quiet_NaN();
  r.state.x_m = 1.23456;
  StateHeader h;
  const nlohmann::json j = nlohmann::json::parse(encode_state(h, std::span<const RobotView>(&r, 1), false));
  EXPECT_TRUE(j["robots"][0]["latency_ms"].is_null());
  EXPECT_DOUBLE_EQ(j["robots"][0]["x_m"].get<double>(), 1.2346);  // to 0.1 mm
}

TEST(ViewProtocol, ErrorMessagesAreEscapedJson) {
  const nlohmann::json j = nlohmann::json::parse(encode_error("bad \"thing\"\n\\ \x01"));
  EXPECT_EQ(j["type"], "error");
  EXPECT_EQ(j["error"], "bad \"thing\"\n\\ \x01");
}

}  // namespace
}  // namespace teamscan::view
