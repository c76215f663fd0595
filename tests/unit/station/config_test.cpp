// Ground-station config: the commented example in deploy/ parses to the defaults; errors name the key.
#include <gtest/gtest.h>

#include <cstdlib>

#include "groundstation/station/config.hpp"

namespace teamscan::station {
namespace {

TEST(GroundStationConfig, DeployExampleParsesAndEqualsTheDefaults) {
  const char* src = std::getenv("TEAMSCAN_SOURCE_DIR");
  ASSERT_NE(src, nullptr);
  GroundStationConfig c;
  ConfigError e;
  ASSERT_TRUE(load_groundstation_config(std::string(src) + "/deploy/groundstation.toml", c, e)) << e.message;
  const GroundStationConfig d;
  EXPECT_EQ(c.session_root, d.session_root);
  EXPECT_EQ(c.station.scan_history_depth, d.station.scan_history_depth);
  EXPECT_EQ(c.station.team_period, d.station.team_period);
  EXPECT_EQ(c.station.silence_timeout, d.station.silence_timeout);
  EXPECT_EQ(c.station.domain_id, d.station.domain_id);
  EXPECT_DOUBLE_EQ(c.last_pose.default_body.length_m, d.last_pose.default_body.length_m);
  EXPECT_DOUBLE_EQ(c.last_pose.sigma_velocity_mps, d.last_pose.sigma_velocity_mps);
  EXPECT_DOUBLE_EQ(c.kalman.lost_after_s, d.kalman.lost_after_s);
  EXPECT_EQ(c.team_source, TeamSourceKind::kKalman);
}

TEST(GroundStationConfig, TeamSourceChoice) {
  GroundStationConfig c;
  ConfigError e;
  ASSERT_TRUE(parse_groundstation_config("[team]\nsource = \"last_pose\"\n", "t.toml", c, e)) << e.message;
  EXPECT_EQ(c.team_source, TeamSourceKind::kLastPose);
  EXPECT_FALSE(parse_groundstation_config("[team]\nsource = \"magic\"\n", "t.toml", c, e));
  EXPECT_NE(e.message.find("team.source"), std::string::npos);
  ASSERT_TRUE(parse_groundstation_config("[team]\nsource = \"kalman\"\n", "t.toml", c, e)) << e.message;
  EXPECT_EQ(c.team_source, TeamSourceKind::kKalman);
}

TEST(GroundStationConfig, ValuesAreApplied) {
  GroundStationConfig c;
  ConfigError e;
  ASSERT_TRUE(parse_groundstation_config("[team]\npublish_rate_hz = 10\nsilence_timeout_s = 0\n[dds]\ndomain_id = 7\n"
                                         "scan_history_depth = 1000\n",
                                         "t.toml", c, e))
      << e.message;
  EXPECT_EQ(c.station.team_period, std::chrono::milliseconds(100));
  EXPECT_EQ(c.station.silence_timeout.count(), 0);
  EXPECT_EQ(c.station.domain_id, 7u);
  EXPECT_EQ(c.station.scan_history_depth, 1000u);
}

struct Bad {
  const char* text;
  const char* key_in_message;
};

TEST(GroundStationConfig, BadInputNamesTheKey) {
  const Bad cases[] = {
      {"[team]\npublish_rate_hz = 0\n", "team.publish_rate_hz"},
      {"[team]\npublish_rate_hz = \"fast\"\n", "team.publish_rate_hz"},
      {"[dds]\nscan_history_depth = 0\n", "dds.scan_history_depth"},
      {"[dds]\nscan_history_depth = 1.5\n", "dds.scan_history_depth"},
      {"[team.body]\nheight_m = -1\n", "team.body.height_m"},
      {"[station]\nsession_root = \"\"\n", "station.session_root"},
      {"[team]\npublish_rate = 20\n", "team.publish_rate"},  // misspelt: unknown key
      {"[team\n", "t.toml:1"},                               // syntax error with its location
  };
  for (const Bad& b : cases) {
    GroundStationConfig c;
    ConfigError e;
    EXPECT_FALSE(parse_groundstation_config(b.text, "t.toml", c, e)) << b.text;
    EXPECT_NE(e.message.find(b.key_in_message), std::string::npos) << e.message;
  }
}

}  // namespace
}  // namespace teamscan::station
