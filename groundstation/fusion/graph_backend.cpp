// The fusion core's back end, the team's pose graph on its own thread (graph_backend.hpp).
#include "groundstation/fusion/graph_backend.hpp"

#include <algorithm>
#include <array>
#include <cstdint>
#include <utility>
#include <vector>

#include <pthread.h>
#include <sched.h>
#include <sys/resource.h>

namespace teamscan::fusion {

GraphBackend::GraphBackend(GraphBackendOptions options)
    : options_(std::move(options)),
      open_(static_cast<std::size_t>(kMaxRobots) + 1),
      scans_taken_(static_cast<std::size_t>(kMaxRobots) + 1),
      thread_([this] { run(); }) {}

GraphBackend::~GraphBackend() {
  {
    const std::lock_guard lock(mutex_);
    stop_ = true;
  }
  wake_.notify_all();
  thread_.join();
}

void GraphBackend::add(const FusedScan& released, const Pose2* odom_from_robot) {
  if (finishing_ || released.view == nullptr) return;
  const mapping::ScanView& v = *released.view;
  if (v.robot > kMaxRobots) return;
  auto& taken = scans_taken_[v.robot];
  const std::pair<std::int64_t, std::uint32_t> key{v.stamp_ns, v.scan};
  if (taken.empty() || taken.back() < key) {
    taken.push_back(key);
  } else {
    const auto at = std::lower_bound(taken.begin(), taken.end(), key);
    if (at != taken.end() && *at == key) {
      ++counters_.repeated_scans;
      return;
    }
    taken.insert(at, key);
  }
  if (v.stamp_ns < newest_taken_ns_) ++counters_.out_of_stamp_order;
  newest_taken_ns_ = std::max(newest_taken_ns_, v.stamp_ns);
  Open& o = open_[v.robot];
  if (!o.tilted && v.points.size() >= 2) o.tilted = !level_scan(v);
  const bool tilted = o.tilted.value_or(false);
  // A level laser's scan is a node; a tilted laser's node closes when its robot's next scan is
  // tilted_node_s or more after the node's first.
  const auto span_ns = static_cast<std::int64_t>(options_.returns.tilted_node_s * 1e9);
  if (!o.scans.empty() && (!tilted || v.stamp_ns - o.first_stamp_ns >= span_ns)) close(v.robot);
  if (o.scans.empty()) o.first_stamp_ns = v.stamp_ns;
  // The scan as the robot's odometry placed it, before the core's correction, with the teammates as
  // theirs place them: nothing the corrections decide (core.hpp CoreOptions::odometry_team).
  mapping::ScanView odom_view = v;
  if (released.odom_points.size() == v.points.size()) {
    odom_view.points = released.odom_points;
    odom_view.origin_m = released.odom_origin_m;
  }
  odom_view.team = released.odom_team;
  const std::span<const mapping::MapPoint> points = odom_view.points;
  take_planar_returns(odom_view, tilted, options_.returns, taken_, counters_.returns);
  for (std::size_t j = 0; j < points.size(); ++j)
    if (taken_[j] != 0) o.odom_returns.push_back({points[j].x, points[j].y});
  const Pose2 odom = odom_from_robot != nullptr ? *odom_from_robot : released.odom_from_robot;
  o.scans.push_back({v.scan, v.stamp_ns, odom});
  if (counters_.scans++ == 0) first_scan_ = std::chrono::steady_clock::now();
  if (tilted) ++counters_.tilted_scans;
  if (!tilted) close(v.robot);
}

void GraphBackend::close(std::uint8_t robot) {
  Open& o = open_[robot];
  if (o.scans.empty()) return;
  Node n;
  n.robot = robot;
  n.tilted = o.tilted.value_or(false);
  n.odom = o.scans.back().odom;
  // Into the frame of the node's last scan.
  const Pose2 node_from_odom = n.odom.inverse();
  n.returns.reserve(o.odom_returns.size());
  for (const Vec2& p : o.odom_returns) n.returns.push_back(node_from_odom.apply(p));
  n.scans = std::make_shared<const std::vector<NodeScan>>(o.scans.begin(), o.scans.end());  // exact: kept for the whole run
  o.scans.clear();
  o.odom_returns.clear();
  ++counters_.nodes;
  {
    const std::lock_guard lock(mutex_);
    queue_.push_back(std::move(n));
    counters_.queue_max = std::max(counters_.queue_max, queue_.size());
  }
  wake_.notify_one();
}

void GraphBackend::finish() {
  if (finishing_) return;
  finishing_ = true;
  for (std::size_t r = 0; r < open_.size(); ++r) close(static_cast<std::uint8_t>(r));
  {
    const std::lock_guard lock(mutex_);
    input_done_ = true;
  }
  wake_.notify_one();
}

void GraphBackend::run() {
  {
    const int error = set_current_thread_cpus(options_.cpus);
    set_current_thread_below_loop();
    const std::lock_guard lock(mutex_);
    thread_id_ = current_thread_id();
    affinity_error_ = error;
  }
  for (;;) {
    Node n;
    {
      std::unique_lock lock(mutex_);
      wake_.wait(lock, [&] { return stop_ || !queue_.empty() || input_done_; });
      if (stop_) return;
      if (queue_.empty()) break;  // input_done_ and everything taken
      n = std::move(queue_.front());
      queue_.pop_front();
    }
    if (!slam_) slam_ = std::make_unique<posegraph::PlanarSlam>(
                    options_.slam ? *options_.slam : n.tilted ? posegraph::tilted_laser_options() : options_.level);
    {
      const std::vector<Vec2> returns = std::move(n.returns);  // the graph keeps its own copy: freed here
      graph_node_.push_back(slam_->add_scan(n.robot, n.scans->back().stamp_ns, n.odom, returns));
    }
    in_graph_.push_back(std::move(n));
    publish_estimate();
  }
  if (slam_) slam_->finish();
  std::vector<Pose2> nodes;
  if (slam_)
    for (std::size_t k = 0; k < in_graph_.size(); ++k) nodes.push_back(slam_->pose(graph_node_[k]));
  poses_ = scan_poses(nodes);
  {
    const std::lock_guard lock(mutex_);
    done_at_ = std::chrono::steady_clock::now();
    done_ = true;
  }
  done_cv_.notify_all();
}

std::vector<GraphScanPose> scan_poses_on_nodes(std::span<const NodeScans> nodes) {
  std::vector<GraphScanPose> out;
  std::array<const NodeScans*, 256> previous{};  // per robot id: its node before
  for (const NodeScans& n : nodes) {
    if (n.scans.empty()) continue;
    const NodeScans* before = std::exchange(previous[n.robot], &n);
    const Pose2 node_from_odom = n.odom.inverse();
    for (const NodeScan& scan : n.scans) {
      GraphScanPose s{n.robot, scan.scan, scan.stamp_ns, scan.odom, n.graph};
      if (&scan == &n.scans.back()) {
        out.push_back(s);  // the node's last scan: at the node's pose, exactly
        continue;
      }
      s.graph = n.graph * (node_from_odom * s.odom);
      if (before != nullptr) {
        const std::int64_t t0 = before->scans.back().stamp_ns, t1 = n.scans.back().stamp_ns;
        const double f = t1 > t0 ? std::clamp(static_cast<double>(s.stamp_ns - t0) / static_cast<double>(t1 - t0), 0.0, 1.0) : 1.0;
        const Pose2 forward = before->graph * (before->odom.inverse() * s.odom);
        const Pose2 step = forward.inverse() * s.graph;
        s.graph = forward * Pose2{f * step.x_m, f * step.y_m, f * step.theta_rad};
      }
      out.push_back(s);
    }
  }
  return out;
}

std::vector<GraphScanPose> GraphBackend::scan_poses(const std::vector<Pose2>& nodes) const {
  std::vector<NodeScans> placed;
  placed.reserve(std::min(in_graph_.size(), nodes.size()));
  for (std::size_t k = 0; k < in_graph_.size() && k < nodes.size(); ++k)
    placed.push_back({in_graph_[k].robot, in_graph_[k].odom, nodes[k], *in_graph_[k].scans});
  return scan_poses_on_nodes(placed);
}

std::vector<GraphScanPose> GraphEstimate::poses() const {
  std::vector<NodeScans> placed;
  placed.reserve(graph_nodes.size());
  for (const EstimateNode& n : graph_nodes) placed.push_back({n.robot, n.odom, n.graph, *n.scans});
  return scan_poses_on_nodes(placed);
}

std::array<std::optional<GraphScanPose>, kMaxRobots + 1> GraphEstimate::newest_scans() const {
  // A robot's newest scan is the last of its node whose last scan is stamped latest; its pose is worked out
  // as poses() does, from that node and the robot's node before it, to the bit.
  constexpr std::size_t kNone = SIZE_MAX;
  std::array<std::size_t, kMaxRobots + 1> newest, before_newest, last;
  newest.fill(kNone);
  before_newest.fill(kNone);
  last.fill(kNone);
  for (std::size_t k = 0; k < graph_nodes.size(); ++k) {
    const EstimateNode& n = graph_nodes[k];
    if (n.robot == 0 || n.robot > kMaxRobots || n.scans->empty()) continue;
    const std::size_t b = std::exchange(last[n.robot], k);
    if (newest[n.robot] == kNone || n.scans->back().stamp_ns >= graph_nodes[newest[n.robot]].scans->back().stamp_ns) {
      newest[n.robot] = k;
      before_newest[n.robot] = b;
    }
  }
  std::array<std::optional<GraphScanPose>, kMaxRobots + 1> out;
  for (std::size_t r = 1; r <= kMaxRobots; ++r) {
    if (newest[r] == kNone) continue;
    std::vector<NodeScans> two;
    for (const std::size_t k : {before_newest[r], newest[r]})
      if (k != kNone) two.push_back({graph_nodes[k].robot, graph_nodes[k].odom, graph_nodes[k].graph, *graph_nodes[k].scans});
    out[r] = scan_poses_on_nodes(two).back();
  }
  return out;
}

std::shared_ptr<GraphEstimate> GraphEstimate::of_scans(const std::vector<GraphScanPose>& poses) {
  auto e = std::make_shared<GraphEstimate>();
  e->graph_nodes.reserve(poses.size());
  for (const GraphScanPose& p : poses)
    e->graph_nodes.push_back({p.robot, p.odom, p.graph, std::make_shared<const std::vector<NodeScan>>(1, NodeScan{p.scan, p.stamp_ns, p.odom})});
  return e;
}

void GraphBackend::publish_estimate() {
  if (!(options_.estimate_every_s > 0.0) || in_graph_.size() == estimated_nodes_) return;
  const auto now = std::chrono::steady_clock::now();
  if (in_graph_.size() == 1) estimated_at_ = now;  // the clock starts with the first node
  if (std::chrono::duration<double>(now - estimated_at_).count() < options_.estimate_every_s) return;
  auto e = std::make_shared<GraphEstimate>();
  const std::vector<Pose2> all = slam_->estimate();
  std::vector<Pose2> nodes;
  nodes.reserve(in_graph_.size());
  for (std::size_t k = 0; k < in_graph_.size(); ++k) nodes.push_back(all[graph_node_[k]]);
  e->graph_nodes.reserve(in_graph_.size());
  for (std::size_t k = 0; k < in_graph_.size(); ++k) e->graph_nodes.push_back({in_graph_[k].robot, in_graph_[k].odom, nodes[k], in_graph_[k].scans});
  const posegraph::SlamStats stats = slam_->stats();
  e->nodes = stats.nodes;
  e->closures = stats.closures;
  e->solve_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - now).count();
  estimated_at_ = now;
  estimated_nodes_ = in_graph_.size();
  const std::lock_guard lock(mutex_);
  e->version = latest_ ? latest_->version + 1 : 1;
  latest_ = std::move(e);
}

std::shared_ptr<const GraphEstimate> GraphBackend::latest() {
  const std::lock_guard lock(mutex_);
  return latest_;
}

void GraphBackend::wait_done() {
  std::unique_lock lock(mutex_);
  done_cv_.wait(lock, [&] { return done_ || stop_; });
}

bool GraphBackend::finished_within(std::chrono::milliseconds timeout) {
  finish();
  std::unique_lock lock(mutex_);
  return done_cv_.wait_for(lock, timeout, [&] { return done_ || stop_; });
}

const std::vector<GraphScanPose>& GraphBackend::poses() {
  finish();
  wait_done();
  return poses_;
}

std::size_t GraphBackend::queued() {
  const std::lock_guard lock(mutex_);
  return queue_.size();
}

GraphThreadPlacement GraphBackend::placement() {
  int tid = 0;
  bool running = false;
  GraphThreadPlacement out;
  {
    const std::lock_guard lock(mutex_);
    tid = thread_id_;
    running = !done_ && !stop_;
    out.affinity_error = affinity_error_;
  }
  if (tid != 0 && running) out.scheduling = thread_scheduling(thread_.native_handle(), tid);
  return out;
}

double GraphBackend::seconds() {
  finish();
  wait_done();
  return counters_.scans == 0 ? 0.0 : std::chrono::duration<double>(done_at_ - first_scan_).count();
}

posegraph::SlamStats GraphBackend::graph_stats() {
  finish();
  wait_done();
  return slam_ ? slam_->stats() : posegraph::SlamStats{};
}

}  // namespace teamscan::fusion
