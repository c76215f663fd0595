// `teamscan eval --trajectory-out / --relations` (support_slam.hpp).
#include "tools/teamscan/support_slam.hpp"

#include <cstdio>
#include <map>

#include <nlohmann/json.hpp>

#include "common/dataset/log_text.hpp"
#include "groundstation/fusion/planar_returns.hpp"
#include "groundstation/mapping/dataset_registration.hpp"
#include "groundstation/trajectory/relations.hpp"
#include "groundstation/trajectory/tum.hpp"
#include "tools/demo/eval_report.hpp"

namespace teamscan::tool {
namespace {

using trajectory::RelationErrors;
using trajectory::StampedPose;

std::vector<StampedPose> stamped(const Dataset& d, const std::vector<Pose2>& poses, const std::vector<std::uint8_t>& decided) {
  std::vector<StampedPose> out;
  out.reserve(d.scans.size());
  for (std::size_t i = 0; i < d.scans.size() && i < poses.size(); ++i)
    if (decided.empty() || (i < decided.size() && decided[i] != 0)) out.push_back({trajectory::scan_stamp_us(d.scans[i]), poses[i]});
  return out;
}

std::string row(const std::string& name, const RelationErrors& e) {
  char buf[256];
  std::snprintf(buf, sizeof buf, "| %s | %zu of %zu | %.4f ± %.4f | %.6f | %.3f ± %.3f | %.3f |\n", name.c_str(), e.used, e.relations,
                e.translation_mean_m, e.translation_std_m, e.translation_squared_mean_m2, e.rotation_mean_deg, e.rotation_std_deg,
                e.rotation_squared_mean_deg2);
  return buf;
}

nlohmann::ordered_json to_json(const RelationErrors& e) {
  return {{"relations", e.relations},
          {"used", e.used},
          {"rounded", e.rounded},
          {"translation_mean_m", e.translation_mean_m},
          {"translation_std_m", e.translation_std_m},
          {"translation_squared_mean_m2", e.translation_squared_mean_m2},
          {"translation_max_m", e.translation_max_m},
          {"rotation_mean_deg", e.rotation_mean_deg},
          {"rotation_std_deg", e.rotation_std_deg},
          {"rotation_squared_mean_deg2", e.rotation_squared_mean_deg2},
          {"rotation_max_deg", e.rotation_max_deg}};
}

// The share of a level laser's scans below local SLAM's search score above which eval warns of open
// spaces.
constexpr double kBelowShareWarning = 0.1;

// A default in a flag's help, as printf's %g writes it.
std::string shown(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%g", v);
  return buf;
}

std::string stats_cell(const mapping::ErrorStats& e, double scale) {
  char buf[128];
  std::snprintf(buf, sizeof buf, scale > 1 ? "%.1f / %.1f / %.1f" : "%.2f / %.2f / %.2f", e.p50 * scale, e.p99 * scale, e.max * scale);
  return buf;
}

}  // namespace

std::optional<fusion::GraphBackendOptions> pose_graph_options(const SlamEvalArgs& args) {
  if (!args.pose_graph) return std::nullopt;
  fusion::GraphBackendOptions options;
  if (args.min_height_m) options.returns.min_height_m = *args.min_height_m;
  if (args.max_height_m) options.returns.max_height_m = *args.max_height_m;
  if (args.node_span_s) options.returns.tilted_node_s = *args.node_span_s;
  posegraph::SlamOptions& level = options.level;
  if (args.local_search_score) level.local_search_score = *args.local_search_score;
  if (args.local_rotation_weight) level.local.rotation_weight = *args.local_rotation_weight;
  if (args.closure_window_m) level.closure_window.linear_m = *args.closure_window_m;
  if (args.closure_max_distance_m) level.closure_max_distance_m = *args.closure_max_distance_m;
  return options;
}

void print_pose_graph_summary(const fusion::EvalReport& report) {
  const fusion::GraphBackendCounters& c = report.graph_counters;
  const posegraph::SlamStats& st = report.graph_stats;
  std::fprintf(stderr,
               "teamscan eval: pose graph: %llu scans (%llu of tilted lasers), %llu returns taken (%llu flagged by the robots, %llu on "
               "teammates, %llu out of the height band), %zu nodes (%zu standing still, not searched; %zu placed by local SLAM's search of %zu, %zu below its score not searched, %zu from the robot's last motion rather than the odometry's), %zu submaps (%zu retired), %zu loop-closure searches, %zu closures, %zu optimisations, %.0f MB of "
               "submaps and kept returns at the end, %.1f s from the first release to the last optimisation\n",
               static_cast<unsigned long long>(c.scans), static_cast<unsigned long long>(c.tilted_scans),
               static_cast<unsigned long long>(c.returns.kept), static_cast<unsigned long long>(c.returns.flagged),
               static_cast<unsigned long long>(c.returns.teammates),
               static_cast<unsigned long long>(c.returns.out_of_band), st.nodes, st.still, st.local_found, st.local_searches, st.local_declined, st.coasted, st.submaps, st.retired, st.searches, st.closures,
               st.optimizations, static_cast<double>(st.memory_bytes) / 1e6, report.graph_seconds);
  // Local SLAM's search is a rescue from the odometry's rare misses (a wheel slip, a stall): when more
  // than a tenth of the scans score below its score they match their submaps poorly everywhere (open
  // spaces, few returns), where the graph may be worse than the odometry (the search stops at a fifth:
  // SlamOptions::local_search_max_share).
  const std::size_t below = st.local_searches + st.local_declined;
  if (st.nodes > 0 && static_cast<double>(below) > kBelowShareWarning * static_cast<double>(st.nodes))
    std::fprintf(stderr,
                 "teamscan eval: pose graph: warning: %zu of its %zu scans scored below local SLAM's search score (%zu searched, %zu "
                 "not): they match their submaps poorly (open spaces, few returns?), and the graph may be worse than the odometry "
                 "here (docs/slam.md \"A held-out log in open spaces\")\n",
                 below, st.nodes, st.local_searches, st.local_declined);
  for (const posegraph::SlamStats::Calibration& k : st.calibrations)
    std::fprintf(stderr, "teamscan eval: pose graph: robot %u's odometry calibrated: distance × %.4f, turn × %.4f, heading drift %+.3f°/m\n",
                 static_cast<unsigned>(k.robot), k.odometry.distance_scale, k.odometry.turn_scale, k.odometry.heading_drift_rad_per_m * 180.0 / kPi);
}

void resolve_pose_graph(SlamEvalArgs& args, bool odometry_alone) {
  args.pose_graph = args.pose_graph_flag || (!args.no_pose_graph_flag && !odometry_alone);
}

void add_slam_eval_options(CLI::App& app, SlamEvalArgs& args) {
  auto* on = app.add_flag("--pose-graph", args.pose_graph_flag,
                          "The 2-D pose graph (submaps, loop closure, Ceres; docs/slam.md), the default; with --no-registration "
                          "the graph over odometry alone. The fusion core's back end on the robots' odometry (the same graph "
                          "with or without --registration); every method is decided on the graph's poses, so the cloud, the "
                          "decisions, the figures, --trajectory-out and --relations follow the graph");
  auto* off = app.add_flag("--no-pose-graph", args.no_pose_graph_flag,
                           "No pose graph: the cloud on odometry, or with --registration on the registration's corrections");
  on->excludes(off);
  const fusion::PlanarReturnOptions d;
  app.add_option("--pose-graph-min-height", args.min_height_m,
                 "--pose-graph: a tilted laser's returns taken from this height above the floor, m (default " +
                     std::to_string(d.min_height_m).substr(0, 4) + "; below: the floor)");
  app.add_option("--pose-graph-max-height", args.max_height_m,
                 "--pose-graph: … up to this height, m (default " + std::to_string(d.max_height_m).substr(0, 4) + "; above: ceilings)");
  app.add_option("--pose-graph-node-span", args.node_span_s,
                 "--pose-graph: a tilted laser's scans gathered into one node of the graph over this span, s (default " +
                     std::to_string(d.tilted_node_s).substr(0, 4) + ")");
  const posegraph::SlamOptions level;
  app.add_option("--pose-graph-local-search-score", args.local_search_score,
                 "--pose-graph, a level laser: a scan scoring below this on its submap after the refinement is searched for "
                 "around the odometry's prediction (default " + shown(level.local_search_score) + "; 0: never searched)")
      ->check(CLI::Range(0.0, 1.0));
  app.add_option("--pose-graph-local-rotation-weight", args.local_rotation_weight,
                 "--pose-graph, a level laser: local SLAM's pull towards the odometry's heading, per radian (default " +
                     shown(level.local.rotation_weight) + ")")
      ->check(CLI::Range(0.0, 1e6));
  app.add_option("--pose-graph-closure-window", args.closure_window_m,
                 "--pose-graph, a level laser: a loop closure is searched for within ± this of the estimate, m (default " +
                     shown(level.closure_window.linear_m) + ")")
      ->check(CLI::Range(0.1, 50.0));
  app.add_option("--pose-graph-closure-max-distance", args.closure_max_distance_m,
                 "--pose-graph, a level laser: a node is searched against finished submaps whose origin is within this, m (default " +
                     shown(level.closure_max_distance_m) + ")")
      ->check(CLI::Range(0.1, 200.0));
  app.add_option("--trajectory-out", args.trajectory_dir,
                 "Write robot<N>.tum per robot into DIR (TUM 't x y z qx qy qz qw', one line per scan in processing order, "
                 "t = the scan's own stamp): the corrected poses, or odometry with --no-registration (docs/slam.md)");
  app.add_option("--relations", args.relations_path,
                 "Relations file (Kümmerle et al. 2009: 't1 t2 x y z roll pitch yaw', scans named by exact stamp): report "
                 "the trajectory's translation and rotation errors beside odometry alone (docs/slam.md)")
      ->check(CLI::ExistingFile);
}

SlamEvalOutput slam_eval_outputs(const SlamEvalArgs& args, const Dataset& dataset, const std::vector<Pose2>& corrected,
                                 const std::vector<std::uint8_t>& decided, const std::string& method) {
  SlamEvalOutput out;
  const bool odometry_only = method == "odometry";
  // The graph's poses against the truth (a simulated data set), beside odometry alone: the registration's
  // figures (per scan, translation and rotation), measured the same way.
  if (args.pose_graph && !dataset.truth.empty() && corrected.size() == dataset.scans.size()) {
    mapping::ErrorStats odo_m, odo_deg, graph_m, graph_deg, unused_points;
    mapping::measure_errors(dataset, odo_m, odo_deg, unused_points);
    mapping::measure_errors(dataset, graph_m, graph_deg, unused_points, {}, corrected);
    out.pose_markdown = "**Pose graph** (pose error per scan against the truth; docs/slam.md):\n\n"
                        "| poses | translation p50 / p99 / max (cm) | rotation p50 / p99 / max (°) |\n"
                        "| --- | ---: | ---: |\n"
                        "| odometry | " + stats_cell(odo_m, 100) + " | " + stats_cell(odo_deg, 1) + " |\n"
                        "| pose graph | " + stats_cell(graph_m, 100) + " | " + stats_cell(graph_deg, 1) + " |\n";
    out.pose_errors = {{"pose_m_odometry", demo::stats_json(odo_m)},
                       {"pose_deg_odometry", demo::stats_json(odo_deg)},
                       {"pose_m_graph", demo::stats_json(graph_m)},
                       {"pose_deg_graph", demo::stats_json(graph_deg)}};
  }
  std::vector<Pose2> odometry;
  odometry.reserve(dataset.scans.size());
  for (const ScanRecord& s : dataset.scans) odometry.push_back(s.pose);
  const std::vector<Pose2>& shown = odometry_only ? odometry : corrected;
  if (!args.trajectory_dir.empty()) {
    const Status s = trajectory::write_tum_per_robot(args.trajectory_dir, dataset, shown, odometry_only ? std::vector<std::uint8_t>{} : decided);
    if (!s) {
      std::fprintf(stderr, "teamscan eval: --trajectory-out %s: %s\n", args.trajectory_dir.c_str(), s.error().what);
      out.ok = false;
    } else {
      std::fprintf(stderr, "teamscan eval: wrote %s trajectories (robot<N>.tum) into %s\n", method.c_str(), args.trajectory_dir.c_str());
    }
  }
  if (args.relations_path.empty()) return out;
  const Result<std::string> text = read_log_text(args.relations_path);
  if (!text) {
    std::fprintf(stderr, "teamscan eval: --relations %s: %s\n", args.relations_path.c_str(), text.error().what);
    out.ok = false;
    return out;
  }
  const trajectory::RelationsFile file = trajectory::parse_relations(text.value());
  if (file.malformed > 0)
    std::fprintf(stderr, "teamscan eval: --relations %s: %llu malformed lines skipped (first: %s)\n", args.relations_path.c_str(),
                 static_cast<unsigned long long>(file.malformed), file.first_error.c_str());
  const RelationErrors odo = trajectory::relation_errors(file.relations, stamped(dataset, odometry, {}));
  out.markdown = "Relations (Kümmerle et al. 2009; " + args.relations_path +
                 "): error of each relation's motion, translation (m) and absolute rotation (°)\n\n"
                 "| trajectory | relations used | translation m | squared m² | rotation ° | squared °² |\n"
                 "| --- | ---: | ---: | ---: | ---: | ---: |\n" +
                 row("odometry", odo);
  nlohmann::ordered_json j = {{"file", args.relations_path}, {"odometry", to_json(odo)}};
  if (!odometry_only) {
    const RelationErrors cor = trajectory::relation_errors(file.relations, stamped(dataset, corrected, decided));
    out.markdown += row(method, cor);
    j["corrected"] = to_json(cor);
    j["corrected"]["method"] = method;
  }
  if (odo.used < odo.relations)
    std::fprintf(stderr, "teamscan eval: --relations: %zu of %zu relations name a stamp no scan has\n", odo.relations - odo.used, odo.relations);
  if (odo.rounded > 0)
    std::fprintf(stderr, "teamscan eval: --relations: %zu relations name a scan by its stamp rounded (fewer decimals than the log's)\n",
                 odo.rounded);
  out.relations = std::move(j);
  return out;
}

}  // namespace teamscan::tool
