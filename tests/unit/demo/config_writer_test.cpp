// The configs `teamscan demo` writes (tools/demo/config_writer.hpp), read back by the daemons' own
// config parsers: every value the demo sets arrives.
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>

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
                                                    Pose2{1.5, -2.0, 0.5}, 17, 0.03});
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

TEST(DemoConfig, OnboardMaxHoldUnsetKeepsTheDaemonsDefault) {
  const std::string text = onboard_config(robot(), {"/a", "/b", Pose2{}, 1, std::nullopt});
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
  EXPECT_EQ(c.fusion.method, "visibility");
  EXPECT_EQ(c.fusion.compare_methods, (std::vector<std::string>{"position", "best"}));
  EXPECT_TRUE(c.fusion.enabled);
  EXPECT_TRUE(c.fusion.write_all_points);
  EXPECT_TRUE(c.fusion.latency_log);
  EXPECT_EQ(c.fusion.write_interval, std::chrono::seconds(5));
  EXPECT_EQ(c.team_source, station::TeamSourceKind::kKalman);
  EXPECT_TRUE(c.ros2.enabled);      // --station-ros2 defaults to on
  EXPECT_EQ(c.view.listen, "");     // no --view: the station serves no page
  EXPECT_FALSE(c.fusion.registration);  // odometry alone unless the demo turns it on
}

// --registration (or a drifting scenario): a [registration] section, which the station's parser reads as
// the registration on with its defaults, and so do the demo's checks (fusion_options_from_config).
TEST(DemoConfig, StationRegistrationSectionTurnsItOn) {
  StationConfigInput in;
  in.session_root = "/tmp/demo-out";
  in.registration = true;
  const std::string text = station_config(in);
  station::GroundStationConfig c;
  station::ConfigError e;
  ASSERT_TRUE(station::parse_groundstation_config(text, "groundstation.toml", c, e)) << e.message << "\n" << text;
  EXPECT_TRUE(c.fusion.registration);
  const station::FusionOptions o = station::fusion_options_from_config(c.fusion, c.kalman, c.registration);
  EXPECT_TRUE(o.core.registration);
  EXPECT_EQ(o.core.registration_options.window_s, registration::RegistrationOptions{}.window_s);
  EXPECT_EQ(o.core.registration_options.min_map_features, registration::RegistrationOptions{}.min_map_features);
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
  const station::FusionOptions o = station::fusion_options_from_config(c.fusion, c.kalman, c.registration);
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
