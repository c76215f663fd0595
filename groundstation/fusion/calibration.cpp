// Odometry calibration: a drive's rates through the fusion core, drives combined, the TOML fragment
// (calibration.hpp).
#include "groundstation/fusion/calibration.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <map>
#include <sstream>

#include "common/units.hpp"
#include "groundstation/fusion/evaluation.hpp"

namespace teamscan::fusion {
namespace {

using mapping::MethodOptions;
using registration::OdometryPrior;

// The three rates of a prior as (value, σ) pairs, in the order scale, drift, turn.
std::array<double*, 3> values(OdometryPrior& p) { return {&p.scale, &p.drift_rad_per_m, &p.turn}; }
std::array<double*, 3> sigmas(OdometryPrior& p) { return {&p.sigma_scale, &p.sigma_drift_rad_per_m, &p.sigma_turn}; }

// Each σ at least the floor's.
OdometryPrior floored(OdometryPrior p, OdometryPrior floor) {
  const auto s = sigmas(p);
  const auto f = sigmas(floor);
  for (std::size_t i = 0; i < 3; ++i) *s[i] = std::max(*s[i], *f[i]);
  return p;
}

std::string format(const char* fmt, double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, fmt, v);
  return buf;
}

}  // namespace

Result<Calibration> calibrate_drive(const Dataset& drive, const CalibrationOptions& options) {
  CoreRunOptions run;
  run.tracker = options.tracker;
  run.registration = true;
  run.registration_options = options.registration;
  const Result<CoreRun> ran = run_through_core(drive, "position", MethodOptions{}, run);
  if (!ran) return ran.error();
  const CoreRun& core = ran.value();
  // The path each robot drove, by its odometry (what a real drive has; no truth is used).
  std::map<std::uint8_t, double> path_m;
  std::map<std::uint8_t, Pose2> last;
  for (const TrajectorySample& s : drive.odom) {
    const auto it = last.find(s.robot);
    if (it != last.end()) path_m[s.robot] += std::hypot(s.pose.x_m - it->second.x_m, s.pose.y_m - it->second.y_m);
    last[s.robot] = s.pose;
  }
  Calibration out;
  for (const registration::RobotCorrection& c : core.robots) {
    RobotCalibration rc;
    rc.robot = c.robot;
    rc.path_m = path_m[c.robot];
    rc.matches = c.matches;
    rc.accepted = c.accepted;
    rc.drives = 1;
    rc.estimate = {c.scale, std::sqrt(c.rate_covariance(0, 0)), c.drift_rad_per_m, std::sqrt(c.rate_covariance(1, 1)),
                       c.turn, std::sqrt(c.rate_covariance(2, 2))};
    rc.rates = floored(rc.estimate, options.min_sigma);
    rc.calibrated = options.registration.estimate_rates && rc.path_m >= options.min_path_m &&
                    rc.accepted >= options.min_accepted;
    out.robots.push_back(rc);
  }
  std::sort(out.robots.begin(), out.robots.end(), [](const auto& a, const auto& b) { return a.robot < b.robot; });
  return out;
}

Calibration combine_drives(const std::vector<Calibration>& drives, const CalibrationOptions& options) {
  std::map<std::uint8_t, std::vector<const RobotCalibration*>> by_robot;
  for (const Calibration& d : drives)
    for (const RobotCalibration& r : d.robots) by_robot[r.robot].push_back(&r);
  Calibration out;
  for (const auto& [robot, seen] : by_robot) {
    RobotCalibration rc;
    rc.robot = robot;
    std::vector<const RobotCalibration*> used;
    for (const RobotCalibration* r : seen) {
      rc.path_m += r->path_m;
      rc.matches += r->matches;
      rc.accepted += r->accepted;
      if (r->calibrated) used.push_back(r);
    }
    rc.drives = static_cast<std::uint32_t>(used.size());
    rc.calibrated = !used.empty();
    if (used.empty()) {
      rc.rates = rc.estimate = seen.front()->estimate;
      out.robots.push_back(rc);
      continue;
    }
    for (std::size_t i = 0; i < 3; ++i) {
      double sum_w = 0, sum_wx = 0;
      for (const RobotCalibration* r : used) {
        OdometryPrior p = r->estimate;
        const double w = 1.0 / (*sigmas(p)[i] * *sigmas(p)[i]);
        sum_w += w;
        sum_wx += w * *values(p)[i];
      }
      const double mean = sum_wx / sum_w;
      double spread = 0;  // the weighted variance of the drives about the mean (0 for one drive)
      for (const RobotCalibration* r : used) {
        OdometryPrior p = r->estimate;
        const double w = 1.0 / (*sigmas(p)[i] * *sigmas(p)[i]);
        spread += w * (*values(p)[i] - mean) * (*values(p)[i] - mean) / sum_w;
      }
      *values(rc.estimate)[i] = mean;
      *sigmas(rc.estimate)[i] = std::sqrt(1.0 / sum_w + spread);
    }
    rc.rates = floored(rc.estimate, options.min_sigma);
    out.robots.push_back(rc);
  }
  return out;
}

std::string calibration_toml(const Calibration& calibration, const std::string& comment) {
  std::ostringstream o;
  std::istringstream lines(comment);
  for (std::string line; std::getline(lines, line);) o << "# " << line << "\n";
  for (const RobotCalibration& r : calibration.robots) {
    const std::string basis = std::to_string(r.accepted) + " of " + std::to_string(r.matches) + " matches accepted, " +
                              format("%.1f", r.path_m) + " m driven, " + std::to_string(r.drives) + " drive(s)";
    if (!r.calibrated) {
      o << "\n# robot " << int{r.robot} << ": not calibrated (" << basis << ")\n";
      continue;
    }
    const OdometryPrior& p = r.rates;
    const OdometryPrior& f = r.estimate;
    o << "\n[[registration.robot]]   # " << basis << "\n"
      << "id = " << int{r.robot} << "\n"
      << "scale_percent = " << format("%.4g", 100.0 * p.scale) << "\n"
      << "scale_sigma_percent = " << format("%.4g", 100.0 * p.sigma_scale)
      << format("   # before the floor: %.3g", 100.0 * f.sigma_scale) << "\n"
      << "drift_deg_per_m = " << format("%.4g", rad_to_deg(p.drift_rad_per_m)) << "\n"
      << "drift_sigma_deg_per_m = " << format("%.4g", rad_to_deg(p.sigma_drift_rad_per_m))
      << format("   # before the floor: %.3g", rad_to_deg(f.sigma_drift_rad_per_m)) << "\n"
      << "turn_percent = " << format("%.4g", 100.0 * p.turn) << "\n"
      << "turn_sigma_percent = " << format("%.4g", 100.0 * p.sigma_turn)
      << format("   # before the floor: %.3g", 100.0 * f.sigma_turn) << "\n";
  }
  return o.str();
}

}  // namespace teamscan::fusion
