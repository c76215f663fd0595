// Odometry calibration (groundstation/fusion/calibration.hpp): a simulated calibration drive recovers
// each robot's wheel slip; drives combine by inverse variance with their disagreement in the σ; the
// TOML it writes is what the station's config reads back.
#include <gtest/gtest.h>

#include <cmath>

#include "common/units.hpp"
#include "groundstation/fusion/calibration.hpp"
#include "groundstation/station/config.hpp"
#include "sim/simulator.hpp"

namespace teamscan::fusion {
namespace {

// corridor2's calibration drive (a figure-of-eight in a hall) with another seed than its own: the same
// two bases as corridor2's (1 % and 1.5 % wheel slip, ±0.1°/m). The calibration sees only the odometry
// and the scans, like a real drive.
TEST(Calibration, ASimulatedDriveRecoversEachRobotsSlip) {
  const sim::ScenarioLoad load = sim::resolve_scenario("corridor2-calibration");
  ASSERT_TRUE(load.scenario) << load.error;
  sim::SimOptions so;
  so.seed = 1001;
  so.device_streams = false;
  const sim::SimOutput drive = sim::simulate(*load.scenario, so);
  const Calibration cal = calibrate_drive(drive.dataset, CalibrationOptions{}).value();
  ASSERT_EQ(cal.robots.size(), load.scenario->robots.size());
  for (const RobotCalibration& r : cal.robots) {
    const sim::RobotSpec* spec = nullptr;
    for (const sim::RobotSpec& s : load.scenario->robots)
      if (s.id == r.robot) spec = &s;
    ASSERT_NE(spec, nullptr);
    EXPECT_TRUE(r.calibrated) << int{r.robot};
    EXPECT_GT(r.path_m, 25.0);
    // The simulator's odometry reports (1 + slip) times the distance: the true one is 1 / (1 + slip) of it.
    const double truth = 1.0 / (1.0 + spec->odometry.slip) - 1.0;
    // Within 0.25 % of the distance: over the 10 m of a long wall matched by nothing yet (the first
    // lap, docs/registration.md) the prior then errs by at most 2.5 cm, half the 5 cm goal; and within
    // twice the σ it writes (the calibration's own claim).
    EXPECT_NEAR(r.rates.scale, truth, 0.0025) << "robot " << int{r.robot};
    EXPECT_LT(std::abs(r.rates.scale - truth), 2.0 * r.rates.sigma_scale) << "robot " << int{r.robot};
    // The heading drift per metre has the opposite sign of the simulator's (the rate corrects it).
    EXPECT_LT(r.rates.drift_rad_per_m * spec->odometry.drift_rad_per_m, 0.0) << "robot " << int{r.robot};
    EXPECT_GE(r.rates.sigma_scale, CalibrationOptions{}.min_sigma.sigma_scale);
  }
  // The two bases are told apart: robot 2 slips half a percent more.
  EXPECT_LT(cal.robots[1].rates.scale, cal.robots[0].rates.scale - 0.002);

  // The TOML fragment is what the station reads: each robot's prior, to the digits written.
  const std::string text = calibration_toml(cal, "corridor2-calibration, seed 1001");
  station::GroundStationConfig c;
  station::ConfigError e;
  ASSERT_TRUE(station::parse_groundstation_config(text, "calib.toml", c, e)) << e.message << "\n" << text;
  ASSERT_EQ(c.fusion.core.registration_options.robot_priors.size(), 2u);
  for (const RobotCalibration& r : cal.robots) {
    const registration::OdometryPrior& p = c.fusion.core.registration_options.prior_of(r.robot);
    EXPECT_NEAR(p.scale, r.rates.scale, 1e-3 * std::abs(r.rates.scale));
    EXPECT_NEAR(p.sigma_scale, r.rates.sigma_scale, 1e-3 * r.rates.sigma_scale);
    EXPECT_NEAR(p.drift_rad_per_m, r.rates.drift_rad_per_m, 1e-3 * std::abs(r.rates.drift_rad_per_m));
    EXPECT_NEAR(p.turn, r.rates.turn, 1e-3 * std::abs(r.rates.turn) + 1e-9);
  }
}

RobotCalibration drive_of(std::uint8_t robot, double scale, double sigma, bool calibrated = true) {
  RobotCalibration r;
  r.robot = robot;
  r.calibrated = calibrated;
  r.estimate = {scale, sigma, 0.001, 0.001, 0.0, 0.01};
  r.rates = r.estimate;
  r.path_m = 50;
  r.matches = 100;
  r.accepted = 90;
  r.drives = 1;
  return r;
}

TEST(Calibration, DrivesCombineByInverseVarianceWithTheirDisagreementInTheSigma) {
  CalibrationOptions o;
  o.min_sigma = {0, 1e-6, 0, 1e-6, 0, 1e-6};
  const Calibration a{{drive_of(1, -0.020, 0.004), drive_of(2, -0.01, 0.002)}};
  const Calibration b{{drive_of(1, -0.017, 0.002), drive_of(2, 0.3, 0.001, false)}};
  const Calibration c = combine_drives({a, b}, o);
  ASSERT_EQ(c.robots.size(), 2u);
  const RobotCalibration& r1 = c.robots[0];
  // Weights 1/16 and 1/4 (per 1e-6): the mean (−0.020/16 − 0.017/4) / (5/16) = −0.0176.
  EXPECT_NEAR(r1.rates.scale, -0.0176, 1e-9);
  const double sum_w = 1 / (0.004 * 0.004) + 1 / (0.002 * 0.002);
  const double spread = (std::pow(-0.020 + 0.0176, 2) / (0.004 * 0.004) + std::pow(-0.017 + 0.0176, 2) / (0.002 * 0.002)) / sum_w;
  EXPECT_NEAR(r1.rates.sigma_scale, std::sqrt(1 / sum_w + spread), 1e-12);
  EXPECT_GT(r1.rates.sigma_scale, std::sqrt(1 / sum_w));  // they disagree: wider than either filter said
  EXPECT_EQ(r1.drives, 2u);
  EXPECT_EQ(r1.accepted, 180u);
  // Robot 2's second drive was not calibrated: its first alone counts.
  EXPECT_DOUBLE_EQ(c.robots[1].rates.scale, -0.01);
  EXPECT_DOUBLE_EQ(c.robots[1].rates.sigma_scale, 0.002);
  EXPECT_EQ(c.robots[1].drives, 1u);
  // The floor: no σ below it.
  o.min_sigma.sigma_scale = 0.005;
  EXPECT_DOUBLE_EQ(combine_drives({a}, o).robots[1].rates.sigma_scale, 0.005);
  // Not calibrated on any drive: named in the TOML, not written.
  const Calibration none = combine_drives({Calibration{{drive_of(4, 0.1, 0.01, false)}}}, o);
  EXPECT_FALSE(none.robots[0].calibrated);
  const std::string text = calibration_toml(none, "x");
  EXPECT_EQ(text.find("[[registration.robot]]"), std::string::npos);
  EXPECT_NE(text.find("robot 4: not calibrated"), std::string::npos);
}

}  // namespace
}  // namespace teamscan::fusion
