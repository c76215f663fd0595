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
  EXPECT_DOUBLE_EQ(c.fusion.core.tracker.lost_after_s, d.fusion.core.tracker.lost_after_s);
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

// [[ros2.laser_mount]]: each robot's laser mount for /tf_static, in the robot's [mount] units.
TEST(GroundStationConfig, Ros2LaserMounts) {
  GroundStationConfig c;
  ConfigError e;
  EXPECT_TRUE(c.ros2.laser_mounts.empty());
  ASSERT_TRUE(parse_groundstation_config("[ros2]\n[[ros2.laser_mount]]\nid = 2\nx_m = 0.125\nz_m = 0.462\n"
                                         "pitch_deg = -20\n[[ros2.laser_mount]]\nid = 1\n", "t.toml", c, e))
      << e.message;
  ASSERT_EQ(c.ros2.laser_mounts.size(), 2u);
  EXPECT_EQ(c.ros2.laser_mounts[0].robot_id, 2u);
  EXPECT_DOUBLE_EQ(c.ros2.laser_mounts[0].mount.x_m, 0.125);
  EXPECT_DOUBLE_EQ(c.ros2.laser_mounts[0].mount.z_m, 0.462);
  EXPECT_NEAR(c.ros2.laser_mounts[0].mount.pitch_rad, deg_to_rad(-20.0), 1e-15);
  EXPECT_EQ(c.ros2.laser_mounts[1].robot_id, 1u);
  EXPECT_EQ(c.ros2.laser_mounts[1].mount.z_m, 0.0);
  for (const auto& [text, why] : std::vector<std::pair<const char*, const char*>>{
           {"[[ros2.laser_mount]]\nx_m = 1\n", "ros2.laser_mount.id: missing"},
           {"[[ros2.laser_mount]]\nid = 33\n", "ros2.laser_mount.id: must be in [1, 32]"},
           {"[[ros2.laser_mount]]\nid = 1\n[[ros2.laser_mount]]\nid = 1\n", "listed twice"},
           {"[[ros2.laser_mount]]\nid = 1\npitch_deg = 200\n", "ros2.laser_mount.pitch_deg: must be in"},
           {"[[ros2.laser_mount]]\nid = 1\nheight = 1\n", "ros2.laser_mount.height: unknown key"},
           {"[ros2]\nlaser_mount = 1\n", "must be [[ros2.laser_mount]] tables"}}) {
    GroundStationConfig bad;
    EXPECT_FALSE(parse_groundstation_config(text, "t.toml", bad, e)) << text;
    EXPECT_NE(e.message.find(why), std::string::npos) << text << " -> " << e.message;
  }
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
  EXPECT_EQ(c.fusion.core.registration_options.prior.scale, d.scale);
  EXPECT_EQ(c.fusion.core.registration_options.prior.sigma_scale, d.sigma_scale);
  EXPECT_TRUE(c.fusion.core.registration_options.robot_priors.empty());
  const char* text =
      "[registration]\nscale_percent = -1.0\nscale_sigma_percent = 2.0\n"
      "[[registration.robot]]\nid = 3\nscale_percent = -1.96\nscale_sigma_percent = 0.5\ndrift_deg_per_m = -0.25\n"
      "drift_sigma_deg_per_m = 0.1\nturn_percent = 0.5\nturn_sigma_percent = 1.0\n"
      "[[registration.robot]]\nid = 1\nturn_percent = -0.4\n";
  c = GroundStationConfig{};
  ASSERT_TRUE(parse_groundstation_config(text, "t.toml", c, e)) << e.message;
  const registration::RegistrationOptions& o = c.fusion.core.registration_options;
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
  const FusionOptions f = c.fusion;
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
    EXPECT_TRUE(c.fusion.core.registration_options.robot_priors.empty());  // nothing taken from a refused config
  }
}

}  // namespace
}  // namespace teamscan::station

namespace teamscan::station {
namespace {

// One bad value in each section: refused with its whole message (key, why, line), and nothing taken.
TEST(GroundStationConfig, ABadValueInEachSectionIsRefusedWithItsMessage) {
  struct Case {
    const char* text;
    const char* message;
  };
  const Case cases[] = {
      {"[station]\nsync_interval_s = 0\n", "station.sync_interval_s: must be in (0, 3600], got 0 (line 2)"},
      {"[dds]\ntake_batch = 5000\n", "dds.take_batch: must be in [1, 4096], got 5000 (line 2)"},
      {"[team]\nliveliness_lease_s = 61\n", "team.liveliness_lease_s: must be in (0, 60], got 61 (line 2)"},
      {"[team.body]\nwidth_m = 0\n", "team.body.width_m: must be in (0, 10], got 0 (line 2)"},
      {"[team.last_pose]\nsigma0_m = -1\n", "team.last_pose.sigma0_m: must be in [0, 100], got -1 (line 2)"},
      {"[team.kalman]\naccel_noise_mps2 = 0\n", "team.kalman.accel_noise_mps2: must be in (0, 100], got 0 (line 2)"},
      {"[team.kalman]\ndrift_deg_per_m = 91\n", "team.kalman.drift_deg_per_m: must be in [0, 90], got 91 (line 2)"},
      {"[team.kalman]\nlost_after = 1\n", "team.kalman.lost_after: unknown key (line 2)"},
      {"[fusion]\nhalf_angle_deg = 61\n", "fusion.half_angle_deg: must be in (0, 60], got 61 (line 2)"},
      {"[fusion]\nresolution_m = 0\n", "fusion.resolution_m: must be in (0, 10], got 0 (line 2)"},
      {"[fusion]\nteam_lag_s = 11\n", "fusion.team_lag_s: must be in [0, 10], got 11 (line 2)"},
      {"[fusion]\nmax_points_per_voxel = -1\n", "fusion.max_points_per_voxel: must be in [0, 1000000], got -1 (line 2)"},
      {"[fusion]\nmethod = \"magic\"\n",
       "fusion.method: must be frequency, visibility, position, direction, combined, freespace, tracked or best, "
       "got \"magic\" (line 2)"},
      {"[fusion]\nwrite_all_points = 1\n", "fusion.write_all_points: must be true or false (line 2)"},
      {"[registration]\nwindow_s = 0\n", "registration.window_s: must be in (0, 60], got 0 (line 2)"},
      {"[registration]\nmin_map_features = -1\n", "registration.min_map_features: must be in [0, 1000000], got -1 (line 2)"},
      {"[ros2]\npose_rate_hz = 0\n", "ros2.pose_rate_hz: must be in (0, 1000], got 0 (line 2)"},
      {"[view]\nperiod_s = 61\n", "view.period_s: must be in (0, 60], got 61 (line 2)"},
      {"[validation]\nmax_seq_jump = 0\n", "validation.max_seq_jump: must be in [1, 1000000000], got 0 (line 2)"},
      {"[validation]\nsite_min_z_m = 5\nsite_max_z_m = 1\n",
       "validation: each site_min_*_m must be below its site_max_*_m (line 1)"},
      {"[team]\nsource = \"magic\"\n", "team.source: must be \"kalman\" or \"last_pose\", got \"magic\" (line 2)"},
      {"[fusion]\nmethod = \"\"\n", "fusion.method: must not be empty (line 2)"},
      {"[team\n", "t.toml:1:6: Error while parsing table header: expected ']', saw '\\n'"},
  };
  for (const Case& k : cases) {
    GroundStationConfig c;
    ConfigError e;
    EXPECT_FALSE(parse_groundstation_config(k.text, "t.toml", c, e)) << k.text;
    EXPECT_EQ(e.message, k.message) << k.text;
    EXPECT_EQ(c.session_root, GroundStationConfig{}.session_root);
  }
}

}  // namespace
}  // namespace teamscan::station

namespace teamscan::station {
namespace {

// [team.kalman] is read into the station's one tracker (the fusion core's, the team source's), in the
// config's units; without it the tracker's own defaults hold, and [fusion] keeps the owners' defaults
// but for the map-based methods' voxel edge.
TEST(GroundStationConfig, KalmanKeysReachTheTrackerAndTheDefaultsAreTheOwners) {
  const GroundStationConfig d;
  const mapping::TrackerOptions t;
  EXPECT_EQ(d.fusion.core.tracker.accel_noise_mps2, t.accel_noise_mps2);
  EXPECT_EQ(d.fusion.core.tracker.position_noise_m, t.position_noise_m);
  EXPECT_EQ(d.fusion.core.tracker.velocity_noise_mps, t.velocity_noise_mps);
  EXPECT_EQ(d.fusion.core.tracker.lost_after_s, t.lost_after_s);
  EXPECT_EQ(d.fusion.core.tracker.drift_m_per_m, t.drift_m_per_m);
  EXPECT_EQ(d.fusion.core.tracker.team_lag_s, t.team_lag_s);
  const mapping::MethodOptions m;
  EXPECT_EQ(d.fusion.core.methods.frequency.resolution_m, 0.1);
  EXPECT_EQ(d.fusion.core.methods.visibility.resolution_m, 0.1);
  EXPECT_EQ(d.fusion.core.methods.combined_resolution_m, m.combined_resolution_m);
  EXPECT_EQ(d.fusion.core.methods.direction.half_angle_rad, m.direction.half_angle_rad);
  EXPECT_EQ(d.fusion.core.methods.combined_half_angle_rad, m.combined_half_angle_rad);
  EXPECT_EQ(d.fusion.core.hold_s, fusion::CoreOptions{}.hold_s);
  EXPECT_FALSE(d.fusion.core.registration);

  GroundStationConfig c;
  ConfigError e;
  ASSERT_TRUE(parse_groundstation_config("[team.kalman]\naccel_noise_mps2 = 0.8\nposition_noise_m = 0.03\n"
                                         "velocity_noise_mps = 0.07\nlost_after_s = 2.5\ndrift_m_per_m = 0.01\n"
                                         "drift_deg_per_m = 0.5\ndrift_deg_per_deg = 0.02\n[fusion]\nteam_lag_s = 0.15\n"
                                         "grid_origin_z_m = -0.05\ndirection_from_flags = true\nlatency_log = true\n",
                                         "t.toml", c, e))
      << e.message;
  const mapping::TrackerOptions& k = c.fusion.core.tracker;
  EXPECT_EQ(k.accel_noise_mps2, 0.8);
  EXPECT_EQ(k.position_noise_m, 0.03);
  EXPECT_EQ(k.velocity_noise_mps, 0.07);
  EXPECT_EQ(k.lost_after_s, 2.5);
  EXPECT_EQ(k.drift_m_per_m, 0.01);
  EXPECT_DOUBLE_EQ(k.drift_heading_rad_per_m, deg_to_rad(0.5));
  EXPECT_EQ(k.drift_heading_rad_per_rad, 0.02);  // deg/deg = rad/rad
  EXPECT_EQ(k.team_lag_s, 0.15);
  const mapping::MethodOptions& mo = c.fusion.core.methods;
  EXPECT_EQ(mo.frequency.grid_origin_z_m, -0.05);
  EXPECT_EQ(mo.visibility.grid_origin_z_m, -0.05);
  EXPECT_EQ(mo.combined_grid_origin_z_m, -0.05);
  EXPECT_EQ(mo.direction.source, mapping::DirectionSource::flags);
  EXPECT_EQ(c.fusion.latency_log_csv, "fused_latency.csv");
}

}  // namespace
}  // namespace teamscan::station
