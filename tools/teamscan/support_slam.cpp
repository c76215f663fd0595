// `teamscan eval --trajectory-out / --relations` (support_slam.hpp).
#include "tools/teamscan/support_slam.hpp"

#include <chrono>
#include <cstdio>
#include <map>

#include <nlohmann/json.hpp>

#include "common/dataset/log_text.hpp"
#include "groundstation/posegraph/slam.hpp"
#include "groundstation/trajectory/relations.hpp"
#include "groundstation/trajectory/tum.hpp"

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

}  // namespace

std::vector<Pose2> pose_graph_poses(const Dataset& dataset) {
  const auto start = std::chrono::steady_clock::now();
  std::map<std::pair<std::uint8_t, std::uint32_t>, std::size_t> row;
  for (std::size_t i = 0; i < dataset.scans.size(); ++i) row.emplace(std::make_pair(dataset.scans[i].robot, dataset.scans[i].scan), i);
  // The returns back in each scan's robot frame (the data set holds them in the odometry's map frame).
  std::vector<std::vector<Vec2>> points(dataset.scans.size());
  for (const LabelledPoint& p : dataset.points) {
    const auto it = row.find({p.robot, p.scan});
    if (it == row.end()) continue;
    points[it->second].push_back(dataset.scans[it->second].pose.inverse().apply({p.x, p.y}));
  }
  posegraph::PlanarSlam slam;
  std::vector<std::size_t> node(dataset.scans.size());
  for (std::size_t i = 0; i < dataset.scans.size(); ++i) node[i] = slam.add_scan(dataset.scans[i].robot, dataset.scans[i].pose, points[i]);
  slam.finish();
  std::vector<Pose2> poses(dataset.scans.size());
  for (std::size_t i = 0; i < dataset.scans.size(); ++i) poses[i] = slam.pose(node[i]);
  const posegraph::SlamStats st = slam.stats();
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  std::fprintf(stderr, "teamscan eval: pose graph: %zu nodes, %zu submaps, %zu loop-closure searches, %zu closures, %zu optimisations, %.1f s\n",
               st.nodes, st.submaps, st.searches, st.closures, st.optimizations, seconds);
  return poses;
}

void add_slam_eval_options(CLI::App& app, SlamEvalArgs& args) {
  app.add_flag("--pose-graph", args.pose_graph,
               "The trajectory of the 2-D pose graph (submaps, loop closure, Ceres; docs/slam.md) for --trajectory-out and "
               "--relations (offline; the filters still run on the fusion core's poses)");
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
