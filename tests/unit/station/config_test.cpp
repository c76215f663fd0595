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
  EXPECT_EQ(c.ros2.enabled, d.ros2.enabled);
  EXPECT_EQ(c.ros2.map_interval, d.ros2.map_interval);
  EXPECT_DOUBLE_EQ(c.ros2.pose_rate_hz, d.ros2.pose_rate_hz);
  EXPECT_DOUBLE_EQ(c.ros2.heading_sigma_deg, d.ros2.heading_sigma_deg);
  EXPECT_EQ(c.view.listen, d.view.listen);
  EXPECT_DOUBLE_EQ(c.view.period_s, d.view.period_s);
  const ValidationOptions& v = c.station.validation;
  const ValidationOptions& dv = d.station.validation;
  EXPECT_DOUBLE_EQ(v.site_min_x_m, dv.site_min_x_m);
  EXPECT_DOUBLE_EQ(v.site_max_z_m, dv.site_max_z_m);
  EXPECT_EQ(v.max_stamp_age, dv.max_stamp_age);
  EXPECT_EQ(v.max_stamp_ahead, dv.max_stamp_ahead);
  EXPECT_EQ(v.clock_offset_warn, dv.clock_offset_warn);
  EXPECT_EQ(v.max_seq_jump, dv.max_seq_jump);
  EXPECT_EQ(v.log_interval, dv.log_interval);
}

TEST(GroundStationConfig, Ros2Keys) {
  GroundStationConfig c;
  ConfigError e;
  EXPECT_TRUE(c.ros2.enabled);  // on by default (docs/ros2.md)
  ASSERT_TRUE(parse_groundstation_config("[ros2]\nenabled = false\nmap_interval_s = 2.5\npose_rate_hz = 30\n"
                                         "heading_sigma_deg = 0\n", "t.toml", c, e))
      << e.message;
  EXPECT_FALSE(c.ros2.enabled);
  EXPECT_EQ(c.ros2.map_interval, std::chrono::milliseconds(2500));
  EXPECT_DOUBLE_EQ(c.ros2.pose_rate_hz, 30.0);
  EXPECT_DOUBLE_EQ(c.ros2.heading_sigma_deg, 0.0);
}

TEST(GroundStationConfig, ViewListenIsValidatedAndMayBeOff) {
  GroundStationConfig c;
  ConfigError e;
  EXPECT_EQ(c.view.listen, "127.0.0.1:8080");
  ASSERT_TRUE(parse_groundstation_config("[view]\nlisten = \"\"\n", "t.toml", c, e)) << e.message;
  EXPECT_TRUE(c.view.listen.empty());
  ASSERT_TRUE(parse_groundstation_config("[view]\nlisten = \"127.0.0.1:9000\"\n", "t.toml", c, e)) << e.message;
  EXPECT_EQ(c.view.listen, "127.0.0.1:9000");
  for (const char* bad : {"[view]\nlisten = \"8080\"\n", "[view]\nlisten = \"127.0.0.1:70000\"\n",
                          "[view]\nlisten = \"host.example:80\"\n", "[view]\nlisten = 8080\n",
                          "[view]\nperiod_s = 0\n", "[view]\nlisen = \"\"\n"}) {
    EXPECT_FALSE(parse_groundstation_config(bad, "t.toml", c, e)) << bad;
    EXPECT_EQ(e.message.rfind("view.", 0), 0u) << e.message;
  }
}

TEST(GroundStationConfig, ValidationKeys) {
  GroundStationConfig c;
  ConfigError e;
  ASSERT_TRUE(parse_groundstation_config("[validation]\nsite_min_x_m = -50\nsite_max_x_m = 60\nmax_stamp_age_s = 5\n"
                                         "max_seq_jump = 100\n", "t.toml", c, e)) << e.message;
  EXPECT_DOUBLE_EQ(c.station.validation.site_min_x_m, -50.0);
  EXPECT_DOUBLE_EQ(c.station.validation.site_max_x_m, 60.0);
  EXPECT_EQ(c.station.validation.max_stamp_age, std::chrono::seconds(5));
  EXPECT_EQ(c.station.validation.max_seq_jump, 100u);
  GroundStationConfig bad;
  EXPECT_FALSE(parse_groundstation_config("[validation]\nsite_min_y_m = 10\nsite_max_y_m = 5\n", "t.toml", bad, e));
  EXPECT_NE(e.message.find("validation"), std::string::npos);
  EXPECT_FALSE(parse_groundstation_config("[validation]\nmax_stamp_age_s = -1\n", "t.toml", bad, e));
  EXPECT_NE(e.message.find("validation.max_stamp_age_s"), std::string::npos);
  EXPECT_FALSE(parse_groundstation_config("[validation]\nsite_bounds = 1\n", "t.toml", bad, e));
  EXPECT_NE(e.message.find("validation.site_bounds"), std::string::npos);
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
      {"[ros2]\nenabled = 1\n", "ros2.enabled"},
      {"[ros2]\nmap_interval_s = 0\n", "ros2.map_interval_s"},
      {"[ros2]\npose_rate_hz = -1\n", "ros2.pose_rate_hz"},
      {"[ros2]\nheading_sigma_deg = 200\n", "ros2.heading_sigma_deg"},
      {"[ros2]\nmap_rate_hz = 1\n", "ros2.map_rate_hz"},     // unknown key
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
