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

#include "common/error_message.hpp"
#include "common/units.hpp"
#include "groundstation/fusion/core.hpp"
#include "groundstation/fusion/graph_map.hpp"
#include "groundstation/fusion/planar_returns.hpp"
#include "groundstation/fusion/time_line.hpp"

namespace teamscan::fusion {

using mapping::Filter;
using mapping::MapPoint;
using mapping::MethodOptions;
using mapping::RegistrationReport;
using mapping::ScanView;
using mapping::TeamTracker;
using mapping::TrackerOptions;

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

Result<std::vector<std::uint8_t>> decide_through_core(const Dataset& dataset, const std::string& method, const MethodOptions& options,
                                                      const TrackerOptions& tracker, const PoseNoise& noise) {
  CoreRunOptions run;
  run.tracker = tracker;
  run.noise = noise;
  Result<CoreRun> r = run_through_core(dataset, method, options, run);
  if (!r) return r.error();
  return std::move(r.value().removed);
}

bool level_lasers(const Dataset& dataset) {
  bool level = !dataset.robots.empty();
  for (const DatasetRobot& r : dataset.robots) level = level && level_laser(r);
  return level;
}

Result<CoreRun> run_through_core(const Dataset& dataset, const std::string& method, const MethodOptions& options,
                                 const CoreRunOptions& run) {
  const PoseNoise& noise = run.noise;
  fusion::CoreOptions co;
  co.method = method;
  co.methods = options;
  co.tracker = run.tracker;
  co.max_points_per_voxel = 0;  // the decisions are kept here, per point
  co.registration = run.registration;
  co.registration_options = run.registration_options;
  if (run.graph != nullptr || !run.decide_with.empty()) co = with_graph_order(co);
  auto created = fusion::FusionCore::create(co);
  if (!created) return with_context(method, created.error());
  fusion::FusionCore& core = *created.value();
  if (!run.decide_with.empty()) {
    if (run.registration) return Error{"the pose graph's poses and the registration cannot both place the scans"};
    if (Status st = decide_with(core.poses(), dataset, run.decide_with); !st.ok()) return st.error();
  }

  // The one time order (fusion/time_line.hpp), the station's catch-up's too.
  const fusion::TimeLine time_line(dataset);
  const auto& by_scan = time_line.points_by_scan();

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
    // The back end: each scan's returns relative to the pose its points were placed with (the row's).
    if (run.graph != nullptr) {
      const auto row = row_of.find({f.view->robot, f.view->scan});
      run.graph->add(f, row != row_of.end() ? &dataset.scans[row->second].pose : nullptr);
    }
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
  time_line.feed(
      [&](fusion::PoseInput& p) {
        if (noise.active()) {
          const Pose2 err = pose_error.at(p.robot, p.stamp_ns);
          p.odom = {p.odom.x_m + err.x_m, p.odom.y_m + err.y_m, p.odom.theta_rad + err.theta_rad};
        }
        core.add_pose(p);
      },
      [&](fusion::ScanInput& in) {
        if (noise.active()) {
          const Pose2 err = pose_error.at(in.robot, in.stamp_ns);
          in.origin_m = {in.origin_m.x + err.x_m, in.origin_m.y + err.y_m, in.origin_m.z};
        }
        (void)core.add_scan(in);
      },
      run.progress);
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
    names = mapping::known_methods();
  } else {
    std::stringstream in(list);
    std::string item;
    while (std::getline(in, item, ',')) {
      if (item.empty()) continue;
      if (std::find(mapping::known_methods().begin(), mapping::known_methods().end(), item) == mapping::known_methods().end() &&
          std::find(mapping::extended_methods().begin(), mapping::extended_methods().end(), item) == mapping::extended_methods().end())
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

Result<EvalReport> evaluate(const Dataset& dataset, const EvalOptions& options) {
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
  mapping::measure_errors(dataset, g.pose_m_before, g.pose_deg_before, g.point_m_before);
  g.consistency_before = mapping::revisit_consistency(dataset);
  // The share of the whole evaluation: each method one part, table 1 and the metrics one more.
  // (With the pose graph, its first run one more.)
  const double graph_parts = options.pose_graph ? 1.0 : 0.0;
  const double parts = static_cast<double>(options.methods.size() + 1) + graph_parts;
  // The back end: fed a first run of the first method's core (registered, or odometry alone); its
  // poses then decide every method's run, so the cloud and the decisions follow the graph.
  std::unique_ptr<GraphBackend> graph;
  if (options.pose_graph) {
    graph = std::make_unique<GraphBackend>(*options.pose_graph);
    CoreRunOptions first = run;
    first.graph = graph.get();
    const MethodSpec& m = options.methods.front();
    const std::string stage = m.name + (options.registration ? " (fusion core, registration on, feeding the pose graph)" : " (fusion core, feeding the pose graph)");
    if (options.progress) {
      options.progress(stage, 0.0);
      first.progress = [&](double f) { options.progress(stage, f / parts); };
    }
    Result<CoreRun> ran = run_through_core(dataset, m.method, m.options, first);
    if (!ran) return ran.error();
    g.robots = std::move(ran.value().robots);
    g.masked_points = ran.value().masked_points;
    graph->finish();
    if (options.progress) options.progress("pose graph (the last search and optimisation)", 1.0 / parts);
    std::map<std::pair<std::uint8_t, std::uint32_t>, std::size_t> row_of;
    for (std::size_t i = 0; i < dataset.scans.size(); ++i) row_of.emplace(std::make_pair(dataset.scans[i].robot, dataset.scans[i].scan), i);
    report.graph_poses.resize(dataset.scans.size());
    for (std::size_t i = 0; i < dataset.scans.size(); ++i)
      report.graph_poses[i] = ran.value().scan_decided[i] ? ran.value().scan_poses[i] : dataset.scans[i].pose;
    for (const GraphScanPose& p : graph->poses())
      if (const auto it = row_of.find({p.robot, p.scan}); it != row_of.end()) report.graph_poses[it->second] = p.graph;
    report.graph_stats = graph->graph_stats();
    report.graph_counters = graph->counters();
    report.graph_seconds = graph->seconds();
    run.registration = false;
    run.decide_with = graph_poses_by_row(dataset, graph->poses());
    g.by_graph = true;
  }
  for (std::size_t mi = 0; mi < options.methods.size(); ++mi) {
    const MethodSpec& m = options.methods[mi];
    const std::string stage = m.name + (graph                  ? " (fusion core, the pose graph's poses)"
                                        : options.registration ? " (fusion core, registration on)"
                                                               : " (fusion core)");
    if (options.progress) {
      options.progress(stage, (graph_parts + static_cast<double>(mi)) / parts);
      run.progress = [&](double f) { options.progress(stage, (graph_parts + static_cast<double>(mi) + f) / parts); };
    }
    Result<CoreRun> ran = run_through_core(dataset, m.method, m.options, run);
    if (!ran) return ran.error();
    CoreRun& r = ran.value();
    if (removed_by_method.empty()) {
      mapping::measure_errors(dataset, g.pose_m_after, g.pose_deg_after, g.point_m_after, r.placed, r.scan_poses, r.scan_decided);
      if (!graph) {
        g.robots = std::move(r.robots);
        g.masked_points = r.masked_points;
      }
      if (options.registration || graph) g.consistency_after = mapping::revisit_consistency(dataset, r.placed);
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

  if (options.progress) options.progress("table 1 (floor plane with and without the ghosts)", (parts - 1.0) / parts);
  report.table1 = mapping::table1(dataset.points, cloud, options.ransac);
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
      report.floor_reference = mapping::fit_plane_least_squares(cloud, inliers);
    }
    report.floor_bias_before_m = have_reference ? mapping::floor_bias_m(cloud, report.floor_reference, options.ransac.threshold_m) : std::numeric_limits<double>::quiet_NaN();
    report.floor_bias_ghost_free_m = have_reference ? mapping::floor_bias_m(cloud, report.floor_reference, options.ransac.threshold_m, ghost) : std::numeric_limits<double>::quiet_NaN();
  }
  for (std::size_t k = 0; k < options.methods.size(); ++k) {
    const MethodSpec& m = options.methods[k];
    if (options.progress)
      options.progress(m.name + " (metrics, floor plane)",
                       (parts - 1.0 + static_cast<double>(k) / static_cast<double>(options.methods.size())) / parts);
    std::unique_ptr<Filter> filter = mapping::make_filter(m.method, m.options);
    TEAMSCAN_EXPECTS(filter != nullptr);
    MethodResult r;
    r.name = m.name;
    r.method = m.method;
    r.params = filter->params();
    r.removed = std::move(removed_by_method[k]);
    r.removal = mapping::removal_metrics(dataset.points, r.removed);
    r.plane_after = mapping::fit_plane_ransac(cloud, options.ransac, r.removed);
    r.plane_error_improvement_pct = mapping::plane_error_improvement_pct(report.plane_before, r.plane_after);
    r.plane_inlier_improvement_pct = mapping::plane_inlier_improvement_pct(report.plane_before, r.plane_after);
    r.floor_bias_after_m = have_reference ? mapping::floor_bias_m(cloud, report.floor_reference, options.ransac.threshold_m, r.removed) : std::numeric_limits<double>::quiet_NaN();
    r.floor_bias_improvement_pct = mapping::floor_bias_improvement_pct(report.floor_bias_before_m, r.floor_bias_after_m);
    report.methods.push_back(std::move(r));
  }
  return report;
}

}  // namespace teamscan::fusion
