// `teamscan eval DIR…`: runs the tracker and the paper's filters on labelled data sets and prints,
// per data set, the paper's metrics, SA/DA/AA/HA, the share kept per class and Table 1.
// Thin: the work is in groundstation/fusion/evaluation.hpp.
#include <cctype>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <optional>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include "common/dataset/dataset.hpp"
#include "common/units.hpp"
#include "groundstation/fusion/evaluation.hpp"
#include "groundstation/station/config.hpp"
#include "groundstation/station/session_replay.hpp"
#include "tools/demo/eval_report.hpp"
#include "tools/demo/progress.hpp"
#include "tools/teamscan/subcommand.hpp"
#include "tools/teamscan/support_slam.hpp"
#if __has_include("tools/render/render.hpp")
#include "tools/render/render.hpp"
#endif

namespace teamscan::tool {
namespace {

using mapping::DirectionSource;
using fusion::EvalOptions;
using fusion::EvalReport;
using mapping::MethodOptions;
using mapping::PlaneErrorReference;

struct EvalArgs {
  std::vector<std::string> dirs;
  std::string methods = "all";
  std::optional<double> resolution_m;
  std::optional<double> half_angle_deg;
  std::uint64_t seed = 1;
  bool registration = false;     // scan-to-map registration in the fusion core (docs/registration.md)
  bool no_registration = false;  // odometry alone: no registration and, without --pose-graph, no graph
  // Unset: the registration's defaults for the data set's lasers (registration::planar_scan_options
  // for an imported 2-D log, RegistrationOptions{} else).
  std::optional<double> registration_window_s;
  std::optional<int> registration_min_correspondences;
  // The odometry prior the registration's rates start from (docs/registration.md "Odometry prior and
  // calibration"): a calibration (`teamscan calibrate`'s output, or a station config: its
  // [registration] priors), then the team's default from the flags, in the config's units.
  std::string calibration_path;
  std::optional<double> prior_scale_percent, prior_scale_sigma_percent;
  std::optional<double> prior_drift_deg_per_m, prior_drift_sigma_deg_per_m;
  std::optional<double> prior_turn_percent, prior_turn_sigma_percent;
  std::string json_path;
  std::string out_dir;
  bool quiet = false;  // no progress on stderr
  // Named interpretations of the paper (PAPER_NOTES.md), defaults as there.
  double frequency_k = 0.0;
  double grid_origin_z_m = 0.0;
  double sigma_m = 0.35;
  double n_sigma = 1.0;
  std::string direction_source = "recompute";
  bool range_gate = false;
  double range_gate_margin_m = 0.3;
  bool height_gate = false;
  double height_gate_margin_m = 0.1;
  double ransac_threshold_m = 0.02;
  int ransac_iterations = 500;
  double floor_max_tilt_deg = 15.0;
  double floor_max_height_m = 0.5;
  std::string plane_error = "sample";
  double accel_noise_mps2 = mapping::TrackerOptions{}.accel_noise_mps2;
  double position_noise_m = mapping::TrackerOptions{}.position_noise_m;
  double velocity_noise_mps = mapping::TrackerOptions{}.velocity_noise_mps;
  // Odometry drift model of the tracker (TrackerOptions::drift_*; docs/beyond.md "Drift").
  double drift_m_per_m = mapping::TrackerOptions{}.drift_m_per_m;
  double drift_deg_per_m = mapping::TrackerOptions{}.drift_heading_rad_per_m * 180.0 / 3.14159265358979323846;
  double drift_deg_per_deg = mapping::TrackerOptions{}.drift_heading_rad_per_rad;
  // The fusion core's decision lag (TrackerOptions::team_lag_s; the station's fusion.team_lag_s).
  double team_lag_s = mapping::TrackerOptions{}.team_lag_s;
  // Beyond the paper (docs/beyond.md): localisation noise on what the filters see, and the new methods' knobs.
  double pose_noise_m = 0.0;
  double pose_noise_deg = 0.0;
  double pose_noise_correlation_s = 1.0;
  double fs_min_free = 2;
  double fs_free_per_hit = 1.0;
  double fs_clearance_m = 0.05;
  double fs_end_margin_m = 0.1;
  int fs_guard_neighbours = mapping::FreespaceOptions{}.guard_neighbours;
  double best_fs_free_per_hit = 8.0;
  double best_drift_band_free_per_hit = 2.0;
  int fs_ray_stride = static_cast<int>(mapping::MethodOptions{}.freespace.ray_stride);
  int best_fs_ray_stride = static_cast<int>(mapping::MethodOptions{}.best_freespace.ray_stride);
  double tracked_n_sigma = 3.0;
  double tracked_margin_m = 0.04;
  int tracked_height_profile = 1;
  double tracked_low_margin_m = mapping::TrackedOptions{}.low_margin_m;
  double tracked_low_floor_n_sigma = mapping::TrackedOptions{}.low_floor_n_sigma;
  double tracked_low_outline_margin_m = mapping::TrackedOptions{}.low_outline_margin_m;
  // Table-top heights (m): report the kept share of furniture points whose true z is within 3 cm of one.
  std::vector<double> top_heights_m;
  SlamEvalArgs slam;  // --trajectory-out, --relations (support_slam.hpp)
};

std::string number(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%g", v);
  return buf;
}

// The command line that reproduces the run: every parameter that differs from its default.
std::string reproduce_command(const EvalArgs& a, const std::string& dir) {
  const EvalArgs d;
  std::ostringstream o;
  o << "teamscan eval " << dir << " --method " << a.methods;
  if (a.resolution_m) o << " --resolution " << number(*a.resolution_m);
  if (a.half_angle_deg) o << " --half-angle " << number(*a.half_angle_deg);
  o << " --seed " << a.seed;
  if (a.registration && !a.no_registration) o << " --registration";
  if (a.registration_window_s) o << " --registration-window " << number(*a.registration_window_s);
  if (a.registration_min_correspondences) o << " --registration-min-correspondences " << *a.registration_min_correspondences;
  if (!a.calibration_path.empty()) o << " --calibration " << a.calibration_path;
  if (a.prior_scale_percent) o << " --prior-scale-percent " << number(*a.prior_scale_percent);
  if (a.prior_scale_sigma_percent) o << " --prior-scale-sigma-percent " << number(*a.prior_scale_sigma_percent);
  if (a.prior_drift_deg_per_m) o << " --prior-drift-deg-per-m " << number(*a.prior_drift_deg_per_m);
  if (a.prior_drift_sigma_deg_per_m) o << " --prior-drift-sigma-deg-per-m " << number(*a.prior_drift_sigma_deg_per_m);
  if (a.prior_turn_percent) o << " --prior-turn-percent " << number(*a.prior_turn_percent);
  if (a.prior_turn_sigma_percent) o << " --prior-turn-sigma-percent " << number(*a.prior_turn_sigma_percent);
  if (a.frequency_k != d.frequency_k) o << " --k " << number(a.frequency_k);
  if (a.grid_origin_z_m != d.grid_origin_z_m) o << " --grid-origin-z " << number(a.grid_origin_z_m);
  if (a.sigma_m != d.sigma_m) o << " --sigma " << number(a.sigma_m);
  if (a.n_sigma != d.n_sigma) o << " --n " << number(a.n_sigma);
  if (a.direction_source != d.direction_source) o << " --direction-source " << a.direction_source;
  if (a.range_gate) o << " --range-gate --range-gate-margin " << number(a.range_gate_margin_m);
  if (a.height_gate) o << " --height-gate --height-gate-margin " << number(a.height_gate_margin_m);
  if (a.ransac_threshold_m != d.ransac_threshold_m) o << " --ransac-threshold " << number(a.ransac_threshold_m);
  if (a.ransac_iterations != d.ransac_iterations) o << " --ransac-iterations " << a.ransac_iterations;
  if (a.floor_max_tilt_deg != d.floor_max_tilt_deg) o << " --floor-max-tilt " << number(a.floor_max_tilt_deg);
  if (a.floor_max_height_m != d.floor_max_height_m) o << " --floor-max-height " << number(a.floor_max_height_m);
  if (a.plane_error != d.plane_error) o << " --plane-error " << a.plane_error;
  if (a.accel_noise_mps2 != d.accel_noise_mps2) o << " --tracker-accel-noise " << number(a.accel_noise_mps2);
  if (a.position_noise_m != d.position_noise_m) o << " --tracker-position-noise " << number(a.position_noise_m);
  if (a.velocity_noise_mps != d.velocity_noise_mps) o << " --tracker-velocity-noise " << number(a.velocity_noise_mps);
  if (a.drift_m_per_m != d.drift_m_per_m) o << " --tracker-drift-m-per-m " << number(a.drift_m_per_m);
  if (a.drift_deg_per_m != d.drift_deg_per_m) o << " --tracker-drift-deg-per-m " << number(a.drift_deg_per_m);
  if (a.drift_deg_per_deg != d.drift_deg_per_deg) o << " --tracker-drift-deg-per-deg " << number(a.drift_deg_per_deg);
  if (a.team_lag_s != d.team_lag_s) o << " --team-lag " << number(a.team_lag_s);
  if (a.pose_noise_m != d.pose_noise_m) o << " --pose-noise-m " << number(a.pose_noise_m);
  if (a.pose_noise_deg != d.pose_noise_deg) o << " --pose-noise-deg " << number(a.pose_noise_deg);
  if (a.pose_noise_correlation_s != d.pose_noise_correlation_s) o << " --pose-noise-correlation " << number(a.pose_noise_correlation_s);
  if (a.fs_min_free != d.fs_min_free) o << " --fs-min-free " << number(a.fs_min_free);
  if (a.fs_free_per_hit != d.fs_free_per_hit) o << " --fs-free-per-hit " << number(a.fs_free_per_hit);
  if (a.fs_clearance_m != d.fs_clearance_m) o << " --fs-clearance " << number(a.fs_clearance_m);
  if (a.fs_end_margin_m != d.fs_end_margin_m) o << " --fs-end-margin " << number(a.fs_end_margin_m);
  if (a.fs_guard_neighbours != d.fs_guard_neighbours) o << " --fs-guard-neighbours " << a.fs_guard_neighbours;
  if (a.best_fs_free_per_hit != d.best_fs_free_per_hit) o << " --best-fs-free-per-hit " << number(a.best_fs_free_per_hit);
  if (a.best_drift_band_free_per_hit != d.best_drift_band_free_per_hit)
    o << " --best-drift-band-free-per-hit " << number(a.best_drift_band_free_per_hit);
  if (a.fs_ray_stride != d.fs_ray_stride) o << " --fs-ray-stride " << a.fs_ray_stride;
  if (a.best_fs_ray_stride != d.best_fs_ray_stride) o << " --best-fs-ray-stride " << a.best_fs_ray_stride;
  if (a.tracked_n_sigma != d.tracked_n_sigma) o << " --tracked-n-sigma " << number(a.tracked_n_sigma);
  if (a.tracked_margin_m != d.tracked_margin_m) o << " --tracked-margin " << number(a.tracked_margin_m);
  if (a.tracked_height_profile != d.tracked_height_profile) o << " --tracked-height-profile " << a.tracked_height_profile;
  if (a.tracked_low_margin_m != d.tracked_low_margin_m) o << " --tracked-low-margin " << number(a.tracked_low_margin_m);
  if (a.tracked_low_floor_n_sigma != d.tracked_low_floor_n_sigma)
    o << " --tracked-low-floor-n-sigma " << number(a.tracked_low_floor_n_sigma);
  if (a.tracked_low_outline_margin_m != d.tracked_low_outline_margin_m)
    o << " --tracked-low-outline-margin " << number(a.tracked_low_outline_margin_m);
  for (double h : a.top_heights_m) o << " --top-height " << number(h);
  if (a.no_registration) o << " --no-registration";
  if (a.no_registration && a.slam.pose_graph) o << " --pose-graph";
  if (!a.no_registration && !a.slam.pose_graph) o << " --no-pose-graph";
  if (a.slam.min_height_m) o << " --pose-graph-min-height " << number(*a.slam.min_height_m);
  if (a.slam.max_height_m) o << " --pose-graph-max-height " << number(*a.slam.max_height_m);
  if (a.slam.node_span_s) o << " --pose-graph-node-span " << number(*a.slam.node_span_s);
  if (a.slam.local_search_score) o << " --pose-graph-local-search-score " << number(*a.slam.local_search_score);
  if (a.slam.local_rotation_weight) o << " --pose-graph-local-rotation-weight " << number(*a.slam.local_rotation_weight);
  if (a.slam.closure_window_m) o << " --pose-graph-closure-window " << number(*a.slam.closure_window_m);
  if (a.slam.closure_max_distance_m) o << " --pose-graph-closure-max-distance " << number(*a.slam.closure_max_distance_m);
  if (!a.slam.relations_path.empty()) o << " --relations " << a.slam.relations_path;
  return o.str();
}

// "Furniture-top kept": the simulator labels a table top like any furniture, so tops are
// measured by geometry: furniture points whose true height is within 3 cm of a given top height.
std::string furniture_top_table(const Dataset& d, const EvalReport& report, const std::vector<double>& heights_m) {
  std::vector<std::size_t> tops;
  for (std::size_t i = 0; i < d.points.size(); ++i) {
    const LabelledPoint& p = d.points[i];
    if (p.label != PointClass::furniture) continue;
    for (double h : heights_m)
      if (std::abs(static_cast<double>(p.tz) - h) <= 0.03) {
        tops.push_back(i);
        break;
      }
  }
  std::ostringstream o;
  o << "Furniture tops (furniture points with true z within 3 cm of";
  for (double h : heights_m) o << " " << number(h);
  o << " m): " << tops.size() << " points\n\n| method | furniture-top kept % |\n| --- | ---: |\n";
  for (const fusion::MethodResult& m : report.methods) {
    std::size_t kept = 0;
    for (std::size_t i : tops) kept += m.removed[i] ? 0 : 1;
    char buf[32];
    if (tops.empty()) std::snprintf(buf, sizeof buf, "–");
    else std::snprintf(buf, sizeof buf, "%.2f", 100.0 * static_cast<double>(kept) / static_cast<double>(tops.size()));
    o << "| " << m.name << " | " << buf << " |\n";
  }
  return o.str();
}

bool write_file(const std::string& path, const std::string& text) {
  std::ofstream out(path, std::ios::trunc);
  out << text;
  return static_cast<bool>(out);
}

// Pictures of each method's result like the paper's figures 4–8 (top view; filtered points white),
// drawn by tools/render when it is part of the build.
std::string picture_slug(const std::string& name) {
  std::string out;
  for (char c : name) out += (std::isalnum(static_cast<unsigned char>(c)) || c == '.') ? c : '_';
  return out;
}

std::string write_pictures(const Dataset& dataset, const EvalReport& report, const std::string& out_dir) {
#if __has_include("tools/render/render.hpp")
  std::string md = "Pictures (top view; class colours, then each method with its filtered points white):\n\n";
  const std::string prefix = picture_slug(report.scenario);
  render::RenderOptions options;
  options.view = render::View::top;
  options.color = render::ColorMode::class_label;
  options.title = report.scenario + ": all points (ghosts black)";
  const std::string all = prefix + "-all-top.png";
  if (render::render_dataset_png(out_dir + "/" + all, dataset, {}, options)) md += "![all points](" + all + ")\n";
  options.color = render::ColorMode::filter;
  for (const fusion::MethodResult& m : report.methods) {
    std::vector<std::uint8_t> keep(m.removed.size());
    for (std::size_t i = 0; i < keep.size(); ++i) keep[i] = m.removed[i] ? 0 : 1;
    std::string shown = m.name;  // the picture font has no '@'
    for (std::size_t at = shown.find('@'); at != std::string::npos; at = shown.find('@')) shown.replace(at, 1, " at ");
    char title[160];
    std::snprintf(title, sizeof title, "%s: %s (DA %.1f %%, SA %.1f %%)", report.scenario.c_str(), shown.c_str(),
                  m.removal.da, m.removal.sa);
    options.title = title;
    const std::string file = prefix + "-" + picture_slug(m.name) + "-top.png";
    Status st = render::render_dataset_png(out_dir + "/" + file, dataset, keep, options);
    if (st) {
      md += "![" + m.name + "](" + file + ")\n";
    } else {
      std::fprintf(stderr, "teamscan eval: picture %s: %s\n", file.c_str(), st.error().what);
    }
  }
  return md;
#else
  (void)dataset;
  (void)report;
  (void)out_dir;
  return "Pictures: not generated (this build has no tools/render library).\n";
#endif
}

std::string describe(const Error& e) {
  std::string s = e.what;
  if (e.detail != 0) s += " (line " + std::to_string(e.detail) + ")";
  return s;
}

// The odometry priors of --calibration and the --prior-* flags on the registration's defaults; false
// (with the reason on stderr) for a file that does not parse or a prior that cannot be a robot's.
bool odometry_priors(const EvalArgs& a, registration::RegistrationOptions& o) {
  const bool flags = a.prior_scale_percent || a.prior_scale_sigma_percent || a.prior_drift_deg_per_m ||
                     a.prior_drift_sigma_deg_per_m || a.prior_turn_percent || a.prior_turn_sigma_percent;
  if ((flags || !a.calibration_path.empty()) && !(a.registration && !a.no_registration)) {
    std::fprintf(stderr, "teamscan eval: --calibration and --prior-* set the registration's odometry prior: they need --registration\n");
    return false;
  }
  if (!a.calibration_path.empty()) {
    station::ConfigError error;
    if (!station::load_registration_priors(a.calibration_path, o, error)) {
      std::fprintf(stderr, "teamscan eval: --calibration %s\n", error.message.c_str());
      return false;
    }
  }
  registration::OdometryPrior& p = o.prior;
  if (a.prior_scale_percent) p.scale = 0.01 * *a.prior_scale_percent;
  if (a.prior_scale_sigma_percent) p.sigma_scale = 0.01 * *a.prior_scale_sigma_percent;
  if (a.prior_drift_deg_per_m) p.drift_rad_per_m = deg_to_rad(*a.prior_drift_deg_per_m);
  if (a.prior_drift_sigma_deg_per_m) p.sigma_drift_rad_per_m = deg_to_rad(*a.prior_drift_sigma_deg_per_m);
  if (a.prior_turn_percent) p.turn = 0.01 * *a.prior_turn_percent;
  if (a.prior_turn_sigma_percent) p.sigma_turn = 0.01 * *a.prior_turn_sigma_percent;
  const std::string why = registration::prior_error(p);
  if (!why.empty()) {
    std::fprintf(stderr, "teamscan eval: --prior-*: %s\n", why.c_str());
    return false;
  }
  return true;
}

// The filters' options from the command line (the named interpretations of the paper and beyond).
MethodOptions method_options(const EvalArgs& a) {
  MethodOptions base;
  base.frequency.k = a.frequency_k;
  base.frequency.grid_origin_z_m = base.visibility.grid_origin_z_m = base.combined_grid_origin_z_m = a.grid_origin_z_m;
  base.position.sigma_m = a.sigma_m;
  base.position.n = a.n_sigma;
  base.direction.source = a.direction_source == "flags" ? DirectionSource::flags : DirectionSource::recompute;
  base.direction.range_gate = a.range_gate;
  base.direction.range_gate_margin_m = a.range_gate_margin_m;
  base.direction.height_gate = a.height_gate;
  base.direction.height_gate_margin_m = a.height_gate_margin_m;
  for (mapping::FreespaceOptions* fs : {&base.freespace, &base.best_freespace}) {
    fs->min_free = static_cast<std::uint32_t>(a.fs_min_free);
    fs->free_per_hit = a.fs_free_per_hit;
    fs->clearance_m = a.fs_clearance_m;
    fs->end_margin_m = a.fs_end_margin_m;
    fs->guard_neighbours = a.fs_guard_neighbours;
  }
  base.best_freespace.free_per_hit = a.best_fs_free_per_hit;
  base.best_drift_band_free_per_hit = a.best_drift_band_free_per_hit;
  base.freespace.ray_stride = static_cast<std::uint32_t>(a.fs_ray_stride);
  base.best_freespace.ray_stride = static_cast<std::uint32_t>(a.best_fs_ray_stride);
  base.tracked.n_sigma = a.tracked_n_sigma;
  base.tracked.margin_m = a.tracked_margin_m;
  base.tracked.height_profile = a.tracked_height_profile != 0;
  base.tracked.low_margin_m = a.tracked_low_margin_m;
  base.tracked.low_floor_n_sigma = a.tracked_low_floor_n_sigma;
  base.tracked.low_outline_margin_m = a.tracked_low_outline_margin_m;
  return base;
}

// The evaluation's options from the command line, but for its methods and the registration's options,
// which depend on the data set.
EvalOptions eval_options(const EvalArgs& a) {
  EvalOptions options;
  options.ransac.threshold_m = a.ransac_threshold_m;
  options.ransac.iterations = a.ransac_iterations;
  options.ransac.seed = a.seed;
  options.ransac.max_tilt_deg = a.floor_max_tilt_deg;
  options.ransac.max_height_m = a.floor_max_height_m;
  options.ransac.error_reference = a.plane_error == "refit" ? PlaneErrorReference::refit : PlaneErrorReference::sample;
  options.tracker.accel_noise_mps2 = a.accel_noise_mps2;
  options.tracker.position_noise_m = a.position_noise_m;
  options.tracker.velocity_noise_mps = a.velocity_noise_mps;
  options.tracker.drift_m_per_m = a.drift_m_per_m;
  options.tracker.drift_heading_rad_per_m = a.drift_deg_per_m * 3.14159265358979323846 / 180.0;
  options.tracker.drift_heading_rad_per_rad = a.drift_deg_per_deg;
  options.tracker.team_lag_s = a.team_lag_s;
  options.pose_noise.sigma_m = a.pose_noise_m;
  options.pose_noise.sigma_rad = a.pose_noise_deg * 3.14159265358979323846 / 180.0;
  options.pose_noise.correlation_s = a.pose_noise_correlation_s;
  options.pose_noise.seed = a.seed;
  options.registration = a.registration && !a.no_registration;
  return options;
}

// A data set folder (`teamscan sim`'s) or a ground-station session folder (scans.bin, no dataset.toml),
// read as what the station received and decided by the same fusion core
// (groundstation/station/session_replay.hpp).
Result<Dataset> read_eval_input(const std::string& dir) {
  if (std::filesystem::exists(dir + "/dataset.toml") || !std::filesystem::exists(dir + "/scans.bin")) return read_dataset(dir);
  station::SessionReadStats stats;
  Result<Dataset> dataset = station::read_session_dataset(dir, stats);
  if (stats.bad_pose_lines + stats.bad_scan_records > 0)
    std::fprintf(stderr, "teamscan eval: %s: skipped %llu bad poses.csv lines and %llu bad scans.bin records\n", dir.c_str(),
                 static_cast<unsigned long long>(stats.bad_pose_lines), static_cast<unsigned long long>(stats.bad_scan_records));
  return dataset;
}

// One data set: the report object; several: an array of them.
std::string joined_json(const std::vector<std::string>& jsons) {
  if (jsons.size() == 1) return jsons.front();
  std::string json = "[\n";
  for (std::size_t i = 0; i < jsons.size(); ++i) json += (i ? ",\n" : "") + jsons[i];
  json += "]\n";
  return json;
}

int run_eval(EvalArgs& a) {
  resolve_pose_graph(a.slam, a.no_registration);
  registration::RegistrationOptions priors;  // only its prior and robot_priors are used
  if (!odometry_priors(a, priors)) return 2;
  const MethodOptions base = method_options(a);
  auto methods = fusion::parse_methods(a.methods, a.resolution_m, a.half_angle_deg, base);
  if (!methods) {
    std::fprintf(stderr, "teamscan eval: --method %s: %s\n", a.methods.c_str(), methods.error().what);
    return 2;
  }
  EvalOptions options = eval_options(a);
  options.methods = methods.value();
  std::string markdown;
  std::vector<std::string> jsons;
  int status = 0;
  // Progress on stderr: a bar on a terminal, a line every few seconds otherwise (--quiet: none).
  demo::Progress progress(a.quiet);
  const auto started = std::chrono::steady_clock::now();
  for (const std::string& dir : a.dirs) {
    progress.stage("teamscan eval: reading " + dir);
    Result<Dataset> dataset = read_eval_input(dir);
    if (!dataset) {
      std::fprintf(stderr, "teamscan eval: %s: %s\n", dir.c_str(), describe(dataset.error()).c_str());
      status = 1;
      continue;
    }
    options.progress = [&](const std::string& stage, double fraction) {
      const double at_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
      progress.update(fraction, at_s, dir + ": " + stage);
    };
    // An imported 2-D log (level lasers; not a session folder, whose robots carry no mount): the
    // registration's policy for sparse planar scans.
    const bool planar = std::filesystem::exists(dir + "/dataset.toml") && fusion::level_lasers(dataset.value());
    options.registration_options = planar ? registration::planar_scan_options() : registration::RegistrationOptions{};
    if (a.registration_window_s) {
      options.registration_options.window_s = *a.registration_window_s;
      options.registration_options.window_m = 0.0;  // the window asked for, in time alone
    }
    options.registration_options.prior = priors.prior;
    options.registration_options.robot_priors = priors.robot_priors;
    if (a.registration_min_correspondences)
      options.registration_options.match.min_correspondences = static_cast<std::size_t>(*a.registration_min_correspondences);
    options.pose_graph = pose_graph_options(a.slam);
    Result<EvalReport> evaluated = fusion::evaluate(dataset.value(), options);
    progress.finish();
    if (!evaluated) {
      std::fprintf(stderr, "teamscan eval: %s: %s\n", dir.c_str(), evaluated.error().what);
      status = 1;
      continue;
    }
    EvalReport& report = evaluated.value();
    if (a.slam.pose_graph) print_pose_graph_summary(report);
    const SlamEvalOutput slam =
        a.slam.pose_graph ? slam_eval_outputs(a.slam, dataset.value(), report.graph_poses, {}, "pose graph")
                          : slam_eval_outputs(a.slam, dataset.value(), report.scan_poses, report.scan_decided,
                                              options.registration ? "registration" : "odometry");
    status = slam.ok ? status : 1;
    // The pictures show the cloud the metrics were computed on: where the fusion core put every point.
    const bool placed = options.registration || options.pose_graph.has_value();
    if (placed)
      for (std::size_t i = 0; i < report.placed.size() && i < dataset.value().points.size(); ++i) {
        dataset.value().points[i].x = report.placed[i].x;
        dataset.value().points[i].y = report.placed[i].y;
        dataset.value().points[i].z = report.placed[i].z;
      }
    // … and, without truth (whose track the pictures draw otherwise), the track the core placed the
    // scans on: one sample per decided scan at the pose the core decided it with.
    if (placed && dataset.value().truth.empty() && report.scan_poses.size() == dataset.value().scans.size()) {
      std::vector<TrajectorySample> track;
      for (std::size_t i = 0; i < dataset.value().scans.size(); ++i) {
        if (i < report.scan_decided.size() && !report.scan_decided[i]) continue;
        const ScanRecord& sc = dataset.value().scans[i];
        track.push_back({sc.robot, sc.stamp_ns, report.scan_poses[i], 0.0, 0.0});
      }
      dataset.value().odom = std::move(track);
    }
    const std::string command = reproduce_command(a, dir);
    const std::string md = demo::report_markdown(report, command);
    std::fputs(md.c_str(), stdout);
    std::fputs("\n", stdout);
    markdown += md + "\n";
    if (!a.top_heights_m.empty()) {
      const std::string tops = furniture_top_table(dataset.value(), report, a.top_heights_m);
      std::fputs(tops.c_str(), stdout);
      std::fputs("\n", stdout);
      markdown += tops + "\n";
    }
    if (!a.out_dir.empty()) {
      std::error_code ec;
      std::filesystem::create_directories(a.out_dir, ec);
      markdown += write_pictures(dataset.value(), report, a.out_dir) + "\n";
    }
    if (!slam.pose_markdown.empty()) {
      std::fputs(slam.pose_markdown.c_str(), stdout);
      std::fputs("\n", stdout);
      markdown += slam.pose_markdown + "\n";
    }
    if (!slam.markdown.empty()) {
      std::fputs(slam.markdown.c_str(), stdout);
      std::fputs("\n", stdout);
      markdown += slam.markdown + "\n";
    }
    demo::ReportJson report_value = demo::report_json_value(report, command);
    if (!slam.relations.is_null()) report_value["relations"] = slam.relations;
    if (!slam.pose_errors.is_null()) report_value["pose_graph"] = slam.pose_errors;
    jsons.push_back(demo::json_report(report_value));
  }
  const std::string json = joined_json(jsons);
  if (!a.json_path.empty() && !write_file(a.json_path, json)) {
    std::fprintf(stderr, "teamscan eval: cannot write %s\n", a.json_path.c_str());
    status = 1;
  }
  if (!a.out_dir.empty()) {
    std::error_code ec;
    std::filesystem::create_directories(a.out_dir, ec);
    const std::string header = "# teamscan evaluation report\n\n";
    if (ec || !write_file(a.out_dir + "/report.md", header + markdown) || !write_file(a.out_dir + "/report.json", json)) {
      std::fprintf(stderr, "teamscan eval: cannot write the report into %s\n", a.out_dir.c_str());
      status = 1;
    } else {
      progress.stage("teamscan eval: wrote " + a.out_dir + "/report.md and report.json");
    }
  }
  return status;
}

const SubcommandRegistration kEval{{"eval", "Evaluate the ghost-point filters on labelled data sets", [](CLI::App& app) {
  auto a = std::make_shared<EvalArgs>();
  app.add_option("DIR", a->dirs, "Data set folder(s) written by `teamscan sim`, or ground-station session folders (scans.bin, poses.csv)")->required()->check(CLI::ExistingDirectory);
  app.add_option("--method", a->methods,
                 "Methods, comma separated, or 'all': frequency (eq. 4), visibility (eq. 5), position (eq. 6), "
                 "direction (eq. 7), combined (direction then visibility, Table 6). Without --resolution/--half-angle "
                 "frequency and visibility run at 0.05 and 0.1 m, direction at 5 and 7 deg, combined at 7 deg and 0.1 m")
      ->capture_default_str();
  app.add_option("--resolution", a->resolution_m, "Voxel size in metres for the map-based methods (paper: 0.05, 0.1)")
      ->check(CLI::PositiveNumber);
  app.add_option("--half-angle", a->half_angle_deg, "Direction-filter cone half-angle ha in degrees (paper: 5, 7)")
      ->check(CLI::Range(0.0, 60.0));
  auto* reg_on = app.add_flag("--registration", a->registration,
               "Correct each robot's odometry drift by scan-to-map registration in the fusion core (as the station with "
               "[fusion] registration = true); with --no-pose-graph the cloud is the registration's, and the report gives "
               "pose and point error with odometry alone and registered (docs/registration.md)");
  auto* reg_off = app.add_flag("--no-registration", a->no_registration,
                               "Odometry alone: no registration and no pose graph (with --pose-graph: the graph over odometry)");
  reg_on->excludes(reg_off);
  app.add_option("--registration-window", a->registration_window_s,
                 "Registration: a robot's recent points matched as one rigid piece, seconds ([registration] window_s; "
                 "default 2.5; an imported 2-D log: the last scan, by path, docs/registration.md)")
      ->check(CLI::Range(0.1, 60.0));
  app.add_option("--registration-min-correspondences", a->registration_min_correspondences,
                 "Registration: a match needs at least this many features with a correspondence (default 25)")
      ->check(CLI::Range(3, 100000));
  app.add_option("--calibration", a->calibration_path,
                 "Registration: each robot's odometry prior from FILE (`teamscan calibrate`'s output, or a station config: "
                 "its [registration] priors; docs/registration.md)")
      ->check(CLI::ExistingFile);
  const registration::OdometryPrior d;  // the registration's defaults: no drift known
  app.add_option("--prior-scale-percent", a->prior_scale_percent,
                 "Registration: every robot's odometry distance scale starts here (%; negative: the odometry over-reports "
                 "the distance; default " + number(100.0 * d.scale) + "; [registration] scale_percent)");
  app.add_option("--prior-scale-sigma-percent", a->prior_scale_sigma_percent,
                 "… and its σ (%, default " + number(100.0 * d.sigma_scale) + ")");
  app.add_option("--prior-drift-deg-per-m", a->prior_drift_deg_per_m,
                 "Registration: the heading drift's prior (deg/m, default " + number(rad_to_deg(d.drift_rad_per_m)) + ")");
  app.add_option("--prior-drift-sigma-deg-per-m", a->prior_drift_sigma_deg_per_m,
                 "… and its σ (deg/m, default " + number(rad_to_deg(d.sigma_drift_rad_per_m)) + ")");
  app.add_option("--prior-turn-percent", a->prior_turn_percent,
                 "Registration: the turn scale's prior (%, default " + number(100.0 * d.turn) + ")");
  app.add_option("--prior-turn-sigma-percent", a->prior_turn_sigma_percent,
                 "… and its σ (%, default " + number(100.0 * d.sigma_turn) + ")");
  app.add_option("--seed", a->seed, "RANSAC seed (the report is deterministic for a seed)")->capture_default_str();
  app.add_option("--json", a->json_path, "Write the JSON report to FILE");
  app.add_flag("--quiet,-q", a->quiet, "No progress on stderr (errors only)");
  app.add_option("--out", a->out_dir, "Write report.md and report.json (and pictures) into REPORTDIR");
  app.add_option("--k", a->frequency_k, "Frequency filter: remove if count < mean - k*stddev (paper: no value)")
      ->capture_default_str();
  app.add_option("--grid-origin-z", a->grid_origin_z_m,
                 "Map-based methods: vertical offset of the voxel grid (m; paper 0 puts a z = 0 floor on a voxel boundary, "
                 "-r/2 centres it in a voxel)")
      ->capture_default_str();
  app.add_option("--sigma", a->sigma_m, "Position filter: robot size sigma in metres")->capture_default_str();
  app.add_option("--n", a->n_sigma, "Position filter: remove within n*sigma of another robot")->capture_default_str();
  app.add_option("--direction-source", a->direction_source,
                 "Direction filter: 'recompute' (eq. 7 from the tracked team) or 'flags' (the onboard decisions)")
      ->check(CLI::IsMember({"recompute", "flags"}))
      ->capture_default_str();
  app.add_flag("--range-gate", a->range_gate,
               "Direction filter variant (off = the paper's rule): only points within body radius 0.36 m + margin of "
               "the teammate's distance along L");
  app.add_option("--range-gate-margin", a->range_gate_margin_m, "Range gate margin (m)")->capture_default_str();
  app.add_flag("--height-gate", a->height_gate,
               "Direction filter variant (off = the paper's rule): only points below the teammate's height 0.5 m + margin");
  app.add_option("--height-gate-margin", a->height_gate_margin_m, "Height gate margin (m)")->capture_default_str();
  app.add_option("--ransac-threshold", a->ransac_threshold_m, "RANSAC inlier distance (m)")->capture_default_str();
  app.add_option("--ransac-iterations", a->ransac_iterations, "RANSAC iterations")->check(CLI::PositiveNumber)->capture_default_str();
  app.add_option("--floor-max-tilt", a->floor_max_tilt_deg, "Floor plane: normal within this angle of +z (deg, 0 = any plane)")
      ->capture_default_str();
  app.add_option("--floor-max-height", a->floor_max_height_m, "Floor plane: at most this high (m), so the ceiling never wins")
      ->capture_default_str();
  app.add_option("--plane-error", a->plane_error,
                 "Signed plane error against the best RANSAC 'sample' plane or the least-squares 'refit' (which is ~0 by construction)")
      ->check(CLI::IsMember({"sample", "refit"}))
      ->capture_default_str();
  app.add_option("--tracker-accel-noise", a->accel_noise_mps2, "Kalman process noise: acceleration sigma (m/s^2)")->capture_default_str();
  app.add_option("--tracker-position-noise", a->position_noise_m, "Kalman measurement noise: odometry position sigma (m)")
      ->capture_default_str();
  app.add_option("--tracker-velocity-noise", a->velocity_noise_mps, "Kalman measurement noise: odometry velocity sigma (m/s)")
      ->capture_default_str();
  app.add_option("--tracker-drift-m-per-m", a->drift_m_per_m,
                 "Tracker odometry drift: position sigma grows this much per metre driven (docs/beyond.md)")
      ->check(CLI::NonNegativeNumber)->capture_default_str();
  app.add_option("--tracker-drift-deg-per-m", a->drift_deg_per_m, "Tracker odometry drift: heading sigma per metre driven (deg/m)")
      ->check(CLI::NonNegativeNumber)->capture_default_str();
  app.add_option("--tracker-drift-deg-per-deg", a->drift_deg_per_deg, "Tracker odometry drift: heading sigma per degree turned")
      ->check(CLI::NonNegativeNumber)->capture_default_str();
  app.add_option("--team-lag", a->team_lag_s,
                 "Fusion core decision lag (s): the team at a scan's stamp t is predicted from poses stamped <= t - lag "
                 "(the station's fusion.team_lag_s; 0: exact)")
      ->check(CLI::Range(0.0, 10.0))->capture_default_str();
  app.add_option("--pose-noise-m", a->pose_noise_m,
                 "Localisation noise added to the poses the filters see: sigma per axis (m; docs/beyond.md)")
      ->check(CLI::NonNegativeNumber)->capture_default_str();
  app.add_option("--pose-noise-deg", a->pose_noise_deg, "Localisation noise: heading sigma (deg)")
      ->check(CLI::NonNegativeNumber)->capture_default_str();
  app.add_option("--pose-noise-correlation", a->pose_noise_correlation_s, "Localisation noise: correlation time (s)")
      ->check(CLI::PositiveNumber)->capture_default_str();
  app.add_option("--fs-min-free", a->fs_min_free, "freespace/best: free passes a voxel needs to be void")
      ->check(CLI::NonNegativeNumber)->capture_default_str();
  app.add_option("--fs-free-per-hit", a->fs_free_per_hit, "freespace: and at least this many free passes per hit (best: --best-fs-free-per-hit)")
      ->check(CLI::NonNegativeNumber)->capture_default_str();
  app.add_option("--fs-clearance", a->fs_clearance_m, "freespace/best: grazing rays stop this high above their hit (m)")
      ->check(CLI::NonNegativeNumber)->capture_default_str();
  app.add_option("--fs-end-margin", a->fs_end_margin_m, "freespace/best: rays stop this far short of their hit (m)")
      ->check(CLI::NonNegativeNumber)->capture_default_str();
  app.add_option("--fs-guard-neighbours", a->fs_guard_neighbours,
                 "freespace/best: a void voxel with a solid neighbour stays; 6 = face neighbours, 26 = also edges and corners")
      ->check(CLI::IsMember({6, 26}))->capture_default_str();
  app.add_option("--best-fs-free-per-hit", a->best_fs_free_per_hit, "best: its freespace part's free passes per hit")
      ->check(CLI::NonNegativeNumber)->capture_default_str();
  app.add_option("--best-drift-band-free-per-hit", a->best_drift_band_free_per_hit,
                 "best: a point only in the drift band of a body box goes when its voxel has this many free passes per hit")
      ->check(CLI::NonNegativeNumber)->capture_default_str();
  app.add_option("--fs-ray-stride", a->fs_ray_stride,
                 "freespace: every Nth ray of a scan is cast, a pass counts as N rays (1: every ray; best: --best-fs-ray-stride)")
      ->check(CLI::Range(1, 64))->capture_default_str();
  app.add_option("--best-fs-ray-stride", a->best_fs_ray_stride, "best: its freespace part casts every Nth ray of a scan")
      ->check(CLI::Range(1, 64))->capture_default_str();
  app.add_option("--tracked-n-sigma", a->tracked_n_sigma, "tracked/best: body box inflated by n Kalman sigma")
      ->check(CLI::NonNegativeNumber)->capture_default_str();
  app.add_option("--tracked-margin", a->tracked_margin_m, "tracked/best: fixed body box margin (m)")
      ->check(CLI::NonNegativeNumber)->capture_default_str();
  app.add_option("--tracked-height-profile", a->tracked_height_profile,
                 "tracked/best: 1 = body box follows the Pioneer's height profile (housing only above the top plate), 0 = one box")
      ->check(CLI::Range(0, 1))->capture_default_str();
  app.add_option("--tracked-low-margin", a->tracked_low_margin_m,
                 "tracked/best: margin of the wheel strips below 2 cm (m; negative = --tracked-margin)")
      ->capture_default_str();
  app.add_option("--tracked-low-floor-n-sigma", a->tracked_low_floor_n_sigma,
                 "tracked/best: a wheel-strip point within this many σ of the floor's height (σ = 5 mm range noise "
                 "· |sin elevation| of its beam) is a wheel hit only at the wheel's outline + "
                 "--tracked-low-outline-margin (negative = off)")
      ->capture_default_str();
  app.add_option("--tracked-low-outline-margin", a->tracked_low_outline_margin_m,
                 "tracked/best: margin of the wheel outline for floor-consistent low points (m; negative = off)")
      ->capture_default_str();
  add_slam_eval_options(app, a->slam);
  app.add_option("--top-height", a->top_heights_m,
                 "Table-top height (m, repeatable): also report the kept share of furniture points within 3 cm of it");
  return [a] { return run_eval(*a); };
}}};

}  // namespace
}  // namespace teamscan::tool
