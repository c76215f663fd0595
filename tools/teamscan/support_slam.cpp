// `teamscan eval --trajectory-out / --relations` (support_slam.hpp).
#include "tools/teamscan/support_slam.hpp"

#include <chrono>
#include <cstdio>
#include <map>

#include <nlohmann/json.hpp>

#include "common/dataset/log_text.hpp"
#include "groundstation/fusion/planar_returns.hpp"
#include "groundstation/mapping/dataset_registration.hpp"
#include "groundstation/posegraph/slam.hpp"
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
          {"translation_mean_m", e.translation_mean_m},
          {"translation_std_m", e.translation_std_m},
          {"translation_squared_mean_m2", e.translation_squared_mean_m2},
          {"translation_max_m", e.translation_max_m},
          {"rotation_mean_deg", e.rotation_mean_deg},
          {"rotation_std_deg", e.rotation_std_deg},
          {"rotation_squared_mean_deg2", e.rotation_squared_mean_deg2},
          {"rotation_max_deg", e.rotation_max_deg}};
}

std::string stats_cell(const mapping::ErrorStats& e, double scale) {
  char buf[128];
  std::snprintf(buf, sizeof buf, scale > 1 ? "%.1f / %.1f / %.1f" : "%.2f / %.2f / %.2f", e.p50 * scale, e.p99 * scale, e.max * scale);
  return buf;
}

}  // namespace

std::vector<Pose2> pose_graph_poses(const Dataset& dataset, const SlamEvalArgs& args) {
  const auto start = std::chrono::steady_clock::now();
  // Planar returns: a level laser's as they are, a tilted laser's in the wall band; the points the
  // registration leaves out left out here too (groundstation/fusion/planar_returns.hpp).
  fusion::PlanarReturnOptions options;
  if (args.min_height_m) options.min_height_m = *args.min_height_m;
  if (args.max_height_m) options.max_height_m = *args.max_height_m;
  if (args.node_span_s) options.tilted_node_s = *args.node_span_s;
  const fusion::PlanarReturns planar = fusion::planar_returns(dataset, options);
  // Tilted lasers' nodes: local SLAM held closer to the odometry (posegraph::tilted_laser_options).
  bool tilted = false;
  for (const DatasetRobot& r : dataset.robots) tilted = tilted || !fusion::level_laser(r);
  const posegraph::SlamOptions so = tilted ? posegraph::tilted_laser_options() : posegraph::SlamOptions{};
  posegraph::PlanarSlam slam(so);
  std::vector<Pose2> node_poses(planar.nodes.size());
  std::vector<std::size_t> node(planar.nodes.size());
  for (std::size_t k = 0; k < planar.nodes.size(); ++k)
    node[k] = slam.add_scan(planar.nodes[k].robot, dataset.scans[planar.nodes[k].row].pose, planar.nodes[k].returns);
  slam.finish();
  for (std::size_t k = 0; k < planar.nodes.size(); ++k) node_poses[k] = slam.pose(node[k]);
  std::vector<Pose2> poses = fusion::scan_poses(dataset, planar, node_poses);
  const posegraph::SlamStats st = slam.stats();
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  std::fprintf(stderr,
               "teamscan eval: pose graph: %llu returns taken (%llu masked, %llu out of the height band), %zu nodes, %zu submaps, "
               "%zu loop-closure searches, %zu closures, %zu optimisations, %.1f s\n",
               static_cast<unsigned long long>(planar.kept), static_cast<unsigned long long>(planar.masked),
               static_cast<unsigned long long>(planar.out_of_band), st.nodes, st.submaps, st.searches, st.closures, st.optimizations,
               seconds);
  return poses;
}

void add_slam_eval_options(CLI::App& app, SlamEvalArgs& args) {
  app.add_flag("--pose-graph", args.pose_graph,
               "The trajectory of the 2-D pose graph (submaps, loop closure, Ceres; docs/slam.md) for --trajectory-out and "
               "--relations (offline; the filters still run on the fusion core's poses)");
  const fusion::PlanarReturnOptions d;
  app.add_option("--pose-graph-min-height", args.min_height_m,
                 "--pose-graph: a tilted laser's returns taken from this height above the floor, m (default " +
                     std::to_string(d.min_height_m).substr(0, 4) + "; below: the floor)");
  app.add_option("--pose-graph-max-height", args.max_height_m,
                 "--pose-graph: … up to this height, m (default " + std::to_string(d.max_height_m).substr(0, 4) + "; above: ceilings)");
  app.add_option("--pose-graph-node-span", args.node_span_s,
                 "--pose-graph: a tilted laser's scans gathered into one node of the graph over this span, s (default " +
                     std::to_string(d.tilted_node_s).substr(0, 4) + ")");
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
  out.relations = std::move(j);
  return out;
}

}  // namespace teamscan::tool
