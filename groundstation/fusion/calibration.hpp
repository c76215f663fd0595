// Odometry calibration (`teamscan calibrate`; docs/registration.md "Odometry prior and calibration"): a
// calibration drive goes through the fusion core with the registration on (the station's path, no
// truth used), and each robot's drift rates as they converged (distance scale, heading drift per
// metre, turn scale) with their σ become that robot's odometry prior, written as the
// [[registration.robot]] TOML that the station's [registration] and `teamscan eval --calibration` read.
// A real base is calibrated once on such a drive; its missions then start from its prior instead of
// "no drift known". Several drives of the same robots combine per robot (inverse-variance mean, the
// drives' disagreement added to the σ). Pure: data sets in, values and text out.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "common/dataset/dataset.hpp"
#include "common/result.hpp"
#include "groundstation/mapping/tracker.hpp"
#include "groundstation/registration/registration.hpp"

namespace teamscan::fusion {

struct CalibrationOptions {
  registration::RegistrationOptions registration{};  // the drive's rates start from its prior
  mapping::TrackerOptions tracker{};
  // A robot is calibrated only with at least this much path and this many accepted matches (else
  // its rates are still the prior's: it is reported, not written).
  double min_path_m = 20.0;
  std::uint64_t min_accepted = 20;
  // The σ written is at least this (each rate): the filter's own σ at the end of one drive says how
  // well that drive told the rates, not how much they change from one drive to the next (floor, load,
  // tyre wear); docs/registration.md gives the figures behind the defaults.
  registration::OdometryPrior min_sigma{0.0, 0.002, 0.0, 0.0005, 0.0, 0.005};
};

// One robot's calibration: the rates and σ as an odometry prior, and what they rest on.
struct RobotCalibration {
  std::uint8_t robot = 0;
  bool calibrated = false;         // enough path and matches (CalibrationOptions::min_*)
  registration::OdometryPrior rates;  // value and σ of each rate (σ at least min_sigma)
  registration::OdometryPrior estimate;  // the filter's values and σ at the end (drives: combined), before the floor
  double path_m = 0;               // driven (odometry)
  std::uint64_t matches = 0, accepted = 0;
  std::uint32_t drives = 0;        // calibration drives it was seen on
};

struct Calibration {
  std::vector<RobotCalibration> robots;  // by robot id
};

// One drive: the data set through the fusion core (method `position`, which places the scans as every
// method does) with the registration on; each robot's rates at the end. An error when the core refuses
// the options.
[[nodiscard]] Result<Calibration> calibrate_drive(const Dataset& drive, const CalibrationOptions& options);

// Several drives of the same robots: per robot and rate the inverse-variance mean of the calibrated
// drives, σ² = 1 / Σ(1/σᵢ²) + the weighted spread of the drives' values about it (their disagreement
// is what a new drive may differ by), at least min_sigma.
[[nodiscard]] Calibration combine_drives(const std::vector<Calibration>& drives, const CalibrationOptions& options);

// The calibrated robots as [[registration.robot]] tables (the station config's units: percent,
// degrees per metre), preceded by `comment` (each line prefixed with "# "); robots not calibrated are
// named in a comment, not written.
[[nodiscard]] std::string calibration_toml(const Calibration& calibration, const std::string& comment);

}  // namespace teamscan::fusion
