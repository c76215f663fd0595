// The station's fused_all.pcd against `teamscan eval` of its session (model_check.hpp).
#include "groundstation/station/model_check.hpp"

#include <unordered_map>

#include "common/dataset/pcd.hpp"
#include "common/error_message.hpp"
#include "groundstation/fusion/evaluation.hpp"
#include "groundstation/fusion/graph_map.hpp"
#include "groundstation/station/session_replay.hpp"

namespace teamscan::station {

Result<ModelCheck> check_model_against_eval(const std::string& session, const FusionOptions& options) {
  const std::string name = options.all_points_pcd.empty() ? std::string("fused_all.pcd") : options.all_points_pcd;
  auto cloud = read_pcd(session + "/" + name);
  if (!cloud) return with_context(name, cloud.error());
  const PcdCloud& c = cloud.value();
  const int fr = c.field("robot"), fs = c.field("scan"), fb = c.field("beam"), fk = c.field("keep"), fl = c.field("live_keep");
  if (fr < 0 || fs < 0 || fb < 0 || fk < 0) return make_error(name + " lacks robot/scan/beam/keep");
  std::unordered_map<std::uint64_t, std::uint8_t> model;  // bit 0: removed, bit 1: removed at release, bit 2: matched
  model.reserve(c.size());
  for (std::size_t i = 0; i < c.size(); ++i) {
    auto col = [&](int f) { return c.columns[static_cast<std::size_t>(f)][i]; };
    model[point_key(static_cast<std::uint32_t>(col(fr)), static_cast<std::uint32_t>(col(fs)), static_cast<std::uint32_t>(col(fb)))] =
        static_cast<std::uint8_t>((col(fk) == 0.0 ? 1 : 0) | (fl >= 0 && col(fl) == 0.0 ? 2 : 0));
  }
  SessionReadStats stats;
  auto ds = read_session_dataset(session, stats);
  if (!ds) return ds.error();
  fusion::CoreRunOptions run;
  run.tracker = options.core.tracker;
  run.registration = options.core.registration;
  run.registration_options = options.core.registration_options;
  if (options.pose_graph) {
    // As the station's final model: a graph fed the primary's releases, then the model on its poses.
    fusion::GraphBackend graph(fusion::without_estimates(*options.pose_graph));
    run.graph = &graph;
    Result<fusion::CoreRun> first = fusion::run_through_core(ds.value(), options.core.method, options.core.methods, run);
    if (!first) return first.error();
    graph.finish();
    run.graph = nullptr;
    run.registration = false;
    run.decide_with = fusion::graph_poses_by_row(ds.value(), graph.poses());
  }
  Result<fusion::CoreRun> ran = fusion::run_through_core(ds.value(), options.core.method, options.core.methods, run);
  if (!ran) return ran.error();
  const std::vector<std::uint8_t>& eval = ran.value().removed;
  ModelCheck out;
  out.model_points = c.size();
  out.points.reserve(ds->points.size());
  for (std::size_t i = 0; i < ds->points.size(); ++i) {
    const LabelledPoint& p = ds->points[i];
    PointDecision d;
    d.robot = p.robot;
    d.seq = p.scan;
    d.beam = p.beam;
    d.eval_removed = eval[i] != 0;
    auto it = model.find(point_key(p.robot, p.scan, p.beam));
    if (it != model.end()) {
      d.in_model = true;
      d.model_removed = (it->second & 1) != 0;
      d.live_removed = (it->second & 2) != 0;
      it->second |= 4;
      ++out.compared;
      if (d.model_removed != d.eval_removed) ++out.mismatches;
    } else {
      ++out.not_in_model;
    }
    out.points.push_back(d);
  }
  for (const auto& [key, flags] : model)
    if (!(flags & 4)) ++out.model_unknown;
  return out;
}

}  // namespace teamscan::station
