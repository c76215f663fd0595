// Ground-station config: the commented example in deploy/ parses to the defaults; errors name the key.
#include <gtest/gtest.h>

#include <cstdlib>

#include "common/units.hpp"
#include "groundstation/station/config.hpp"
#include "groundstation/station/fusion.hpp"

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
                          "[view]\nperiod_s = 0\n", "[view]\nlisen = \"\"\n", "[view]\ncpus = 0\n",
                          "[view]\ncpus = [-1]\n", "[view]\ncpus = [\"0\"]\n"}) {
    EXPECT_FALSE(parse_groundstation_config(bad, "t.toml", c, e)) << bad;
    EXPECT_EQ(e.message.rfind("view.", 0), 0u) << e.message;
  }
}

TEST(GroundStationConfig, ViewCpusPlaceTheServerThread) {
  GroundStationConfig c;
  ConfigError e;
  EXPECT_TRUE(c.view.cpus.empty());  // default: the process's CPUs
  ASSERT_TRUE(parse_groundstation_config("[view]\ncpus = [0, 2]\n", "t.toml", c, e)) << e.message;
  EXPECT_EQ(c.view.cpus, (std::vector<int>{0, 2}));
  GroundStationConfig bad;
  EXPECT_FALSE(parse_groundstation_config("[view]\ncpus = [1024]\n", "t.toml", bad, e));
  EXPECT_EQ(e.message, "view.cpus: each must be in [0, 1023], got 1024 (line 2)") << e.message;
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

namespace teamscan::station {
namespace {

// [registration]'s odometry priors: the team's default in the section, a robot's own in a
// [[registration.robot]] table (keys it does not set: the default's), in percent and degrees per metre.
TEST(GroundStationConfig, RegistrationPriorsDefaultAndPerRobot) {
  GroundStationConfig c;
  ConfigError e;
  const registration::OdometryPrior d;  // the registration's own defaults: no prior keys, no change
  ASSERT_TRUE(parse_groundstation_config("[registration]\nwindow_s = 2.0\n", "t.toml", c, e)) << e.message;
  EXPECT_EQ(c.registration.prior.scale, d.scale);
  EXPECT_EQ(c.registration.prior.sigma_scale, d.sigma_scale);
  EXPECT_TRUE(c.registration.robot_priors.empty());
  const char* text =
      "[registration]\nscale_percent = -1.0\nscale_sigma_percent = 2.0\n"
      "[[registration.robot]]\nid = 3\nscale_percent = -1.96\nscale_sigma_percent = 0.5\ndrift_deg_per_m = -0.25\n"
      "drift_sigma_deg_per_m = 0.1\nturn_percent = 0.5\nturn_sigma_percent = 1.0\n"
      "[[registration.robot]]\nid = 1\nturn_percent = -0.4\n";
  c = GroundStationConfig{};
  ASSERT_TRUE(parse_groundstation_config(text, "t.toml", c, e)) << e.message;
  const registration::RegistrationOptions& o = c.registration;
  EXPECT_DOUBLE_EQ(o.prior.scale, -0.01);
  EXPECT_DOUBLE_EQ(o.prior.sigma_scale, 0.02);
  EXPECT_EQ(o.prior.drift_rad_per_m, d.drift_rad_per_m);
  ASSERT_EQ(o.robot_priors.size(), 2u);
  const registration::OdometryPrior& r3 = o.prior_of(3);
  EXPECT_DOUBLE_EQ(r3.scale, -0.0196);
  EXPECT_DOUBLE_EQ(r3.sigma_scale, 0.005);
  EXPECT_DOUBLE_EQ(r3.drift_rad_per_m, deg_to_rad(-0.25));
  EXPECT_DOUBLE_EQ(r3.sigma_drift_rad_per_m, deg_to_rad(0.1));
  EXPECT_DOUBLE_EQ(r3.turn, 0.005);
  EXPECT_DOUBLE_EQ(r3.sigma_turn, 0.01);
  const registration::OdometryPrior& r1 = o.prior_of(1);  // its turn, the default's rest
  EXPECT_DOUBLE_EQ(r1.turn, -0.004);
  EXPECT_DOUBLE_EQ(r1.scale, -0.01);
  EXPECT_DOUBLE_EQ(r1.sigma_scale, 0.02);
  EXPECT_EQ(&o.prior_of(2), &o.prior);
  // They reach the fusion core's registration.
  const FusionOptions f = fusion_options_from_config(c.fusion, c.kalman, c.registration);
  EXPECT_TRUE(f.core.registration);
  EXPECT_DOUBLE_EQ(f.core.registration_options.prior_of(3).scale, -0.0196);
  EXPECT_DOUBLE_EQ(f.core.registration_options.window_s, registration::RegistrationOptions{}.window_s);
}

TEST(GroundStationConfig, BadRegistrationPriorsAreRefusedNamingThem) {
  struct Case {
    const char* text;
    const char* starts;
  };
  const Case cases[] = {
      {"[registration]\nscale_percent = nan\n", "registration.scale_percent: must be finite"},
      {"[registration]\nscale_sigma_percent = inf\n", "registration.scale_sigma_percent: must be finite"},
      {"[registration]\nscale_sigma_percent = 0\n", "registration: the scale's σ"},
      {"[registration]\ndrift_sigma_deg_per_m = -0.1\n", "registration: the heading drift's σ"},
      {"[registration]\nscale_percent = -60\n", "registration: the scale must be within"},
      {"[registration]\nturn_percent = 75\n", "registration: the turn scale must be within"},
      {"[registration]\ndrift_deg_per_m = 20\n", "registration: the heading drift must be within"},
      {"[registration]\nscale_percent = \"-1\"\n", "registration.scale_percent: must be a number"},
      {"[[registration.robot]]\nid = 2\nturn_sigma_percent = 0\n", "registration.robot (id 2): the turn scale's σ"},
      {"[[registration.robot]]\nid = 2\nscale_percent = inf\n", "registration.robot (id 2).scale_percent: must be finite"},
      {"[[registration.robot]]\nscale_percent = -1\n", "registration.robot.id: missing"},
      {"[[registration.robot]]\nid = 0\n", "registration.robot.id: must be in [1, 32]"},
      {"[[registration.robot]]\nid = 33\n", "registration.robot.id: must be in [1, 32]"},
      {"[[registration.robot]]\nid = 1\n[[registration.robot]]\nid = 1\n", "registration.robot.id: 1 is listed twice"},
      {"[[registration.robot]]\nid = 1\nslip = 2\n", "registration.robot.slip: unknown key"},
      {"[registration]\nrobot = 3\n", "registration.robot: must be [[registration.robot]] tables"},
  };
  for (const Case& k : cases) {
    GroundStationConfig c;
    ConfigError e;
    EXPECT_FALSE(parse_groundstation_config(k.text, "t.toml", c, e)) << k.text;
    EXPECT_EQ(e.message.rfind(k.starts, 0), 0u) << k.text << " -> " << e.message;
    EXPECT_TRUE(c.registration.robot_priors.empty());  // nothing taken from a refused config
  }
}

}  // namespace
}  // namespace teamscan::station
