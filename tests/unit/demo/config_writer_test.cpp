// The configs `teamscan demo` writes (tools/demo/config_writer.hpp), read back by the daemons' own
// config parsers: every value the demo sets arrives.
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>

#include "common/units.hpp"
#include "groundstation/station/config.hpp"
#include "groundstation/station/fusion.hpp"
#include "onboard/core/config.hpp"
#include "tools/demo/config_writer.hpp"

namespace teamscan::demo {
namespace {

sim::RobotSpec robot() {
  sim::RobotSpec s;
  s.id = 3;
  s.name = "robot3";
  s.mount_xyz_m[0] = 0.2;
  s.mount_xyz_m[2] = 0.55;
  s.mount_rpy_rad[1] = -0.3;
  s.variant = LaserVariant{100, 25};
  return s;
}

TEST(DemoConfig, OnboardConfigParsesWithTheDaemonsParser) {
  const std::string text = onboard_config(robot(), {"/run/x/robot3-arcos", "/run/x/robot3-lms200",
                                                    Pose2{1.5, -2.0, 0.5}, 17, 0.03, "", 1800.0});
  std::string message;
  auto c = onboard::parse_onboard_config(text, message);
  ASSERT_TRUE(c.ok()) << message << "\n" << text;
  EXPECT_EQ(c->robot_id, 3u);
  EXPECT_EQ(c->arcos_device, "/run/x/robot3-arcos");
  EXPECT_EQ(c->lms_device, "/run/x/robot3-lms200");
  EXPECT_EQ(c->dds_domain, 17u);
  EXPECT_EQ(c->lms_variant.fov_deg, 100);
  EXPECT_EQ(c->lms_variant.resolution_cdeg, 25);
  EXPECT_NEAR(c->registration_x_m, 1.5, 1e-6);
  EXPECT_NEAR(c->registration_y_m, -2.0, 1e-6);
  EXPECT_NEAR(c->registration_theta_deg, 0.5 * 180.0 / M_PI, 1e-4);
  EXPECT_NEAR(c->mount.x_m, 0.2, 1e-6);
  EXPECT_NEAR(c->mount.z_m, 0.55, 1e-6);
  EXPECT_NEAR(c->mount.pitch_deg, -0.3 * 180.0 / M_PI, 1e-4);
  EXPECT_EQ(c->odometry_max_hold, std::chrono::milliseconds(30));
}

TEST(DemoConfig, PathsWithQuotesBackslashesAndControlCharactersArriveAsTheyAre) {
  const std::string arcos = "/tmp/a \"quoted\" dir\\with\\backslashes/robot3-arcos";
  const std::string lms = "/tmp/tab\there/x'y/robot3-lms200";
  const std::string text = onboard_config(robot(), {arcos, lms, Pose2{}, 1, std::nullopt, "", 1800.0});
  std::string message;
  auto c = onboard::parse_onboard_config(text, message);
  ASSERT_TRUE(c.ok()) << message << "\n" << text;
  EXPECT_EQ(c->arcos_device, arcos);
  EXPECT_EQ(c->lms_device, lms);

  StationConfigInput in;
  in.session_root = "/tmp/demo \"out\"\\x\n";
  in.domain = 3;
  station::GroundStationConfig cfg;
  station::ConfigError err;
  ASSERT_TRUE(station::parse_groundstation_config(station_config(in), "groundstation.toml", cfg, err)) << err.message << "\n" << station_config(in);
  EXPECT_EQ(cfg.session_root, in.session_root);
  EXPECT_EQ(toml_string("a\"b\\c\u0001"), "\"a\\\"b\\\\c\\u0001\"");
}

TEST(DemoConfig, OnboardMaxHoldUnsetKeepsTheDaemonsDefault) {
  const std::string text = onboard_config(robot(), {"/a", "/b", Pose2{}, 1, std::nullopt, "", 1800.0});
  EXPECT_EQ(text.find("max_hold_s"), std::string::npos);
  std::string message;
  auto c = onboard::parse_onboard_config(text, message);
  ASSERT_TRUE(c.ok()) << message;
  EXPECT_EQ(c->odometry_max_hold, c->odometry_max_extrapolation);
}

TEST(DemoConfig, StationConfigParsesWithTheStationsParser) {
  StationConfigInput in;
  in.session_root = "/tmp/demo-out";
  in.domain = 42;
  in.method = "visibility";
  in.compare_methods = {"position", "best"};
  in.write_interval_s = 5.0;
  const std::string text = station_config(in);
  station::GroundStationConfig c;
  station::ConfigError e;
  ASSERT_TRUE(station::parse_groundstation_config(text, "groundstation.toml", c, e)) << e.message << "\n" << text;
  EXPECT_EQ(c.session_root, "/tmp/demo-out");
  EXPECT_EQ(c.station.domain_id, 42u);
  EXPECT_EQ(c.fusion.core.method, "visibility");
  EXPECT_EQ(c.fusion.compare_methods, (std::vector<std::string>{"position", "best"}));
  EXPECT_TRUE(c.fusion.enabled);
  EXPECT_EQ(c.fusion.all_points_pcd, "fused_all.pcd");
  EXPECT_EQ(c.fusion.latency_log_csv, "fused_latency.csv");
  EXPECT_EQ(c.fusion.write_interval, std::chrono::seconds(5));
  EXPECT_EQ(c.team_source, station::TeamSourceKind::kKalman);
  EXPECT_TRUE(c.ros2.enabled);      // --station-ros2 defaults to on
  EXPECT_EQ(c.view.listen, "");     // no --view: the station serves no page
  EXPECT_FALSE(c.fusion.core.registration);  // odometry alone unless the demo turns it on
}

// Each robot's laser mount goes to [[ros2.laser_mount]] (rt/tf_static, the view's /tf_static).
TEST(DemoConfig, StationConfigCarriesEachRobotsLaserMount) {
  StationConfigInput in;
  in.session_root = "/tmp/demo-out";
  in.robots.resize(2);
  in.robots[0].id = 1;
  in.robots[1].id = 2;
  in.robots[1].mount_rpy_rad[1] = deg_to_rad(15.0);
  const std::string text = station_config(in);
  station::GroundStationConfig c;
  station::ConfigError e;
  ASSERT_TRUE(station::parse_groundstation_config(text, "groundstation.toml", c, e)) << e.message << "\n" << text;
  ASSERT_EQ(c.ros2.laser_mounts.size(), 2u);
  EXPECT_EQ(c.ros2.laser_mounts[1].robot_id, 2u);
  EXPECT_DOUBLE_EQ(c.ros2.laser_mounts[1].mount.x_m, in.robots[1].mount_xyz_m[0]);
  EXPECT_NEAR(c.ros2.laser_mounts[1].mount.z_m, in.robots[1].mount_xyz_m[2], 1e-6);
  EXPECT_NEAR(c.ros2.laser_mounts[1].mount.pitch_rad, deg_to_rad(15.0), 1e-7);
}

// --registration (or a drifting scenario): a [registration] section, which the station's parser reads as
// the registration on with its defaults, and so do the demo's checks (the same FusionOptions).
TEST(DemoConfig, StationRegistrationSectionTurnsItOn) {
  StationConfigInput in;
  in.session_root = "/tmp/demo-out";
  in.registration = true;
  const std::string text = station_config(in);
  station::GroundStationConfig c;
  station::ConfigError e;
  ASSERT_TRUE(station::parse_groundstation_config(text, "groundstation.toml", c, e)) << e.message << "\n" << text;
  const station::FusionOptions& o = c.fusion;
  EXPECT_TRUE(o.core.registration);
  EXPECT_EQ(o.core.registration_options.window_s, registration::RegistrationOptions{}.window_s);
  EXPECT_EQ(o.core.registration_options.min_map_features, registration::RegistrationOptions{}.min_map_features);
}

// The pose graph: on in the written config by default (as the station's own default), off as the demo's
// --no-pose-graph or --no-registration asks; the station's parser reads either as written.
TEST(DemoConfig, StationPoseGraphOnByDefaultAndOffWhenAsked) {
  StationConfigInput in;
  in.session_root = "/tmp/demo-out";
  for (const bool on : {true, false}) {
    in.pose_graph = on;
    const std::string text = station_config(in);
    station::GroundStationConfig c;
    station::ConfigError e;
    ASSERT_TRUE(station::parse_groundstation_config(text, "groundstation.toml", c, e)) << e.message << "\n" << text;
    EXPECT_EQ(c.fusion.pose_graph.has_value(), on) << text;
  }
  EXPECT_TRUE(StationConfigInput{}.pose_graph);
}

// --calibration: the calibration's [[registration.robot]] tables follow the station config's sections
// and reach the registration's options, as the station reads them.
TEST(DemoConfig, StationConfigCarriesTheCalibration) {
  StationConfigInput in;
  in.session_root = "/tmp/demo-out";
  in.registration = true;
  in.calibration_toml = "# teamscan calibrate\n[[registration.robot]]\nid = 2\nscale_percent = -1.9\nscale_sigma_percent = 0.6\n";
  const std::string text = station_config(in);
  station::GroundStationConfig c;
  station::ConfigError e;
  ASSERT_TRUE(station::parse_groundstation_config(text, "groundstation.toml", c, e)) << e.message << "\n" << text;
  const station::FusionOptions& o = c.fusion;
  EXPECT_TRUE(o.core.registration);
  EXPECT_DOUBLE_EQ(o.core.registration_options.prior_of(2).scale, -0.019);
  EXPECT_DOUBLE_EQ(o.core.registration_options.prior_of(2).sigma_scale, 0.006);
  EXPECT_EQ(o.core.registration_options.prior_of(1).scale, 0.0);
  in.registration = false;  // no registration, no priors
  EXPECT_EQ(station_config(in).find("registration.robot"), std::string::npos);
}

TEST(DemoConfig, StationRos2OffAndViewOnLoopback) {
  StationConfigInput in;
  in.session_root = "/tmp/demo-out";
  in.domain = 7;
  in.ros2 = false;
  in.view_port = 18089;
  const std::string text = station_config(in);
  station::GroundStationConfig c;
  station::ConfigError e;
  ASSERT_TRUE(station::parse_groundstation_config(text, "groundstation.toml", c, e)) << e.message << "\n" << text;
  EXPECT_FALSE(c.ros2.enabled);
  EXPECT_EQ(c.view.listen, "127.0.0.1:18089");
  EXPECT_EQ(c.fusion.write_interval, std::chrono::seconds(0));
}

}  // namespace
}  // namespace teamscan::demo
