// `teamscan calibrate DRIVE… --out calib.toml`: each robot's odometry drift rates (distance scale,
// heading drift per metre, turn scale) with their σ, measured by the registration on calibration
// drives, written as the [[registration.robot]] TOML that the station's config and
// `teamscan eval --calibration` take as each robot's odometry prior. Thin: the work is in
// groundstation/fusion/calibration.hpp; docs/registration.md "Odometry prior and calibration".
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "common/dataset/dataset.hpp"
#include "common/units.hpp"
#include "groundstation/fusion/calibration.hpp"
#include "groundstation/station/session_replay.hpp"
#include "tools/teamscan/subcommand.hpp"

namespace teamscan::tool {
namespace {

struct CalibrateArgs {
  std::vector<std::string> dirs;
  std::string out;
  fusion::CalibrationOptions options;
};

// A data set folder (`teamscan sim`, `teamscan import`) or a ground-station session folder.
Result<Dataset> read_drive(const std::string& dir) {
  if (!std::filesystem::exists(dir + "/dataset.toml") && std::filesystem::exists(dir + "/scans.bin")) {
    station::SessionReadStats stats;
    return station::read_session_dataset(dir, stats);
  }
  return read_dataset(dir);
}

int run_calibrate(const CalibrateArgs& a) {
  std::vector<fusion::Calibration> drives;
  std::string comment = "teamscan calibrate: each robot's odometry prior for the station's [registration] or\n"
                        "`teamscan eval --calibration` (docs/registration.md \"Odometry prior and calibration\"), from:";
  for (const std::string& dir : a.dirs) {
    std::fprintf(stderr, "teamscan calibrate: %s\n", dir.c_str());
    Result<Dataset> drive = read_drive(dir);
    if (!drive) {
      std::fprintf(stderr, "teamscan calibrate: %s: %s\n", dir.c_str(), drive.error().what);
      return 1;
    }
    Result<fusion::Calibration> calibrated = fusion::calibrate_drive(drive.value(), a.options);
    if (!calibrated) {
      std::fprintf(stderr, "teamscan calibrate: %s: %s\n", dir.c_str(), calibrated.error().what);
      return 1;
    }
    drives.push_back(std::move(calibrated.value()));
    comment += "\n  " + dir + " (scenario " + drive.value().scenario + ", seed " + std::to_string(drive.value().seed) + ")";
    for (const fusion::RobotCalibration& r : drives.back().robots)
      std::fprintf(stderr, "  robot %d: scale %+.3f %%, drift %+.4f deg/m, turn %+.3f %% (σ %.3f %%, %.4f deg/m, %.3f %%), "
                           "%llu of %llu matches, %.1f m%s\n",
                   int{r.robot}, 100.0 * r.estimate.scale, rad_to_deg(r.estimate.drift_rad_per_m),
                   100.0 * r.estimate.turn, 100.0 * r.estimate.sigma_scale,
                   rad_to_deg(r.estimate.sigma_drift_rad_per_m), 100.0 * r.estimate.sigma_turn,
                   static_cast<unsigned long long>(r.accepted), static_cast<unsigned long long>(r.matches), r.path_m,
                   r.calibrated ? "" : " (not calibrated: too little path or too few matches)");
  }
  const fusion::Calibration combined = fusion::combine_drives(drives, a.options);
  const std::string text = fusion::calibration_toml(combined, comment);
  if (a.out.empty() || a.out == "-") {
    std::fputs(text.c_str(), stdout);
    return 0;
  }
  std::ofstream f(a.out, std::ios::trunc);
  f << text;
  if (!f) {
    std::fprintf(stderr, "teamscan calibrate: cannot write %s\n", a.out.c_str());
    return 1;
  }
  std::fprintf(stderr, "teamscan calibrate: wrote %s\n", a.out.c_str());
  return 0;
}

const SubcommandRegistration kCalibrate{
    {"calibrate", "Measure each robot's odometry drift on calibration drives: the registration's prior", [](CLI::App& app) {
       auto a = std::make_shared<CalibrateArgs>();
       app.add_option("DRIVE", a->dirs,
                      "Calibration drive(s): data set folders (`teamscan sim`) or ground-station session folders; several "
                      "drives of the same robots are combined")
           ->required()
           ->check(CLI::ExistingDirectory);
       app.add_option("--out,-o", a->out, "Write the TOML fragment to FILE (default: stdout)");
       app.add_option("--min-path", a->options.min_path_m, "A robot is calibrated only after this much path (m)")
           ->check(CLI::NonNegativeNumber)
           ->capture_default_str();
       app.add_option("--min-accepted", a->options.min_accepted, "… and this many accepted matches")->capture_default_str();
       app.footer("The station takes the output appended to its config (or its [[registration.robot]] tables copied "
                  "there); `teamscan eval --registration --calibration FILE` takes the file. docs/registration.md.");
       return [a] { return run_calibrate(*a); };
     }}};

}  // namespace
}  // namespace teamscan::tool
