// The fused map on the pose graph's poses: the graph's pose of each scan row of a data set, and a set of
// fusion cores given those poses and fed the data set in time order, so every scan's points, the team
// state the filters read and every decision follow the graph (`teamscan eval --pose-graph`, the
// station's final model with [fusion] pose_graph, the demo's replay of it).
//
// How: each scan row's robot is given, from the scan's stamp on, the correction that takes the row's
// pose (the one its points were placed with) to the graph's (PoseHistory::set_map_from_odom, a change of
// frame, not a measurement). A row the graph did not take gets none: the correction of the robot's
// scan before it stays in force (an identity there would move its points back to odometry).
#pragma once

#include <cstddef>
#include <functional>
#include <memory>
#include <string>
#include <optional>
#include <span>
#include <vector>

#include "common/dataset/dataset.hpp"
#include "common/pose.hpp"
#include "common/result.hpp"
#include "groundstation/fusion/core_rebuild.hpp"
#include "groundstation/fusion/core_set.hpp"
#include "groundstation/fusion/graph_backend.hpp"
#include "groundstation/fusion/pose_history.hpp"

namespace teamscan::fusion {

// Per Dataset::scans row, the graph's pose of that (robot, scan), or none (a scan the graph did not take).
[[nodiscard]] std::vector<std::optional<Pose2>> graph_poses_by_row(const Dataset& dataset, const std::vector<GraphScanPose>& graph);

// Gives `poses` the corrections that place each row's scan at its pose (see the top). An error when the
// poses are not one per scan row.
[[nodiscard]] Status decide_with(PoseHistory& poses, const Dataset& dataset, std::span<const std::optional<Pose2>> by_row);

// Every core of `cores` reset, given the poses (decide_with) and fed the data set in time order
// (time_line.hpp), then flushed: the model, the decisions and the release callbacks' scans are those of
// the poses given. The cores must not run the registration (it would place the scans again). Returns
// the scans fed. `progress` (optional) as TimeLine::feed's; `points` (optional) as TimeLine's: the
// scans' points read on demand instead of dataset.points.
[[nodiscard]] Result<std::size_t> feed_on_poses(const Dataset& dataset, std::span<const std::optional<Pose2>> by_row, CoreSet& cores,
                                                const std::function<void(double)>& progress = {},
                                                ScanPointsSource* points = nullptr);

// A new set of cores (`primary`'s options without the registration: the graph placed the scans, and the
// compared methods) fed the data set on the graph's poses (feed_on_poses): the station's final model,
// the demo's replay of it. `on_primary_release` (optional) sees every scan the primary releases;
// `points` as feed_on_poses'.
[[nodiscard]] Result<std::unique_ptr<CoreSet>> cores_on_graph(const Dataset& dataset, const std::vector<GraphScanPose>& graph,
                                                              CoreOptions primary, const std::vector<std::string>& compared,
                                                              std::function<void(const FusedScan&)> on_primary_release = {},
                                                              const std::function<void(double)>& progress = {},
                                                              ScanPointsSource* points = nullptr);

// A rebuild in slices (core_rebuild.hpp) on the graph's poses: a new set of cores as cores_on_graph's,
// given the poses (decide_with) and not yet fed: the station's live map following the graph's estimate.
[[nodiscard]] Result<RebuildSource> rebuild_source_on_graph(Dataset dataset, CoreOptions primary, const std::vector<std::string>& compared,
                                                            const std::vector<GraphScanPose>& graph,
                                                            std::unique_ptr<ScanPointsSource> points = nullptr);

}  // namespace teamscan::fusion
