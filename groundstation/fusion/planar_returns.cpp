// A data set's scans as planar returns for the pose graph (planar_returns.hpp).
#include "groundstation/fusion/planar_returns.hpp"

#include <algorithm>
#include <array>
#include <limits>
#include <map>
#include <utility>

#include "common/capacities.hpp"
#include "groundstation/fusion/match_points.hpp"
#include "groundstation/fusion/pose_history.hpp"
#include "groundstation/fusion/time_line.hpp"

namespace teamscan::fusion {

bool level_laser(const DatasetRobot& robot) { return robot.mount_rpy_rad[0] == 0.0 && robot.mount_rpy_rad[1] == 0.0; }

PlanarReturns planar_returns(const Dataset& dataset, const PlanarReturnOptions& options) {
  // Each robot's laser: level (every return taken) or tilted (the height band). A robot the data set
  // does not describe counts as level: its returns are taken as they are.
  std::array<bool, kMaxRobots + 1> tilted{};
  for (const DatasetRobot& r : dataset.robots)
    if (r.id <= kMaxRobots) tilted[r.id] = !level_laser(r);
  // Which points a match may use, scan by scan in the fusion core's time order (its team state at the
  // scan's stamp: the same poses, the same tracker).
  std::vector<std::uint8_t> usable(dataset.points.size(), 1);
  const TimeLine time_line(dataset);
  const auto& by_scan = time_line.points_by_scan();
  PoseHistoryOptions history_options;
  history_options.tracker = options.tracker;
  PoseHistory history(history_options);
  std::vector<std::uint8_t> scan_usable;
  time_line.feed([&](PoseInput& p) { history.add(p); },
                 [&](ScanInput& in) {
                   const auto it = by_scan.find({in.robot, in.scan});
                   if (it == by_scan.end()) return;
                   scan_usable.assign(in.points.size(), 1);
                   for (std::size_t j = 0; j < in.points.size(); ++j)
                     scan_usable[j] = match_usable_flags(j < in.flags.size() ? in.flags[j] : 0) ? 1 : 0;
                   mask_teammates(history.team_at(in.stamp_ns), in.robot, in.origin_m, options.tracked, in.points, scan_usable);
                   for (std::size_t j = 0; j < it->second.size() && j < scan_usable.size(); ++j) usable[it->second[j]] = scan_usable[j];
                 });
  // Scans in time order (stamp, robot, scan), gathered into nodes per robot.
  std::vector<std::size_t> order(dataset.scans.size());
  for (std::size_t i = 0; i < order.size(); ++i) order[i] = i;
  std::stable_sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) {
    const ScanRecord& x = dataset.scans[a];
    const ScanRecord& y = dataset.scans[b];
    if (x.stamp_ns != y.stamp_ns) return x.stamp_ns < y.stamp_ns;
    if (x.robot != y.robot) return x.robot < y.robot;
    return x.scan < y.scan;
  });
  std::vector<std::size_t> node_of(dataset.scans.size(), 0);
  PlanarReturns out;
  std::array<std::vector<std::size_t>, kMaxRobots + 1> open;  // a tilted laser's rows gathered so far
  auto close = [&](std::uint8_t robot) {
    std::vector<std::size_t>& rows = open[robot];
    if (rows.empty()) return;
    for (std::size_t r : rows) node_of[r] = out.nodes.size();
    out.nodes.push_back({robot, rows.back(), std::move(rows), {}});
    rows.clear();
  };
  const auto tilted_node_ns = static_cast<std::int64_t>(options.tilted_node_s * 1e9);
  for (const std::size_t i : order) {
    const ScanRecord& s = dataset.scans[i];
    const std::uint8_t robot = s.robot <= kMaxRobots ? s.robot : 0;
    if (!tilted[robot]) {
      node_of[i] = out.nodes.size();
      out.nodes.push_back({s.robot, i, {i}, {}});
      continue;
    }
    if (!open[robot].empty() && s.stamp_ns - dataset.scans[open[robot].front()].stamp_ns >= tilted_node_ns) close(robot);
    open[robot].push_back(i);
  }
  for (std::size_t r = 0; r <= kMaxRobots; ++r) close(static_cast<std::uint8_t>(r));
  // The nodes in the order of their last scan (a node closes only when its robot's next scan comes).
  std::vector<std::size_t> rank(dataset.scans.size(), 0);
  for (std::size_t k = 0; k < order.size(); ++k) rank[order[k]] = k;
  std::vector<std::size_t> node_order(out.nodes.size());
  for (std::size_t k = 0; k < node_order.size(); ++k) node_order[k] = k;
  std::sort(node_order.begin(), node_order.end(), [&](std::size_t a, std::size_t b) { return rank[out.nodes[a].row] < rank[out.nodes[b].row]; });
  std::vector<PlanarNode> sorted;
  sorted.reserve(out.nodes.size());
  std::vector<std::size_t> new_index(out.nodes.size());
  for (std::size_t k = 0; k < node_order.size(); ++k) {
    new_index[node_order[k]] = k;
    sorted.push_back(std::move(out.nodes[node_order[k]]));
  }
  out.nodes = std::move(sorted);
  for (std::size_t& n : node_of) n = new_index[n];

  std::map<std::pair<std::uint8_t, std::uint32_t>, std::size_t> row;
  for (std::size_t i = 0; i < dataset.scans.size(); ++i) row.emplace(std::make_pair(dataset.scans[i].robot, dataset.scans[i].scan), i);
  std::vector<Pose2> node_from_map(out.nodes.size());
  for (std::size_t k = 0; k < out.nodes.size(); ++k) node_from_map[k] = dataset.scans[out.nodes[k].row].pose.inverse();
  out.taken.assign(dataset.points.size(), 0);
  for (std::size_t i = 0; i < dataset.points.size(); ++i) {
    const LabelledPoint& p = dataset.points[i];
    const auto it = row.find({p.robot, p.scan});
    if (it == row.end()) continue;
    if (usable[i] == 0) {
      ++out.masked;
      continue;
    }
    if (p.robot <= kMaxRobots && tilted[p.robot] && (p.z < options.min_height_m || p.z > options.max_height_m)) {
      ++out.out_of_band;
      continue;
    }
    // Into the node's robot frame (the data set holds the points in the odometry's map frame).
    const std::size_t k = node_of[it->second];
    out.nodes[k].returns.push_back(node_from_map[k].apply({p.x, p.y}));
    out.taken[i] = 1;
    ++out.kept;
  }
  return out;
}

std::vector<Pose2> scan_poses(const Dataset& dataset, const PlanarReturns& returns, const std::vector<Pose2>& node_poses) {
  std::vector<Pose2> poses(dataset.scans.size());
  for (std::size_t i = 0; i < dataset.scans.size(); ++i) poses[i] = dataset.scans[i].pose;
  for (std::size_t k = 0; k < returns.nodes.size() && k < node_poses.size(); ++k) {
    const PlanarNode& n = returns.nodes[k];
    const Pose2 node_from_map = dataset.scans[n.row].pose.inverse();
    for (const std::size_t r : n.rows) poses[r] = r == n.row ? node_poses[k] : node_poses[k] * (node_from_map * dataset.scans[r].pose);
  }
  return poses;
}

}  // namespace teamscan::fusion
