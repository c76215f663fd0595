// The demo's link faults (tools/demo/link_faults.hpp): option syntax, the per-namespace Cyclone config
// derived from the site's and the loopback one, and a shadow as the robot's statuses report it.
#include "tools/demo/link_faults.hpp"

#include <gtest/gtest.h>

#include <fstream>
#include <sstream>
#include <string>

namespace teamscan::demo {
namespace {

std::string slurp(const std::string& path) {
  std::ifstream in(path);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

TEST(LinkLoss, PercentOrPerMille) {
  EXPECT_EQ(parse_link_loss_permille("20").value(), 200);
  EXPECT_EQ(parse_link_loss_permille("20%").value(), 200);
  EXPECT_EQ(parse_link_loss_permille("2.5").value(), 25);
  EXPECT_EQ(parse_link_loss_permille("150pm").value(), 150);
  EXPECT_EQ(parse_link_loss_permille("0").value(), 0);
  EXPECT_EQ(parse_link_loss_permille("100").value(), 1000);
  for (const char* bad : {"", "%", "x", "-1", "101", "1001pm", "20 %", "nan", "20%%"})
    EXPECT_FALSE(parse_link_loss_permille(bad).ok()) << bad;
}

TEST(Shadow, RobotAtFor) {
  const LinkShadow s = parse_shadow("2:12.5:10").value();
  EXPECT_EQ(s.robot_id, 2);
  EXPECT_DOUBLE_EQ(s.at_s, 12.5);
  EXPECT_DOUBLE_EQ(s.for_s, 10.0);
  for (const char* bad : {"", "1", "1:2", "1:2:3:4", "0:1:1", "33:1:1", "x:1:1", "1:-1:5", "1:1:0", "1:a:5", "1:1:b"})
    EXPECT_FALSE(parse_shadow(bad).ok()) << bad;
  const Result<LinkShadow> e = parse_shadow("1:2");
  EXPECT_NE(std::string{e.error().what}.find("ROBOT:AT:FOR"), std::string::npos) << e.error().what;
}

TEST(Shadow, OverlappingShadowsOfOneRobotAreRefused) {
  EXPECT_TRUE(check_shadows({{1, 5, 10}, {1, 15, 10}, {2, 6, 10}}).ok());  // back to back, another robot
  EXPECT_FALSE(check_shadows({{1, 5, 10}, {1, 14, 10}}).ok());
  EXPECT_FALSE(check_shadows({{1, 14, 10}, {1, 5, 10}}).ok());
}

// The site config (and the loopback one) for a namespace: its interface, no multicast, the peers, the
// loss; nothing of the site's network or loopback is left.
TEST(NamespaceDdsConfig, FromTheSiteAndTheLoopbackConfig) {
  const std::string root = TEAMSCAN_TEST_DATA_DIR "/../../deploy/";
  for (const char* file : {"cyclonedds-site.xml", "cyclonedds-lo.xml"}) {
    const Result<std::string> x =
        namespace_dds_config(slurp(root + file), "10.77.0.11", {"10.77.0.1", "10.77.0.11"}, 200);
    ASSERT_TRUE(x.ok()) << file << ": " << x.error().what;
    const std::string& t = x.value();
    EXPECT_NE(t.find("<NetworkInterface address=\"10.77.0.11\" multicast=\"false\"/>"), std::string::npos) << t;
    EXPECT_NE(t.find("<AllowMulticast>false</AllowMulticast>"), std::string::npos) << t;
    EXPECT_NE(t.find("<Peers><Peer address=\"10.77.0.1\"/><Peer address=\"10.77.0.11\"/></Peers>"), std::string::npos)
        << t;
    EXPECT_NE(t.find("<XmitLossiness>200</XmitLossiness>"), std::string::npos) << t;
    EXPECT_EQ(t.find("127.0.0.1"), std::string::npos) << t;
    EXPECT_EQ(t.find("192.168."), std::string::npos) << t;
    EXPECT_EQ(t.find("wlan0"), std::string::npos) << t;
    EXPECT_EQ(t.find("<Internal>"), t.rfind("<Internal>")) << "one Internal element\n" << t;
  }
  EXPECT_FALSE(namespace_dds_config("<CycloneDDS><Domain></Domain></CycloneDDS>", "10.77.0.1", {}, 0).ok());
}

StatusRow row(std::uint32_t id, double t_s, std::uint32_t unconfirmed, std::uint32_t shadow_ms, std::uint32_t last_ms,
              std::uint32_t total, std::uint32_t remaining) {
  StatusRow r;
  r.robot_id = id;
  r.stamp_ns = static_cast<std::int64_t>(t_s * 1e9);
  r.ring_unconfirmed = unconfirmed;
  r.shadow_ms = shadow_ms;
  r.last_shadow_ms = last_ms;
  r.backfill_total = total;
  r.backfill_remaining = remaining;
  return r;
}

// Link down at 10 s, up at 20 s: the robot's status says it is back at 21 s (shadow 13.2 s by its own
// count), back-fills 900 scans, and has nothing left at 25 s; another robot's rows do not count.
TEST(ShadowReport, FromTheRobotsStatuses) {
  const std::vector<StatusRow> rows{
      row(1, 9, 60, 0, 0, 0, 0),         row(1, 19, 800, 6000, 0, 0, 0),       row(2, 22, 5000, 0, 0, 0, 0),
      row(1, 20.5, 1300, 9000, 0, 0, 0), row(1, 21, 1400, 0, 13200, 900, 800), row(1, 23, 600, 0, 13200, 900, 300),
      row(1, 25, 80, 0, 13200, 900, 0),  row(1, 26, 2000, 0, 13200, 900, 0)};
  const ShadowReport r = shadow_report(rows, {1, 10, 10}, 10'000'000'000, 20'000'000'000);
  EXPECT_DOUBLE_EQ(r.robot_shadow_s, 13.2);
  EXPECT_EQ(r.buffered_max, 1400u);  // not robot 2's, not after whole again
  EXPECT_EQ(r.backfill_total, 900u);
  EXPECT_NEAR(r.whole_after_s, 5.0, 1e-9);
  EXPECT_NE(shadow_text(r).find("whole again 5.0 s after its return"), std::string::npos) << shadow_text(r);

  // Still back-filling when the run ended: never whole.
  const ShadowReport never =
      shadow_report({rows.begin(), rows.begin() + 6}, {1, 10, 10}, 10'000'000'000, 20'000'000'000);
  EXPECT_LT(never.whole_after_s, 0);
  EXPECT_NE(shadow_text(never).find("NOT whole again"), std::string::npos) << shadow_text(never);

  ReportJson robots = ReportJson::array();
  robots.push_back({{"id", 1}});
  robots.push_back({{"id", 2}});
  add_shadows_to_robots({r, never}, robots);
  EXPECT_EQ(robots[0]["shadows"], 2);
  EXPECT_EQ(robots[0]["whole_again"], false);
  EXPECT_EQ(robots[1]["shadows"], 0);
  EXPECT_EQ(robots[1]["whole_again"], true);
}

}  // namespace
}  // namespace teamscan::demo
