// Offline evaluation: data set → time-ordered scans with team states → each method → metrics.
#include "groundstation/fusion/evaluation.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <map>
#include <set>
#include <sstream>
#include <tuple>

#include "common/units.hpp"
#include "groundstation/fusion/core.hpp"

namespace teamscan::mapping {

ScanView PreparedDataset::view(std::size_t scan_index) const {
  const PreparedScan& s = scans[scan_index];
  ScanView v;
  v.robot = s.record.robot;
  v.scan = s.record.scan;
  v.stamp_ns = s.record.stamp_ns;
  v.origin_m = s.record.origin;
  v.map_from_robot = s.record.pose;
  v.points = std::span<const MapPoint>(points).subspan(s.first, s.count);
  v.flags = std::span<const std::uint16_t>(flags).subspan(s.first, s.count);
  v.team = &teams[s.team];
  return v;
}

namespace {
// Per-robot AR(1) pose error (PoseNoise), advanced to each stamp it is asked for in time order.
class PoseErrorProcess {
 public:
  explicit PoseErrorProcess(const PoseNoise& noise) : noise_{noise} {}
  // The error (dx, dy, dθ) of `robot` at `stamp_ns` (stamps non-decreasing per robot).
  Pose2 at(std::uint8_t robot, std::int64_t stamp_ns) {
    State& s = states_[robot];
    if (!s.started) {
      s.rng = noise_.seed * 0x9E3779B97F4A7C15ULL + robot;
      s.e = {noise_.sigma_m * normal(s), noise_.sigma_m * normal(s), noise_.sigma_rad * normal(s)};
      s.started = true;
      s.stamp_ns = stamp_ns;
    } else if (stamp_ns > s.stamp_ns) {
      const double dt = static_cast<double>(stamp_ns - s.stamp_ns) * 1e-9;
      const double a = std::exp(-dt / noise_.correlation_s), b = std::sqrt(std::max(0.0, 1.0 - a * a));
      s.e.x_m = a * s.e.x_m + b * noise_.sigma_m * normal(s);
      s.e.y_m = a * s.e.y_m + b * noise_.sigma_m * normal(s);
      s.e.theta_rad = a * s.e.theta_rad + b * noise_.sigma_rad * normal(s);
      s.stamp_ns = stamp_ns;
    }
    return s.e;
  }

 private:
  struct State {
    bool started = false;
    std::uint64_t rng = 0;
    std::int64_t stamp_ns = 0;
    Pose2 e;
  };
  static double uniform(State& s) {  // SplitMix64 → (0, 1)
    std::uint64_t z = (s.rng += 0x9E3779B97F4A7C15ULL);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ULL;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBULL;
    z ^= z >> 31;
    return (static_cast<double>(z >> 11) + 0.5) * (1.0 / 9007199254740992.0);
  }
  static double normal(State& s) {  // Box–Muller, one value per call
    const double u1 = uniform(s), u2 = uniform(s);
    return std::sqrt(-2.0 * std::log(u1)) * std::cos(6.283185307179586 * u2);
  }
  PoseNoise noise_;
  std::map<std::uint8_t, State> states_;
};
}  // namespace

PreparedDataset prepare_dataset(const Dataset& dataset, const TrackerOptions& tracker_options, const PoseNoise& noise) {
  PreparedDataset out;
  PoseErrorProcess pose_error(noise);
  // Group the points by (robot, scan), keeping their order within a scan.
  std::map<std::pair<std::uint8_t, std::uint32_t>, std::vector<std::size_t>> by_scan;
  for (std::size_t i = 0; i < dataset.points.size(); ++i)
    by_scan[{dataset.points[i].robot, dataset.points[i].scan}].push_back(i);

  std::vector<ScanRecord> records;
  records.reserve(by_scan.size());
  std::map<std::pair<std::uint8_t, std::uint32_t>, bool> known;
  for (const ScanRecord& r : dataset.scans) {
    if (known.emplace(std::make_pair(r.robot, r.scan), true).second) records.push_back(r);
  }
  for (const auto& [key, indices] : by_scan) {
    if (known.count(key)) continue;
    // A scan with points but no row in scans.csv: evaluated at time 0 without team state.
    ScanRecord r;
    r.robot = key.first;
    r.scan = key.second;
    records.push_back(r);
    out.orphan_points += indices.size();
  }
  std::sort(records.begin(), records.end(), [](const ScanRecord& a, const ScanRecord& b) {
    return std::tie(a.stamp_ns, a.robot, a.scan) < std::tie(b.stamp_ns, b.robot, b.scan);
  });

  // The tracker sees the odometry in time order, as the ground station receives it.
  std::vector<const TrajectorySample*> odom;
  odom.reserve(dataset.odom.size());
  for (const TrajectorySample& s : dataset.odom) odom.push_back(&s);
  std::stable_sort(odom.begin(), odom.end(), [](const TrajectorySample* a, const TrajectorySample* b) {
    return std::tie(a->stamp_ns, a->robot) < std::tie(b->stamp_ns, b->robot);
  });
  TeamTracker tracker(tracker_options);
  std::size_t next_odom = 0;

  out.points.reserve(dataset.points.size());
  out.flags.reserve(dataset.points.size());
  out.source_index.reserve(dataset.points.size());
  out.scans.reserve(records.size());
  out.teams.reserve(records.size());
  for (const ScanRecord& r : records) {
    while (next_odom < odom.size() && odom[next_odom]->stamp_ns <= r.stamp_ns) {
      const TrajectorySample& s = *odom[next_odom++];
      Pose2 pose = s.pose;
      if (noise.active()) {
        const Pose2 e = pose_error.at(s.robot, s.stamp_ns);
        pose = {pose.x_m + e.x_m, pose.y_m + e.y_m, pose.theta_rad + e.theta_rad};
      }
      tracker.add_pose(s.robot, s.stamp_ns, pose, s.v_mps);
    }
    PreparedScan ps;
    ps.record = r;
    if (noise.active()) {
      const Pose2 e = pose_error.at(r.robot, r.stamp_ns);
      ps.record.pose = {r.pose.x_m + e.x_m, r.pose.y_m + e.y_m, r.pose.theta_rad + e.theta_rad};
      ps.record.origin = {r.origin.x + e.x_m, r.origin.y + e.y_m, r.origin.z};
    }
    ps.first = out.points.size();
    ps.team = out.teams.size();
    out.teams.push_back(tracker.predict(r.stamp_ns));
    auto it = by_scan.find({r.robot, r.scan});
    if (it != by_scan.end()) {
      for (std::size_t i : it->second) {
        const LabelledPoint& p = dataset.points[i];
        out.points.push_back({p.x, p.y, p.z});
        out.flags.push_back(p.flags);
        out.source_index.push_back(i);
      }
    }
    ps.count = out.points.size() - ps.first;
    out.scans.push_back(ps);
  }
  return out;
}

std::vector<std::uint8_t> decide_through_core(const Dataset& dataset, const std::string& method, const MethodOptions& options,
                                              const TrackerOptions& tracker, const PoseNoise& noise) {
  CoreRunOptions run;
  run.tracker = tracker;
  run.noise = noise;
  return run_through_core(dataset, method, options, run).removed;
}

bool level_lasers(const Dataset& dataset) {
  bool level = !dataset.robots.empty();
  for (const DatasetRobot& r : dataset.robots) level = level && r.mount_rpy_rad[0] == 0.0 && r.mount_rpy_rad[1] == 0.0;
  return level;
}

CoreRun run_through_core(const Dataset& dataset, const std::string& method, const MethodOptions& options, const CoreRunOptions& run) {
  const PoseNoise& noise = run.noise;
  fusion::CoreOptions co;
  co.method = method;
  co.methods = options;
  co.tracker = run.tracker;
  co.max_points_per_voxel = 0;  // the decisions are kept here, per point
  co.registration = run.registration;
  co.registration_options = run.registration_options;
  auto created = fusion::FusionCore::create(co);
  TEAMSCAN_EXPECTS(created.ok());
  fusion::FusionCore& core = *created.value();

  // Points grouped by (robot, scan), in data set order within a scan.
  std::map<std::pair<std::uint8_t, std::uint32_t>, std::vector<std::size_t>> by_scan;
  for (std::size_t i = 0; i < dataset.points.size(); ++i) by_scan[{dataset.points[i].robot, dataset.points[i].scan}].push_back(i);
  std::vector<ScanRecord> records;
  std::map<std::pair<std::uint8_t, std::uint32_t>, bool> known;
  for (const ScanRecord& r : dataset.scans)
    if (known.emplace(std::make_pair(r.robot, r.scan), true).second) records.push_back(r);
  for (const auto& [key, indices] : by_scan) {
    if (known.count(key)) continue;
    ScanRecord r;  // a scan with points but no row in scans.csv: at time 0 (no team state)
    r.robot = key.first;
    r.scan = key.second;
    records.push_back(r);
  }
  // One time line: poses before scans of the same stamp (the pose at the scan's stamp is its pose).
  struct Event {
    std::int64_t stamp_ns;
    int kind;  // 0 pose, 1 scan
    std::uint8_t robot;
    std::uint32_t scan;
    std::size_t index;
  };
  std::vector<Event> events;
  events.reserve(dataset.odom.size() + records.size());
  for (std::size_t i = 0; i < dataset.odom.size(); ++i)
    events.push_back({dataset.odom[i].stamp_ns, 0, dataset.odom[i].robot, 0, i});
  for (std::size_t i = 0; i < records.size(); ++i) events.push_back({records[i].stamp_ns, 1, records[i].robot, records[i].scan, i});
  std::stable_sort(events.begin(), events.end(), [](const Event& a, const Event& b) {
    return std::tie(a.stamp_ns, a.kind, a.robot, a.scan) < std::tie(b.stamp_ns, b.kind, b.robot, b.scan);
  });

  // Scan rows by (robot, scan) for the poses the core decided them with.
  std::map<std::pair<std::uint8_t, std::uint32_t>, std::size_t> row_of;
  for (std::size_t i = 0; i < dataset.scans.size(); ++i) row_of.emplace(std::make_pair(dataset.scans[i].robot, dataset.scans[i].scan), i);
  CoreRun out;
  out.placed.reserve(dataset.points.size());
  for (const LabelledPoint& lp : dataset.points) out.placed.push_back({lp.x, lp.y, lp.z});
  out.scan_poses.resize(dataset.scans.size());
  out.scan_decided.assign(dataset.scans.size(), 0);
  std::vector<std::uint8_t> bits(dataset.points.size(), 0);
  core.set_release_callback([&](const fusion::FusedScan& f) {
    if (auto row = row_of.find({f.view->robot, f.view->scan}); row != row_of.end()) {
      out.scan_poses[row->second] = f.view->map_from_robot;
      out.scan_decided[row->second] = 1;
    }
    auto it = by_scan.find({f.view->robot, f.view->scan});
    if (it == by_scan.end()) return;
    for (std::size_t j = 0; j < it->second.size() && j < f.bits.size(); ++j) {
      bits[it->second[j]] = f.bits[j];
      out.placed[it->second[j]] = f.view->points[j];
    }
  });
  PoseErrorProcess pose_error(noise);
  std::vector<MapPoint> points;
  std::vector<std::uint16_t> flags, beams;
  for (const Event& e : events) {
    if (e.kind == 0) {
      const TrajectorySample& s = dataset.odom[e.index];
      fusion::PoseInput p{s.robot, s.stamp_ns, s.stamp_ns, s.pose, s.v_mps, s.w_radps};
      if (noise.active()) {
        const Pose2 err = pose_error.at(s.robot, s.stamp_ns);
        p.odom = {s.pose.x_m + err.x_m, s.pose.y_m + err.y_m, s.pose.theta_rad + err.theta_rad};
      }
      core.add_pose(p);
      continue;
    }
    const ScanRecord& r = records[e.index];
    points.clear();
    flags.clear();
    beams.clear();
    auto it = by_scan.find({r.robot, r.scan});
    if (it != by_scan.end()) {
      for (std::size_t i : it->second) {
        const LabelledPoint& lp = dataset.points[i];
        points.push_back({lp.x, lp.y, lp.z});
        flags.push_back(lp.flags);
        beams.push_back(lp.beam);
      }
    }
    fusion::ScanInput in;
    in.view.robot = r.robot;
    in.view.scan = r.scan;
    in.view.stamp_ns = r.stamp_ns;
    in.view.origin_m = r.origin;
    if (noise.active()) {
      const Pose2 err = pose_error.at(r.robot, r.stamp_ns);
      in.view.origin_m = {r.origin.x + err.x_m, r.origin.y + err.y_m, r.origin.z};
    }
    in.view.points = points;
    in.view.flags = flags;
    in.arrival_ns = r.stamp_ns;
    in.beams = beams;
    core.add_scan(in);
  }
  core.flush();
  // The decision now, for every point where the core put it.
  out.removed.assign(dataset.points.size(), 0);
  core.decide(out.placed, bits, out.removed);
  if (const registration::Registration* reg = core.registration()) {
    for (const DatasetRobot& r : dataset.robots)
      if (const registration::RobotCorrection* c = reg->correction(r.id)) out.robots.push_back(*c);
    out.masked_points = core.counters().registration_masked_points;
  }
  return out;
}

std::vector<std::uint8_t> run_offline(const PreparedDataset& prepared, Filter& filter) {
  filter.reset();
  for (std::size_t s = 0; s < prepared.scans.size(); ++s) filter.observe(prepared.view(s));
  std::vector<std::uint8_t> removed(prepared.points.size(), 0);
  std::vector<std::uint8_t> out(prepared.points.size(), 0);
  for (std::size_t s = 0; s < prepared.scans.size(); ++s) {
    const PreparedScan& ps = prepared.scans[s];
    filter.classify(prepared.view(s), std::span<std::uint8_t>(removed).subspan(ps.first, ps.count));
  }
  for (std::size_t i = 0; i < removed.size(); ++i) out[prepared.source_index[i]] = removed[i];
  return out;
}

std::vector<std::uint8_t> run_live(const PreparedDataset& prepared, Filter& filter) {
  filter.reset();
  std::vector<std::uint8_t> removed(prepared.points.size(), 0);
  std::vector<std::uint8_t> out(prepared.points.size(), 0);
  for (std::size_t s = 0; s < prepared.scans.size(); ++s) {
    const PreparedScan& ps = prepared.scans[s];
    const ScanView view = prepared.view(s);
    filter.observe(view);
    filter.classify(view, std::span<std::uint8_t>(removed).subspan(ps.first, ps.count));
  }
  for (std::size_t i = 0; i < removed.size(); ++i) out[prepared.source_index[i]] = removed[i];
  return out;
}

namespace {

std::string format_number(double v, int decimals) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.*f", decimals, v);
  return buf;
}

MethodSpec spec(const std::string& method, const MethodOptions& base, double resolution_m, double half_angle_deg) {
  MethodSpec s{method, method, base};
  s.options.frequency.resolution_m = resolution_m;
  s.options.visibility.resolution_m = resolution_m;
  s.options.combined_resolution_m = resolution_m;
  s.options.freespace.resolution_m = resolution_m;
  s.options.freespace.grid_origin_z_m = -resolution_m / 2.0;  // floor centred in a voxel layer
  s.options.direction.half_angle_rad = deg_to_rad(half_angle_deg);
  s.options.combined_half_angle_rad = deg_to_rad(half_angle_deg);
  if (method == "frequency" || method == "visibility") s.name = method + "@" + format_number(resolution_m, 2) + "m";
  if (method == "freespace") s.name = method + "@" + format_number(resolution_m, 2) + "m";
  if (method == "direction") s.name = method + "@" + format_number(half_angle_deg, 1) + "deg";
  if (method == "combined")
    s.name = method + "@" + format_number(half_angle_deg, 1) + "deg," + format_number(resolution_m, 2) + "m";
  return s;
}

}  // namespace

Result<std::vector<MethodSpec>> parse_methods(const std::string& list, std::optional<double> resolution_m,
                                              std::optional<double> half_angle_deg, const MethodOptions& base) {
  std::vector<std::string> names;
  if (list == "all") {
    names = known_methods();
  } else {
    std::stringstream in(list);
    std::string item;
    while (std::getline(in, item, ',')) {
      if (item.empty()) continue;
      if (std::find(known_methods().begin(), known_methods().end(), item) == known_methods().end() &&
          std::find(extended_methods().begin(), extended_methods().end(), item) == extended_methods().end())
        return Error{"unknown method (known: frequency, visibility, position, direction, combined, freespace, tracked, best, all)"};
      names.push_back(item);
    }
  }
  if (names.empty()) return Error{"no method given"};
  if (resolution_m && !(*resolution_m > 0.0)) return Error{"resolution must be > 0"};
  if (half_angle_deg && !(*half_angle_deg > 0.0 && *half_angle_deg <= 60.0))
    return Error{"half-angle must be in (0, 60] degrees (the onboard fixed-point filter's domain)"};
  std::vector<MethodSpec> out;
  for (const std::string& m : names) {
    // Paper settings (PAPER_NOTES table): frequency/visibility at 0.05 and 0.1 m, position at
    // 0.05 m (robot-based: resolution unused), direction at 5° and 7°, combined at 7° and 0.1 m.
    std::vector<double> resolutions{resolution_m.value_or(0.05)};
    std::vector<double> angles{half_angle_deg.value_or(7.0)};
    if ((m == "frequency" || m == "visibility") && !resolution_m) resolutions = {0.05, 0.1};
    if (m == "direction" && !half_angle_deg) angles = {5.0, 7.0};
    if (m == "combined" && !resolution_m) resolutions = {0.1};
    for (double r : resolutions)
      for (double a : angles) out.push_back(spec(m, base, r, a));
  }
  return out;
}

EvalReport evaluate(const Dataset& dataset, const EvalOptions& options) {
  EvalReport report;
  report.scenario = dataset.scenario;
  report.seed = dataset.seed;
  report.options = options;
  report.points = dataset.points.size();
  report.scans = dataset.scans.size();
  report.robots = dataset.robots.size();
  for (const LabelledPoint& p : dataset.points)
    if (p.is_ghost()) ++report.ghosts;

  {
    std::set<std::pair<std::uint8_t, std::uint32_t>> scans;
    for (const ScanRecord& r : dataset.scans) scans.emplace(r.robot, r.scan);
    for (const LabelledPoint& p : dataset.points)
      if (!scans.count({p.robot, p.scan})) ++report.orphan_points;
  }
  // Every method through the fusion core first: with the registration on, the core places the points
  // (the same for every method: the registration never reads a filter's decision), and the cloud the
  // metrics are computed on is the placed one.
  CoreRunOptions run;
  run.tracker = options.tracker;
  run.noise = options.pose_noise;
  run.registration = options.registration;
  run.registration_options = options.registration_options;
  std::vector<std::vector<std::uint8_t>> removed_by_method;
  RegistrationReport& g = report.registration;
  g.enabled = options.registration;
  g.have_truth = !dataset.truth.empty();
  measure_errors(dataset, g.pose_m_before, g.pose_deg_before, g.point_m_before);
  g.consistency_before = revisit_consistency(dataset);
  for (const MethodSpec& m : options.methods) {
    if (options.progress) options.progress(m.name + (options.registration ? " (fusion core, registration on)" : " (fusion core)"));
    CoreRun r = run_through_core(dataset, m.method, m.options, run);
    if (removed_by_method.empty()) {
      measure_errors(dataset, g.pose_m_after, g.pose_deg_after, g.point_m_after, r.placed, r.scan_poses, r.scan_decided);
      g.robots = std::move(r.robots);
      g.masked_points = r.masked_points;
      if (options.registration) g.consistency_after = revisit_consistency(dataset, r.placed);
      report.placed = std::move(r.placed);
      report.scan_poses = std::move(r.scan_poses);
      report.scan_decided = std::move(r.scan_decided);
    }
    removed_by_method.push_back(std::move(r.removed));
  }
  if (report.placed.empty()) {
    report.placed.reserve(dataset.points.size());
    for (const LabelledPoint& p : dataset.points) report.placed.push_back({p.x, p.y, p.z});
  }
  const std::vector<MapPoint>& cloud = report.placed;

  if (options.progress) options.progress("table 1 (floor plane with and without the ghosts)");
  report.table1 = table1(dataset.points, cloud, options.ransac);
  report.plane_before = report.table1.with_ghosts;
  const bool have_reference = report.table1.without_ghosts.found;
  {
    std::vector<std::uint8_t> ghost(dataset.points.size());
    for (std::size_t i = 0; i < ghost.size(); ++i) ghost[i] = dataset.points[i].is_ghost() ? 1 : 0;
    // The reference: least squares on the ghost-free points within the threshold, refitted until its
    // inlier set settles, so the ghost-free cloud's bias against it is 0 up to rounding.
    report.floor_reference = report.table1.without_ghosts.plane;
    std::vector<std::size_t> inliers;
    for (int iteration = 0; have_reference && iteration < 10; ++iteration) {
      const std::size_t previous = inliers.size();
      inliers.clear();
      for (std::size_t i = 0; i < cloud.size(); ++i)
        if (!ghost[i] && std::abs(report.floor_reference.signed_distance(cloud[i])) <= options.ransac.threshold_m) inliers.push_back(i);
      if (inliers.size() < 3 || (iteration > 0 && inliers.size() == previous)) break;
      report.floor_reference = fit_plane_least_squares(cloud, inliers);
    }
    report.floor_bias_before_m = have_reference ? floor_bias_m(cloud, report.floor_reference, options.ransac.threshold_m) : std::numeric_limits<double>::quiet_NaN();
    report.floor_bias_ghost_free_m = have_reference ? floor_bias_m(cloud, report.floor_reference, options.ransac.threshold_m, ghost) : std::numeric_limits<double>::quiet_NaN();
  }
  for (std::size_t k = 0; k < options.methods.size(); ++k) {
    const MethodSpec& m = options.methods[k];
    std::unique_ptr<Filter> filter = make_filter(m.method, m.options);
    TEAMSCAN_EXPECTS(filter != nullptr);
    MethodResult r;
    r.name = m.name;
    r.method = m.method;
    r.params = filter->params();
    r.removed = std::move(removed_by_method[k]);
    r.removal = removal_metrics(dataset.points, r.removed);
    r.plane_after = fit_plane_ransac(cloud, options.ransac, r.removed);
    r.plane_error_improvement_pct = plane_error_improvement_pct(report.plane_before, r.plane_after);
    r.plane_inlier_improvement_pct = plane_inlier_improvement_pct(report.plane_before, r.plane_after);
    r.floor_bias_after_m = have_reference ? floor_bias_m(cloud, report.floor_reference, options.ransac.threshold_m, r.removed) : std::numeric_limits<double>::quiet_NaN();
    r.floor_bias_improvement_pct = floor_bias_improvement_pct(report.floor_bias_before_m, r.floor_bias_after_m);
    report.methods.push_back(std::move(r));
  }
  return report;
}

// ---- report writers -------------------------------------------------------------------------------
namespace {

const char* class_name(std::size_t c) {
  static const char* const kNames[kPointClasses] = {"none", "floor", "wall", "ceiling", "furniture", "robot"};
  return c < kPointClasses ? kNames[c] : "?";
}

std::string json_number(double v) {
  if (!std::isfinite(v)) return "null";
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.10g", v);
  return buf;
}

std::string json_string(const std::string& s) {
  std::string out = "\"";
  for (char c : s) {
    if (c == '"' || c == '\\') {
      out += '\\';
      out += c;
    } else if (static_cast<unsigned char>(c) < 0x20) {
      char buf[8];
      std::snprintf(buf, sizeof buf, "\\u%04x", c);
      out += buf;
    } else {
      out += c;
    }
  }
  return out + "\"";
}

std::string json_plane(const PlaneFit& f) {
  std::ostringstream o;
  o << "{\"found\": " << (f.found ? "true" : "false") << ", \"a\": " << json_number(f.plane.normal.x())
    << ", \"b\": " << json_number(f.plane.normal.y()) << ", \"c\": " << json_number(f.plane.normal.z())
    << ", \"d\": " << json_number(f.plane.d) << ", \"points\": " << f.points << ", \"inliers\": " << f.inliers
    << ", \"inlier_share\": " << json_number(f.inlier_share)
    << ", \"signed_mean_error_mm\": " << json_number(f.signed_mean_error_m * 1e3)
    << ", \"mean_abs_error_mm\": " << json_number(f.mean_abs_error_m * 1e3)
    << ", \"rms_error_mm\": " << json_number(f.rms_error_m * 1e3) << "}";
  return o.str();
}

std::string md(double v, int decimals = 1) { return std::isfinite(v) ? format_number(v, decimals) : "–"; }

// Scene classes reported as "kept" (issue 5: floor, wall, ceiling, furniture).
constexpr std::size_t kSceneClasses[] = {1, 2, 3, 4};

}  // namespace

std::string report_json(const EvalReport& r, const std::string& command) {
  std::ostringstream o;
  const RansacOptions& rs = r.options.ransac;
  const TrackerOptions& tr = r.options.tracker;
  o << "{\n  \"scenario\": " << json_string(r.scenario) << ",\n  \"seed\": " << r.seed << ",\n";
  o << "  \"counts\": {\"points\": " << r.points << ", \"ghosts\": " << r.ghosts << ", \"others\": " << (r.points - r.ghosts)
    << ", \"scans\": " << r.scans << ", \"robots\": " << r.robots << ", \"orphan_points\": " << r.orphan_points;
  if (!r.methods.empty()) {
    o << ", \"by_class\": {";
    for (std::size_t c = 0; c < kPointClasses; ++c)
      o << (c ? ", " : "") << json_string(class_name(c)) << ": " << r.methods.front().removal.by_class[c].total;
    o << "}";
  }
  o << "},\n";
  o << "  \"ransac\": {\"threshold_m\": " << json_number(rs.threshold_m) << ", \"iterations\": " << rs.iterations
    << ", \"seed\": " << rs.seed << ", \"max_tilt_deg\": " << json_number(rs.max_tilt_deg)
    << ", \"max_height_m\": " << json_number(rs.max_height_m) << ", \"error_reference\": "
    << (rs.error_reference == PlaneErrorReference::sample ? "\"sample\"" : "\"refit\"") << "},\n";
  o << "  \"tracker\": {\"accel_noise_mps2\": " << json_number(tr.accel_noise_mps2)
    << ", \"position_noise_m\": " << json_number(tr.position_noise_m)
    << ", \"velocity_noise_mps\": " << json_number(tr.velocity_noise_mps)
    << ", \"use_velocity\": " << (tr.use_velocity ? "true" : "false") << ", \"lost_after_s\": " << json_number(tr.lost_after_s)
    << ", \"drift_m_per_m\": " << json_number(tr.drift_m_per_m)
    << ", \"drift_heading_rad_per_m\": " << json_number(tr.drift_heading_rad_per_m)
    << ", \"drift_heading_rad_per_rad\": " << json_number(tr.drift_heading_rad_per_rad) << "},\n";
  o << "  \"table1\": {\"with_ghosts\": " << json_plane(r.table1.with_ghosts)
    << ",\n             \"without_ghosts\": " << json_plane(r.table1.without_ghosts)
    << ",\n             \"ghost_share_of_inliers_pct\": " << json_number(r.table1.ghost_share_of_inliers_pct)
    << ", \"plane_error_improvement_pct\": " << json_number(r.table1.error_improvement_pct)
    << ", \"plane_inlier_improvement_pct\": " << json_number(r.table1.inlier_improvement_pct) << "},\n";
  o << "  \"floor_bias\": {\"reference\": {\"a\": " << json_number(r.floor_reference.normal.x())
    << ", \"b\": " << json_number(r.floor_reference.normal.y()) << ", \"c\": " << json_number(r.floor_reference.normal.z())
    << ", \"d\": " << json_number(r.floor_reference.d) << "}, \"all_points_mm\": " << json_number(r.floor_bias_before_m * 1e3)
    << ", \"ghosts_removed_mm\": " << json_number(r.floor_bias_ghost_free_m * 1e3) << ", \"ghosts_removed_improvement_pct\": "
    << json_number(floor_bias_improvement_pct(r.floor_bias_before_m, r.floor_bias_ghost_free_m)) << "},\n";
  o << "  \"methods\": [";
  for (std::size_t i = 0; i < r.methods.size(); ++i) {
    const MethodResult& m = r.methods[i];
    o << (i ? ",\n" : "\n") << "    {\"name\": " << json_string(m.name) << ", \"params\": {";
    for (std::size_t p = 0; p < m.params.size(); ++p)
      o << (p ? ", " : "") << json_string(m.params[p].first) << ": " << json_number(m.params[p].second);
    o << "}, \"ghost_removed_pct\": " << json_number(m.removal.ghost_removed_pct)
      << ", \"other_removed_pct\": " << json_number(m.removal.other_removed_pct)
      << ", \"plane_error_improvement_pct\": " << json_number(m.plane_error_improvement_pct)
      << ", \"plane_inlier_improvement_pct\": " << json_number(m.plane_inlier_improvement_pct)
      << ", \"floor_bias_mm\": " << json_number(m.floor_bias_after_m * 1e3)
      << ", \"floor_bias_improvement_pct\": " << json_number(m.floor_bias_improvement_pct)
      << ", \"SA\": " << json_number(m.removal.sa) << ", \"DA\": " << json_number(m.removal.da)
      << ", \"AA\": " << json_number(m.removal.aa) << ", \"HA\": " << json_number(m.removal.ha) << ", \"kept_by_class\": {";
    bool first = true;
    for (std::size_t c : kSceneClasses) {
      o << (first ? "" : ", ") << json_string(class_name(c)) << ": " << json_number(m.removal.by_class[c].kept_pct());
      first = false;
    }
    o << "}}";
  }
  o << "\n  ],\n";
  {
    const RegistrationReport& g = r.registration;
    auto share_on_earlier = [](const RevisitConsistency& k) {
      return k.points ? static_cast<double>(k.on_earlier_points) / static_cast<double>(k.points) : 0.0;
    };
    auto js = [&](const ErrorStats& e) {
      return "{\"p50\": " + json_number(e.p50) + ", \"p99\": " + json_number(e.p99) + ", \"max\": " + json_number(e.max) +
             ", \"count\": " + std::to_string(e.count) + "}";
    };
    o << "  \"registration\": {\"enabled\": " << (g.enabled ? "true" : "false") << ", \"have_truth\": " << (g.have_truth ? "true" : "false")
      << ", \"consistency_before_median_m\": " << json_number(g.consistency_before.median_m)
      << ", \"consistency_after_median_m\": " << json_number(g.enabled ? g.consistency_after.median_m : g.consistency_before.median_m)
      << ", \"consistency_before_on_earlier_share\": " << json_number(share_on_earlier(g.consistency_before))
      << ", \"consistency_after_on_earlier_share\": " << json_number(share_on_earlier(g.enabled ? g.consistency_after : g.consistency_before));
    if (g.have_truth) {
      o << ", \"pose_m_before\": " << js(g.pose_m_before) << ", \"pose_deg_before\": " << js(g.pose_deg_before)
        << ", \"point_m_before\": " << js(g.point_m_before);
      if (g.enabled)
        o << ", \"pose_m_after\": " << js(g.pose_m_after) << ", \"pose_deg_after\": " << js(g.pose_deg_after)
          << ", \"point_m_after\": " << js(g.point_m_after);
    }
    o << ", \"robots\": [";
    for (std::size_t i = 0; i < g.robots.size(); ++i) {
      const registration::RobotCorrection& c = g.robots[i];
      o << (i ? ", " : "") << "{\"robot\": " << int(c.robot) << ", \"matches\": " << c.matches << ", \"accepted\": " << c.accepted
        << ", \"degenerate\": " << c.degenerate << ", \"standing_still\": " << c.standing_still << ", \"first_lap\": " << c.first_lap
        << ", \"rejected_overlap\": " << c.rejected_overlap << ", \"rejected_fit\": " << c.rejected_fit
        << ", \"rejected_step\": " << c.rejected_step << ", \"too_few_features\": " << c.too_few_features
        << ", \"scale\": " << c.scale << ", \"drift_rad_per_m\": " << c.drift_rad_per_m << ", \"turn\": " << c.turn << "}";
    }
    o << "]},\n";
  }
  o << "  \"plane_fits\": {\"before\": " << json_plane(r.plane_before);
  for (const MethodResult& m : r.methods) o << ",\n                 " << json_string(m.name) << ": " << json_plane(m.plane_after);
  o << "},\n  \"command\": " << json_string(command) << "\n}\n";
  return o.str();
}

std::string report_markdown(const EvalReport& r, const std::string& command) {
  std::ostringstream o;
  const RansacOptions& rs = r.options.ransac;
  o << "## Data set `" << r.scenario << "` (seed " << r.seed << ")\n\n";
  o << r.points << " points, " << r.ghosts << " ghost points (" << md(r.points ? 100.0 * static_cast<double>(r.ghosts) / static_cast<double>(r.points) : 0.0)
    << " %), " << r.scans << " scans, " << r.robots << " robots";
  if (r.orphan_points) o << ", " << r.orphan_points << " points without a scans.csv row";
  o << ".\n\n";
  o << "| method | % ghost | % other | % impr. plane error | % impr. inliers | SA | DA | AA | HA | floor kept | wall kept | ceiling kept | furniture kept | % impr. floor bias |\n";
  o << "| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |\n";
  for (const MethodResult& m : r.methods) {
    o << "| " << m.name << " | " << md(m.removal.ghost_removed_pct) << " | " << md(m.removal.other_removed_pct) << " | "
      << md(m.plane_error_improvement_pct) << " | " << md(m.plane_inlier_improvement_pct) << " | " << md(m.removal.sa)
      << " | " << md(m.removal.da) << " | " << md(m.removal.aa) << " | " << md(m.removal.ha);
    for (std::size_t c : kSceneClasses) o << " | " << md(m.removal.by_class[c].kept_pct());
    o << " | " << md(m.floor_bias_improvement_pct) << " |\n";
  }
  if (r.registration.have_truth) {
    const RegistrationReport& g = r.registration;
    o << "\n**Registration** (pose error per scan and point error per non-ghost point, against the truth; "
      << (g.enabled ? "scan-to-map registration, docs/registration.md" : "registration off: odometry alone") << "):\n\n";
    o << "| poses | translation p50 / p99 / max (cm) | rotation p50 / p99 / max (°) | point error p50 / p99 / max (cm) |\n";
    o << "| --- | ---: | ---: | ---: |\n";
    auto stats = [&](const ErrorStats& e, double scale, int decimals) {
      return md(e.p50 * scale, decimals) + " / " + md(e.p99 * scale, decimals) + " / " + md(e.max * scale, decimals);
    };
    o << "| odometry | " << stats(g.pose_m_before, 100, 1) << " | " << stats(g.pose_deg_before, 1, 2) << " | "
      << stats(g.point_m_before, 100, 1) << " |\n";
    if (g.enabled)
      o << "| registered | " << stats(g.pose_m_after, 100, 1) << " | " << stats(g.pose_deg_after, 1, 2) << " | "
        << stats(g.point_m_after, 100, 1) << " |\n";
  }
  if (r.registration.consistency_before.points > 0) {
    const RegistrationReport& g = r.registration;
    auto c = [&](const RevisitConsistency& k) {
      const double n = k.points ? static_cast<double>(k.points) : 1.0;
      return md(k.median_m * 100, 1) + " / " + md(k.p90_m * 100, 1) + " cm (" + md(100.0 * static_cast<double>(k.revisit_points) / n) +
             " % of the points; within " + md(k.on_earlier_m * 100, 0) + " cm of the earlier pass: " +
             md(100.0 * static_cast<double>(k.on_earlier_points) / n) + " % of the points)";
    };
    o << "\nRevisit consistency (median / p90 distance of a revisit's points to the earlier pass, ≥ 30 s before, within 0.5 m; "
         "docs/registration.md): odometry "
      << c(g.consistency_before);
    if (g.enabled) o << ", registered " << c(g.consistency_after);
    o << ".\n";
  }
  if (r.registration.enabled) {
    // The drift rates at the end (the odometry prior they started from: docs/registration.md "Odometry prior and calibration").
    o << "\n| robot | matches | accepted | degenerate | standing still | first lap | too few features | rejected overlap / fit / step "
         "| rates at the end: scale % / drift °/m / turn % |\n";
    o << "| ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |\n";
    for (const registration::RobotCorrection& c : r.registration.robots)
      o << "| " << int(c.robot) << " | " << c.matches << " | " << c.accepted << " | " << c.degenerate << " | " << c.standing_still
        << " | " << c.first_lap << " | " << c.too_few_features << " | " << c.rejected_overlap << " / " << c.rejected_fit << " / " << c.rejected_step
        << " | " << md(100.0 * c.scale, 3) << " / " << md(rad_to_deg(c.drift_rad_per_m), 4) << " / " << md(100.0 * c.turn, 3) << " |\n";
    o << "\nPoints kept out of the match (onboard-flagged, inside a teammate's tracked body): " << r.registration.masked_points << ".\n";
  }
  const Table1& t = r.table1;
  o << "\n**Table 1** (floor plane by RANSAC, ghosts removed by label):\n\n";
  o << "| cloud | signed error (mm) | mean abs (mm) | RMS (mm) | inliers | inlier share % |\n";
  o << "| --- | ---: | ---: | ---: | ---: | ---: |\n";
  auto row = [&](const char* name, const PlaneFit& f) {
    o << "| " << name << " | " << md(f.signed_mean_error_m * 1e3, 3) << " | " << md(f.mean_abs_error_m * 1e3, 3) << " | "
      << md(f.rms_error_m * 1e3, 3) << " | " << f.inliers << " / " << f.points << " | " << md(100.0 * f.inlier_share) << " |\n";
  };
  row("all points", t.with_ghosts);
  row("ghosts removed", t.without_ghosts);
  o << "\nGhosts among the inliers with all points: " << md(t.ghost_share_of_inliers_pct) << " %; improvement in plane error "
    << md(t.error_improvement_pct) << " %, in inliers " << md(t.inlier_improvement_pct) << " %.\n\n";
  o << "Floor bias (deterministic; signed mean distance of the points within " << json_number(rs.threshold_m)
    << " m of the fixed least-squares floor of the ghost-free cloud): all points " << md(r.floor_bias_before_m * 1e3, 4)
    << " mm, ghosts removed " << md(r.floor_bias_ghost_free_m * 1e3, 4) << " mm (improvement "
    << md(floor_bias_improvement_pct(r.floor_bias_before_m, r.floor_bias_ghost_free_m)) << " %).\n\n";
  o << "Parameters:\n\n";
  for (const MethodResult& m : r.methods) {
    o << "- " << m.name << ":";
    for (const auto& [name, value] : m.params) o << " " << name << "=" << json_number(value);
    o << "\n";
  }
  o << "- RANSAC: threshold " << json_number(rs.threshold_m) << " m, " << rs.iterations << " iterations, seed " << rs.seed
    << ", normal within " << json_number(rs.max_tilt_deg) << "° of +z, plane height ≤ " << json_number(rs.max_height_m)
    << " m, signed error against the " << (rs.error_reference == PlaneErrorReference::sample ? "best sample" : "refit")
    << " plane\n";
  const TrackerOptions& tr = r.options.tracker;
  o << "- tracker: constant velocity, σ_a " << json_number(tr.accel_noise_mps2) << " m/s², σ_pos "
    << json_number(tr.position_noise_m) << " m, σ_vel " << json_number(tr.velocity_noise_mps) << " m/s, velocity "
    << (tr.use_velocity ? "measured" : "not measured") << ", drift " << json_number(tr.drift_m_per_m) << " m/m, "
    << json_number(tr.drift_heading_rad_per_m) << " rad/m, " << json_number(tr.drift_heading_rad_per_rad) << " rad/rad\n\n";
  o << "Reproduce: `" << command << "`\n";
  return o.str();
}

}  // namespace teamscan::mapping
