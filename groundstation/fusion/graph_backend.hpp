// The fusion core's back end: the team's 2-D pose graph (groundstation/posegraph: submaps, loop
// closure within and between robots, Ceres), fed every scan the core released. Its front end is the
// robots' odometry: each released scan's returns that pin x, y and yaw (planar_returns.hpp) are taken
// back out of the correction the core applied (registration's or the graph's own) into the frame of
// the odometry that placed them, the teammates left out where their odometry places them
// (FusedScan::odom_team), and copied into the robot frame of its node (a level laser's scan, or
// a tilted laser's scans over tilted_node_s). So what the graph is given does not depend on how the
// map was corrected when the scan was released: a map that follows the graph feeds it no feedback. The
// closed nodes go to the graph on the back end's own thread, so the caller's loop only copies returns.
// Deterministic: the nodes join the graph in the order they closed, so the same releases in the same
// order give the same poses to the bit, whatever the threads did (`teamscan eval --pose-graph` and a
// station fed the same releases agree). While it runs it publishes, every estimate_every_s, every
// scan's pose as the graph would put it now (latest()): what a live map follows.
#pragma once

#include <array>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <memory>
#include <mutex>
#include <optional>
#include <span>
#include <utility>
#include <thread>
#include <vector>

#include "common/capacities.hpp"
#include "common/pose.hpp"
#include "common/thread_placement.hpp"
#include "groundstation/fusion/core.hpp"
#include "groundstation/fusion/planar_returns.hpp"
#include "groundstation/posegraph/slam.hpp"

namespace teamscan::fusion {

struct GraphBackendOptions {
  PlanarReturnOptions returns;
  // The graph's options; unset: `level` for level lasers and tilted_laser_options() for tilted ones,
  // chosen by the first node's laser.
  std::optional<posegraph::SlamOptions> slam;
  // A level laser's graph (a planar log's): posegraph's defaults unless the user tuned them (`teamscan
  // eval --pose-graph-local-search-score` and the like, docs/slam.md "A held-out log in open spaces").
  posegraph::SlamOptions level;
  // The CPUs of the graph's thread (empty: the caller's). It runs SCHED_BATCH at nice 10, so a station's
  // receive loop on the same CPU is not preempted by it; a station pinned to one core names another.
  std::vector<int> cpus;
  // While scans come in: at most every this many seconds (the graph thread's clock), once nodes were
  // added since the last one, the graph is solved on a copy (posegraph::PlanarSlam::estimate) and every
  // scan in it so far published with its pose (latest()). 0: none (the poses only at the end).
  double estimate_every_s = 0.0;
};

// `o` for a graph fed offline (a session's check or replay): no estimates while it runs, only the end's.
[[nodiscard]] inline GraphBackendOptions without_estimates(GraphBackendOptions o) {
  o.estimate_every_s = 0.0;
  return o;
}

// A released scan's pose: as the core decided it, and as the graph put it.
struct GraphScanPose {
  std::uint8_t robot = 0;
  std::uint32_t scan = 0;
  std::int64_t stamp_ns = 0;
  Pose2 odom;   // the odometry's pose, its returns relative to it (the released pose without its correction)
  Pose2 graph;  // after the graph's last optimisation
};

// A scan of a node as the back end keeps it until the end: what places it (scan_poses_on_nodes). One per
// scan the graph took, for the whole run: the only part of the back end that grows with the time mapped
// rather than with the place (besides the graph's own nodes and constraints).
struct NodeScan {
  std::uint32_t scan = 0;
  std::int64_t stamp_ns = 0;
  Pose2 odom;  // as GraphScanPose::odom
};

// A node of the graph as scan_poses_on_nodes reads it: its robot, the odometry's pose of its last scan,
// where the graph put it, and the scans it gathers (in order, the last one at `odom`).
struct NodeScans {
  std::uint8_t robot = 0;
  Pose2 odom;
  Pose2 graph;
  std::span<const NodeScan> scans;
};

// Every scan of `nodes` (the graph's node order) with its pose in the graph. A robot's first node's
// scans: the node's pose moved by the odometry's motion from its last scan to them. A later node's: the
// same (B) and the robot's previous node's pose moved forward by the odometry (A), the scan placed from A
// to B in proportion to its stamp between the two nodes' last scans. So what the graph corrected of the
// odometry since the previous node (a turn or slip error over the node) is spread over the node's scans
// instead of being put whole at its last one and carried back by the odometry; a node's last scan is at
// the node's pose either way.
[[nodiscard]] std::vector<GraphScanPose> scan_poses_on_nodes(std::span<const NodeScans> nodes);

// A node of an estimate: as NodeScans, its scans shared with the back end (they never change once the
// node is in the graph), so an estimate holds a node's worth per node, not a pose per scan.
struct EstimateNode {
  std::uint8_t robot = 0;
  Pose2 odom;
  Pose2 graph;
  std::shared_ptr<const std::vector<NodeScan>> scans;
};

// The graph's poses while it runs: every node in the graph when it was solved (the scans of nodes still
// open or queued are not), and through them every scan's pose as GraphBackend::poses() gives it at the end.
struct GraphEstimate {
  std::uint64_t version = 0;  // 1, 2, ... in the order they were made
  std::size_t nodes = 0;      // the graph's nodes and loop closures then
  std::size_t closures = 0;
  double solve_s = 0.0;       // the copy's optimisation, wall time
  std::vector<EstimateNode> graph_nodes;  // the graph's node order
  // Every scan of the nodes with its pose (scan_poses_on_nodes), worked out on each call.
  [[nodiscard]] std::vector<GraphScanPose> poses() const;
  // Each robot's newest scan's pose (none: robot absent), by robot id, from the nodes alone.
  [[nodiscard]] std::array<std::optional<GraphScanPose>, kMaxRobots + 1> newest_scans() const;
  // An estimate that places exactly these scans, each its own node (tests).
  [[nodiscard]] static std::shared_ptr<GraphEstimate> of_scans(const std::vector<GraphScanPose>& poses);
};

struct GraphBackendCounters {
  std::uint64_t scans = 0;       // released scans taken
  std::uint64_t nodes = 0;       // closed nodes handed to the graph
  std::uint64_t tilted_scans = 0;
  std::uint64_t repeated_scans = 0;  // a (robot, scan, stamp) taken before: ignored (a rebuilt core's release of it)
  // Scans taken stamped before one taken earlier (of any robot): the releases were not in time order,
  // so the graph is not the one `teamscan eval`'s time order feeds (the station catches up at its stop).
  std::uint64_t out_of_stamp_order = 0;
  PlanarReturnCounts returns;
  std::size_t queue_max = 0;     // the most closed nodes waiting for the graph at once
};

// The graph's thread as placed: its scheduling read back from the kernel and the errno of setting its CPUs.
struct GraphThreadPlacement {
  ThreadScheduling scheduling;
  int affinity_error = 0;
};

class GraphBackend {
 public:
  explicit GraphBackend(GraphBackendOptions options = {});
  ~GraphBackend();  // stops the graph's thread (the nodes not yet in the graph are dropped)
  GraphBackend(const GraphBackend&) = delete;
  GraphBackend& operator=(const GraphBackend&) = delete;

  // A scan the core released (its release callback), in release order. Not after finish(). A scan taken
  // before (same robot, sequence number and stamp) is ignored. Its returns go into the graph relative to
  // the odometry pose its points were placed with: `odom_from_robot`, when the caller knows it (a data
  // set's scan row: the pose its source placed them with); else the pose the core decided it with
  // without the core's correction (the station: its points were placed by the robot's odometry, of which
  // the core's pose history holds the published samples).
  void add(const FusedScan& released, const Pose2* odom_from_robot = nullptr);
  // No more scans: the open nodes close, the graph takes the rest, is searched again and optimised a
  // last time (posegraph::PlanarSlam::finish), all on the back end's thread. Returns at once.
  void finish();
  // finish(), then waits at most `timeout` for its work: true once done (a caller that must show progress
  // meanwhile, the station's shutdown, calls it again).
  [[nodiscard]] bool finished_within(std::chrono::milliseconds timeout);
  // Waits for finish()'s work; then every taken scan's pose, its node's scans in release order, the
  // nodes in the order they closed.
  [[nodiscard]] const std::vector<GraphScanPose>& poses();
  [[nodiscard]] posegraph::SlamStats graph_stats();
  [[nodiscard]] GraphBackendCounters counters() const { return counters_; }
  // Closed nodes waiting for the graph now (how far the graph is behind the releases).
  [[nodiscard]] std::size_t queued();
  // The graph's thread's CPUs and scheduling, once it started (policy -1 before).
  [[nodiscard]] GraphThreadPlacement placement();
  // The newest estimate the graph's thread published while running (estimate_every_s), nullptr before
  // the first. Cheap: the caller shares it.
  [[nodiscard]] std::shared_ptr<const GraphEstimate> latest();
  // Waits for finish()'s work; then the time from the first scan taken to the last optimisation's end.
  [[nodiscard]] double seconds();

 private:
  struct Node {
    std::uint8_t robot = 0;
    bool tilted = false;
    Pose2 odom;                            // the node's last scan's
    std::vector<Vec2> returns;             // in that scan's robot frame; freed once in the graph
    std::shared_ptr<const std::vector<NodeScan>> scans;  // the scans it gathers, in order (shared with the estimates)
  };
  struct Open {
    std::int64_t first_stamp_ns = 0;
    std::optional<bool> tilted;            // the robot's laser, from its first scan with points
    std::vector<Vec2> odom_returns;        // gathered so far, in the odometry's frame
    std::vector<NodeScan> scans;
  };
  void close(std::uint8_t robot);
  void run();
  // Every scan in the graph with its node's pose in `nodes` (the graph's node order).
  [[nodiscard]] std::vector<GraphScanPose> scan_poses(const std::vector<Pose2>& nodes) const;
  void publish_estimate();
  void wait_done();

  GraphBackendOptions options_;
  GraphBackendCounters counters_;
  std::vector<Open> open_;  // per robot id
  // Per robot id, the (stamp, scan number) of every scan taken, ascending: a scan released again (a
  // rebuilt core's) is found here. Releases come in stamp order, so each grows at its end.
  std::vector<std::vector<std::pair<std::int64_t, std::uint32_t>>> scans_taken_;
  std::vector<std::uint8_t> taken_;  // the returns take_planar_returns took of the scan at hand
  std::int64_t newest_taken_ns_ = INT64_MIN;  // the newest stamp of a scan taken
  bool finishing_ = false;
  std::chrono::steady_clock::time_point first_scan_, done_at_;

  std::mutex mutex_;
  std::condition_variable wake_, done_cv_;
  std::deque<Node> queue_;
  bool input_done_ = false, done_ = false, stop_ = false;
  int thread_id_ = 0, affinity_error_ = 0;

  // The graph's thread's own (read by poses() once done_).
  std::unique_ptr<posegraph::PlanarSlam> slam_;
  std::vector<Node> in_graph_;              // node k = the graph's node k (returns dropped)
  std::vector<std::size_t> graph_node_;
  std::vector<GraphScanPose> poses_;
  std::chrono::steady_clock::time_point estimated_at_;
  std::size_t estimated_nodes_ = 0;
  std::shared_ptr<const GraphEstimate> latest_;  // under mutex_
  std::thread thread_;
};

}  // namespace teamscan::fusion
