// The fused map on the pose graph's poses (graph_map.hpp).
#include "groundstation/fusion/graph_map.hpp"

#include <cstdint>
#include <map>
#include <string>
#include <utility>

#include "common/error_message.hpp"
#include "groundstation/fusion/time_line.hpp"

namespace teamscan::fusion {

std::vector<std::optional<Pose2>> graph_poses_by_row(const Dataset& dataset, const std::vector<GraphScanPose>& graph) {
  std::map<std::pair<std::uint8_t, std::uint32_t>, Pose2> by_scan;
  for (const GraphScanPose& p : graph) by_scan[{p.robot, p.scan}] = p.graph;
  std::vector<std::optional<Pose2>> out(dataset.scans.size());
  for (std::size_t i = 0; i < dataset.scans.size(); ++i)
    if (const auto it = by_scan.find({dataset.scans[i].robot, dataset.scans[i].scan}); it != by_scan.end()) out[i] = it->second;
  return out;
}

Status decide_with(PoseHistory& poses, const Dataset& dataset, std::span<const std::optional<Pose2>> by_row) {
  if (by_row.size() != dataset.scans.size())
    return make_error("the poses to decide with are " + std::to_string(by_row.size()) + " for " +
                      std::to_string(dataset.scans.size()) + " scan rows: one per row expected");
  for (std::size_t i = 0; i < dataset.scans.size(); ++i) {
    if (!by_row[i]) continue;
    const ScanRecord& row = dataset.scans[i];
    poses.set_map_from_odom(row.robot, row.stamp_ns, *by_row[i] * row.pose.inverse(), 0.0, 0.0, false);
  }
  return ok_status();
}

Result<std::size_t> feed_on_poses(const Dataset& dataset, std::span<const std::optional<Pose2>> by_row, CoreSet& cores,
                                  const std::function<void(double)>& progress, ScanPointsSource* points) {
  for (std::size_t i = 0; i < cores.size(); ++i) {
    FusionCore& core = cores.at(i);
    if (core.options().registration) return Error{"the pose graph's poses and the registration cannot both place the scans"};
    if (Status st = core.reset(); !st.ok()) return st.error();
    if (Status st = decide_with(core.poses(), dataset, by_row); !st.ok()) return st.error();
  }
  const TimeLine time_line(dataset, points);
  time_line.feed([&](PoseInput& p) { cores.add_pose(p); }, [&](ScanInput& s) { (void)cores.add_scan(s); }, progress);
  cores.flush();
  return time_line.records().size();
}

Result<std::unique_ptr<CoreSet>> cores_on_graph(const Dataset& dataset, const std::vector<GraphScanPose>& graph, CoreOptions primary,
                                                const std::vector<std::string>& compared,
                                                std::function<void(const FusedScan&)> on_primary_release,
                                                const std::function<void(double)>& progress, ScanPointsSource* points) {
  primary.registration = false;
  Result<std::unique_ptr<CoreSet>> cores = CoreSet::create(with_graph_order(primary), compared);
  if (!cores) return cores.error();
  if (on_primary_release) cores.value()->primary().set_release_callback(std::move(on_primary_release));
  const std::vector<std::optional<Pose2>> by_row = graph_poses_by_row(dataset, graph);
  if (Result<std::size_t> fed = feed_on_poses(dataset, by_row, *cores.value(), progress, points); !fed) return fed.error();
  return cores;
}

Result<RebuildSource> rebuild_source_on_graph(Dataset dataset, CoreOptions primary, const std::vector<std::string>& compared,
                                              const std::vector<GraphScanPose>& graph, std::unique_ptr<ScanPointsSource> points) {
  primary.registration = false;
  Result<RebuildSource> source = make_rebuild_source(std::move(dataset), with_graph_order(primary), compared, std::move(points));
  if (!source) return source.error();
  const std::vector<std::optional<Pose2>> by_row = graph_poses_by_row(*source->dataset, graph);
  for (std::size_t i = 0; i < source->cores->size(); ++i)
    if (Status st = decide_with(source->cores->at(i).poses(), *source->dataset, by_row); !st.ok()) return st.error();
  return source;
}

}  // namespace teamscan::fusion
