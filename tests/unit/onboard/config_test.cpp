// Tests of the onboard config: the deploy/ examples parse to the values they state; malformed and
// inconsistent configs are refused with a message naming the key.
#include "onboard/core/config.hpp"

#include <gtest/gtest.h>

#include <cstdlib>
#include <string>

namespace teamscan::onboard {
namespace {

std::string source_dir() {
  const char* d = std::getenv("TEAMSCAN_SOURCE_DIR");
  return d != nullptr ? d : ".";
}

constexpr const char* kMinimal = R"(
[robot]
id = 3
[arcos]
device = "/dev/ttyUSB0"
[lms]
device = "/dev/ttyUSB1"
[mount]
x_m = 0.1
y_m = 0
z_m = 0.5
pitch_deg = 10
)";

TEST(OnboardConfig, DownLaserExample) {
  std::string msg;
  const auto c = load_onboard_config(source_dir() + "/deploy/onboard-down-laser.toml", msg);
  ASSERT_TRUE(c.ok()) << msg;
  EXPECT_EQ(c->robot_id, 1u);
  EXPECT_EQ(c->arcos_device, "/dev/ttyS0");
  EXPECT_EQ(c->arcos_baud, 9600u);
  EXPECT_EQ(c->lms_device, "/dev/ttyS1");
  EXPECT_EQ(c->lms_baud, 500000u);
  EXPECT_EQ(c->lms_variant, (LaserVariant{180, 50}));
  EXPECT_EQ(c->max_range_mm(), 8000u);
  EXPECT_GT(c->mount.pitch_deg, 0.0);  // nose down
  EXPECT_TRUE(c->filter.range_gate);
  EXPECT_TRUE(c->filter.height_gate);
  EXPECT_EQ(c->filter.stale_policy, cone::StalePolicy::widen);
  EXPECT_EQ(c->filter.max_team_age, 500ms);
  EXPECT_EQ(c->publish, PublishMode::all);
  EXPECT_EQ(c->scan_history_depth, 300u);
  EXPECT_EQ(c->status_period, 1s);
  // The mount pitched down: the laser's x axis points below the horizon.
  const Vec3 ahead = c->mount.robot_from_laser().rotation.apply({1, 0, 0});
  EXPECT_LT(ahead.z, 0.0);
}

TEST(OnboardConfig, UpLaserExample) {
  std::string msg;
  const auto c = load_onboard_config(source_dir() + "/deploy/onboard-up-laser.toml", msg);
  ASSERT_TRUE(c.ok()) << msg;
  EXPECT_EQ(c->robot_id, 2u);
  const Vec3 ahead = c->mount.robot_from_laser().rotation.apply({1, 0, 0});
  EXPECT_GT(ahead.z, 0.0);
}

TEST(OnboardConfig, MinimalConfigTakesDefaults) {
  std::string msg;
  const auto c = parse_onboard_config(kMinimal, msg);
  ASSERT_TRUE(c.ok()) << msg;
  EXPECT_EQ(c->robot_id, 3u);
  EXPECT_EQ(c->lms_baud, 500000u);
  EXPECT_DOUBLE_EQ(c->filter.half_angle_deg, 7.0);
  EXPECT_FALSE(c->filter.range_gate);  // the paper's rule unless the gates are asked for
  EXPECT_TRUE(c->filter_enabled);
  EXPECT_DOUBLE_EQ(c->map_from_odom().x_m, 0.0);
}

// Replaces `from` in the minimal config by `to` (or appends `to` if from is empty) and parses.
std::string refuse(const std::string& from, const std::string& to) {
  std::string text = kMinimal;
  if (from.empty()) text += to;
  else {
    const auto at = text.find(from);
    EXPECT_NE(at, std::string::npos) << from;
    text.replace(at, from.size(), to);
  }
  std::string msg;
  const auto c = parse_onboard_config(text, msg);
  EXPECT_FALSE(c.ok()) << text;
  return msg;
}

#define EXPECT_NAMES(msg, key) EXPECT_EQ((msg).rfind(key, 0), 0u) << "message: " << (msg)

TEST(OnboardConfig, ErrorsNameTheKey) {
  EXPECT_NAMES(refuse("id = 3", "id = 0"), "robot.id:");
  EXPECT_NAMES(refuse("id = 3", "id = 33"), "robot.id:");
  EXPECT_NAMES(refuse("id = 3", "id = \"three\""), "robot.id: must be an integer");
  EXPECT_NAMES(refuse("id = 3\n", ""), "robot.id: missing");
  EXPECT_NAMES(refuse("[lms]\ndevice = \"/dev/ttyUSB1\"", ""), "lms: missing section");
  EXPECT_NAMES(refuse("", "[filter]\nhalf_angle_deg = 75\n"), "filter.half_angle_deg:");
  EXPECT_NAMES(refuse("", "[filter]\nhalf_angel_deg = 5\n"), "filter.half_angel_deg: unknown key");
  EXPECT_NAMES(refuse("", "[filter]\nstale_policy = \"ignore\"\n"), "filter.stale_policy:");
  EXPECT_NAMES(refuse("", "[filter]\nmax_team_age_s = 0\n"), "filter.max_team_age_s:");
  EXPECT_NAMES(refuse("", "[filter]\nrange_gate = 1\n"), "filter.range_gate: must be true or false");
  EXPECT_NAMES(refuse("", "[dds]\npublish = \"some\"\n"), "dds.publish:");
  EXPECT_NAMES(refuse("", "[dds]\nscan_history_depth = 0\n"), "dds.scan_history_depth:");
  EXPECT_NAMES(refuse("", "[status]\nperiod_s = 0\n"), "status.period_s:");
  EXPECT_NAMES(refuse("", "[extra]\nx = 1\n"), "extra: unknown section");
  EXPECT_NAMES(refuse("pitch_deg = 10", "pitch_deg = 200"), "mount.pitch_deg:");
  EXPECT_NAMES(refuse("pitch_deg = 10\n", ""), "mount.pitch_deg: missing");
  EXPECT_NAMES(refuse("z_m = 0.5", "z_m = -1"), "mount.z_m:");
}

TEST(OnboardConfig, Ring) {
  std::string msg;
  auto off = parse_onboard_config(kMinimal, msg);
  ASSERT_TRUE(off.ok()) << msg;
  EXPECT_FALSE(off->ring.enabled());  // no [ring]: no store and forward
  auto c = parse_onboard_config(std::string{kMinimal} + "[ring]\npath = \"/var/lib/teamscan/ring.bin\"\ncapacity_s = 1800\n"
                                                        "flush_records = 10\nflush_period_s = 0.25\nbackfill_rate_hz = 200\n", msg);
  ASSERT_TRUE(c.ok()) << msg;
  EXPECT_TRUE(c->ring.enabled());
  EXPECT_EQ(c->ring.slots(), 153000u);  // 30 min of 75 scans and 10 poses a second
  EXPECT_EQ(c->ring.flush_records, 10u);
  EXPECT_EQ(c->ring.flush_period, std::chrono::milliseconds(250));
  EXPECT_DOUBLE_EQ(c->ring.backfill_rate_hz, 200.0);
  EXPECT_NAMES(refuse("", "[ring]\npath = \"\"\n"), "ring.path:");
  EXPECT_NAMES(refuse("", "[ring]\npath = \"/r\"\ncapacity_s = 0.5\n"), "ring.capacity_s:");
  EXPECT_NAMES(refuse("", "[ring]\npath = \"/r\"\nflush_records = 0\n"), "ring.flush_records:");
  EXPECT_NAMES(refuse("", "[ring]\npath = \"/r\"\nflush_period_s = 0\n"), "ring.flush_period_s:");
  EXPECT_NAMES(refuse("", "[ring]\npath = \"/r\"\nbackfill_rate_hz = 0\n"), "ring.backfill_rate_hz:");
  EXPECT_NAMES(refuse("", "[ring]\nsize = 3\n"), "ring.size: unknown key");
}

TEST(OnboardConfig, InconsistentSettingsAreRefused) {
  EXPECT_NAMES(refuse("\"/dev/ttyUSB1\"", "\"/dev/ttyUSB0\""), "lms.device: is the same device as arcos.device");
  EXPECT_NAMES(refuse("[lms]\n", "[lms]\nbaud = 57600\n"), "lms.baud:");
  EXPECT_NAMES(refuse("[arcos]\n", "[arcos]\nbaud = 500000\n"), "arcos.baud:");
  EXPECT_NAMES(refuse("[lms]\n", "[lms]\nresolution_deg = 0.25\n"), "lms.resolution_deg: 0.25 needs fov_deg = 100");
  EXPECT_NAMES(refuse("[lms]\n", "[lms]\nfov_deg = 90\n"), "lms.fov_deg:");
  EXPECT_NAMES(refuse("[lms]\n", "[lms]\nmax_range_m = 20\n"), "lms.max_range_m:");  // mm units: 8.18 m
  std::string msg;
  std::string text = kMinimal;
  text.replace(text.find("[lms]\n"), 6, "[lms]\nunits = \"cm\"\nmax_range_m = 80\nfov_deg = 100\nresolution_deg = 0.25\n");
  const auto c = parse_onboard_config(text, msg);
  ASSERT_TRUE(c.ok()) << msg;
  EXPECT_EQ(c->max_range_mm(), 80000u);
  EXPECT_EQ(c->lms_variant.beams(), 401);
}

TEST(OnboardConfig, SyntaxErrorGivesTheLine) {
  std::string msg;
  const auto c = parse_onboard_config("[robot]\nid = 1\n[arcos\n", msg);
  ASSERT_FALSE(c.ok());
  EXPECT_EQ(c.error().detail, 3);
  EXPECT_NE(msg.find("line 3"), std::string::npos) << msg;
}

TEST(OnboardConfig, ControlCharactersAreRefused) {
  std::string msg;
  const std::string text = std::string("[robot]\nid = 1\n[") + '\0' + "arcos]\n";
  const auto c = parse_onboard_config(text, msg);
  ASSERT_FALSE(c.ok());
  EXPECT_EQ(c.error().detail, 3);
  EXPECT_NE(msg.find("control character 0x00"), std::string::npos) << msg;
}

TEST(OnboardConfig, BadTableHeaderIsASyntaxError) {
  std::string msg;
  const auto c = parse_onboard_config("[robot]\nid = 1\n  [ !arcos]\n", msg);
  ASSERT_FALSE(c.ok());
  EXPECT_EQ(c.error().detail, 3);
  EXPECT_NE(msg.find("line 3"), std::string::npos) << msg;
}

TEST(OnboardConfig, NonAsciiOnlyInComments) {
  std::string msg;
  std::string text = kMinimal;
  text += "# 60\xC2\xB0 at most\n[filter]\nhalf_angle_deg = 7 # 7\xC2\xB0\n";
  EXPECT_TRUE(parse_onboard_config(text, msg).ok()) << msg;
  const auto c = parse_onboard_config("[robot]\nid = \"\xC3\x9D\"\n", msg);
  ASSERT_FALSE(c.ok());
  EXPECT_NE(msg.find("line 2: non-ASCII"), std::string::npos) << msg;
}

TEST(OnboardConfig, RangeErrorsPointAtTheirLine) {
  std::string msg;
  std::string text = kMinimal;
  text.replace(text.find("id = 3"), 6, "id = 99");
  const auto c = parse_onboard_config(text, msg);
  ASSERT_FALSE(c.ok());
  EXPECT_EQ(c.error().detail, 3);  // kMinimal starts with a newline: [robot] is line 2
  EXPECT_NE(msg.find("(line 3)"), std::string::npos) << msg;
}

TEST(OnboardConfig, MissingFileIsAnError) {
  std::string msg;
  const auto c = load_onboard_config("/nonexistent/teamscan.toml", msg);
  ASSERT_FALSE(c.ok());
  EXPECT_NE(msg.find("/nonexistent/teamscan.toml"), std::string::npos);
}

// [odometry] max_hold_s (docs/demo.md "Latency"): default = the extrapolation limit (the behaviour
// before the key), 0 allowed (publish at once), bounded by max_extrapolation_s, bad values named.
Result<OnboardConfig> parse_with_odometry(const std::string& odometry, std::string& msg) {
  return parse_onboard_config(std::string{kMinimal} + "[odometry]\n" + odometry, msg);
}

TEST(OnboardConfigHold, DefaultsToTheExtrapolationLimit) {
  std::string msg;
  auto c = parse_onboard_config(kMinimal, msg);
  ASSERT_TRUE(c.ok()) << msg;
  EXPECT_EQ(c->odometry_max_hold, c->odometry_max_extrapolation);
  c = parse_with_odometry("max_extrapolation_s = 0.3\n", msg);
  ASSERT_TRUE(c.ok()) << msg;
  EXPECT_EQ(c->odometry_max_hold, from_seconds(0.3));
}

TEST(OnboardConfigHold, ZeroAndBoundaryAccepted) {
  std::string msg;
  auto c = parse_with_odometry("max_hold_s = 0\n", msg);
  ASSERT_TRUE(c.ok()) << msg;
  EXPECT_EQ(c->odometry_max_hold, Duration::zero());
  c = parse_with_odometry("max_extrapolation_s = 0.2\nmax_hold_s = 0.2\n", msg);
  ASSERT_TRUE(c.ok()) << msg;
  EXPECT_EQ(c->odometry_max_hold, from_seconds(0.2));
  c = parse_with_odometry("max_hold_s = 0.05\n", msg);
  ASSERT_TRUE(c.ok()) << msg;
  EXPECT_EQ(c->odometry_max_hold, from_seconds(0.05));
  EXPECT_NE(describe(*c).find("hold 0.050 s"), std::string::npos) << describe(*c);
}

TEST(OnboardConfigHold, OutOfRangeIsRefusedByName) {
  for (const char* bad : {"max_hold_s = -0.01\n", "max_extrapolation_s = 0.1\nmax_hold_s = 0.15\n", "max_hold_s = 2\n",
                          "max_hold_s = \"soon\"\n"}) {
    std::string msg;
    const auto c = parse_with_odometry(bad, msg);
    EXPECT_FALSE(c.ok()) << bad;
    EXPECT_NE(msg.find("odometry.max_hold_s"), std::string::npos) << bad << " -> " << msg;
  }
}

}  // namespace
}  // namespace teamscan::onboard
