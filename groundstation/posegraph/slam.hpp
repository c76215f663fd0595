// 2-D SLAM for a team of robots (the planar counterpart of Cartographer's, Hess et al. 2016): per robot,
// local SLAM matches each scan against its current submap (refine_pose from the odometry's prediction)
// and inserts it into its two active submaps; the team's pose graph gets one node per scan, the
// inserted scans' constraints, odometry between consecutive nodes and loop closures found by the
// correlative search around the current estimate against every finished submap near it, of this robot
// or another; it is optimised every thousand nodes; at the end the kept nodes are searched again from
// their optimised poses against the finished submaps near them (any time), then optimised a last time.
// Deterministic: the closure searches run on several threads, but their closures join the graph in a
// fixed order, so the scans in the order given give the same poses to the bit, whatever the threads did.
#pragma once

#include <array>
#include <cstdint>
#include <map>
#include <memory>
#include <optional>
#include <vector>

#include "common/pose.hpp"
#include "groundstation/posegraph/grid.hpp"
#include "groundstation/posegraph/matching.hpp"
#include "groundstation/posegraph/pose_graph.hpp"

namespace teamscan::posegraph {

struct SlamOptions {
  double resolution_m = 0.03;
  double hit_sigma_m = 0.025;
  double min_range_m = 0.1;
  double max_range_m = 12.0;        // returns beyond are not inserted (and not matched): bounds a submap's grid
  int scans_per_submap = 35;        // a submap is finished after 2× this many scans
  // Scan to submap, pulled towards the odometry's prediction at 3 per metre and 1 per radian: along a
  // corridor the returns cannot tell where the robot is and the odometry's distance holds it; a turn
  // the returns tell better than wheels that slip in it.
  RefineOptions local{1.0, 3.0, 1.0, 20};
  // When the refinement leaves a scan scoring below `local_search_score` on its submap (the odometry's
  // prediction was further off than the refinement reaches: wheels slipping in a turn), local SLAM
  // searches the window around the prediction (the correlative search, as Cartographer's online
  // correlative scan matcher) and keeps what it found, refined, if that scores better. Needs a submap
  // of at least `local_search_min_scans` scans. 0: never searched.
  double local_search_score = 0.7;
  int local_search_min_scans = 10;
  // The search is a rescue from the odometry's rare misses. A robot more than `local_search_max_share`
  // of whose scans (once it has `local_search_share_after_scans`) scored below local_search_score is
  // searched no more: its scans match their submaps poorly everywhere (open spaces, few returns) and
  // the search's placements there are noise that adds up in heading (docs/slam.md "A held-out log in
  // open spaces"). 1: no limit.
  double local_search_max_share = 0.2;
  int local_search_share_after_scans = 200;
  SearchWindow local_search_window{0.3, 0.35, 0.0, 0.0};
  // A second guess for local SLAM: the robot coasting, its velocity from local SLAM's own motion
  // between its last two scans. Where its heading and the odometry's prediction's differ by more than
  // `coast_differs_rad`, the scan is refined from both and placed by the one scoring better on the
  // submap (only the heading: along a corridor the two differ in distance, score alike, and the
  // odometry's distance is the better one). Odometry that stalls (the same pose for several scans while the
  // robot turns) and then catches up in one jump of tens of degrees would otherwise put the scan's
  // guess far outside the refinement's reach and the search's window. Not tried across a gap: when
  // the time since the last scan is more than `coast_max_ratio` times, or less than 1 / it, the time
  // between the two before (a log's pause, a burst). false: the odometry's prediction only.
  bool coast_guess = true;
  double coast_differs_rad = 0.035;
  double coast_max_ratio = 2.0;
  // Loop closure: every `closure_every_n_nodes`-th node of each robot is searched against the `closure_submaps`
  // nearest finished submaps within `closure_max_distance_m` (submap origin to node).
  int closure_every_n_nodes = 6;
  int closure_submaps = 6;
  double closure_max_distance_m = 7.0;
  SearchWindow closure_window{3.0, 0.35, 0.01, 0.01};
  double closure_min_score = 0.55;  // of the search (mean grid value at the points)
  double closure_min_refined_score = 0.65;
  int closure_depth = 6;            // branch and bound levels: blocks of up to 2^6 search cells
  int closure_pool = 2;             // a search cell is pool × pool grid cells
  RefineOptions closure_refine{1.0, 0.5, 1.0, 30};
  // A closure found for a robot's node is followed: its later nodes' closures with the same submap
  // start from that closure moved by local SLAM's motion and are refined only (no search), while the
  // last one is at most this many of the robot's nodes back. 0: every closure searched.
  int closure_track_nodes = 10;
  // A robot's own submaps that took a scan within this many of its nodes are not searched.
  int closure_skip_recent_nodes = 0;
  // A node whose odometry moved less than both of these since the robot's previous node (the robot
  // stands still) is neither searched for loop closures nor kept for the second search: it sees what
  // the nodes before it saw, and a parked robot's hundreds of such closures, all sharing one match's
  // error, would outvote its odometry. It is still inserted into its submaps (its views hold the
  // headings of robots that stop). 0: every node searched.
  double still_translation_m = 0.01;
  double still_rotation_rad = 0.0087;
  // A closure's translation weight along its match's weak axis: √(weak_ratio) (MatchInformation), at
  // least this floor; 1 = isotropic weights.
  double closure_weak_axis_floor = 0.1;
  // A closure's rotation weight scaled by its match's rotation lever (MatchInformation::rotation_lever_m)
  // over this, at most 1 and at least `closure_rotation_floor`: a match whose returns hardly tell its
  // heading (a tilted laser's node beside one long wall sees a few centimetres of it) holds the heading
  // little: at full weight hundreds of such closures bend the heading of a robot whose odometry was
  // right (docs/slam.md "Rotation lever"). 0: the configured weight for every closure.
  double closure_rotation_lever_m = 3.0;
  double closure_rotation_floor = 0.1;
  int optimize_every_n_nodes = 1000;
  // At the end, a second search with the optimised estimate (as Cartographer's constraint builder
  // keeps doing): every searched node against its `rematch_submaps` nearest finished submaps (by the
  // corrected poses, any time, within closure_max_distance_m) it has no constraint with yet, in a
  // window the optimisation has made small; then the last optimisation. 0: no second search.
  // `rematch_every_n_nodes`: which of each robot's nodes (their returns are kept until the end); `rematch_rounds`:
  // optimisation and search repeated, each from the last one's estimate.
  int rematch_submaps = 10;
  int rematch_every_n_nodes = 3;
  int rematch_rounds = 1;
  SearchWindow rematch_window{0.3, 0.05, 0.01, 0.01};
  // Memory bounded by the mapped space, not by the time mapped. When a submap is finished, every older
  // finished submap with at least `retire_after_submaps` newer finished ones (of any robot, not retired)
  // whose origins lie within `retire_distance_m` of its own (by the graph's estimate) is retired: its
  // grid and search levels are freed and it is searched no more; its constraints stay in the graph. A
  // place mapped again and again keeps that many submaps. 0: none retired.
  int retire_after_submaps = 3;
  double retire_distance_m = 1.5;
  // With calibration in the graph (GraphOptions::calibrate_odometry, calibrate_local_links): a robot's
  // calibration stays at none until one of its nodes closes on a submap it started at least this far
  // back (its odometry's distance driven). 0: calibrated from the start.
  double calibration_loop_m = 0.0;
  // The second search's returns: kept for at most this many nodes per square of `rematch_cell_m` (by the
  // node's pose in the graph when it was added). 0: no limit.
  int rematch_nodes_per_cell = 64;
  double rematch_cell_m = 1.0;
  // The kept returns thinned to the first one in each square of this size in the node's frame (0: all
  // kept): a tilted laser's node holds thousands of wall returns, many in one grid cell, and a search
  // scores a cell once as well as many times.
  double rematch_thin_m = 0.03;
  // Threads for the loop-closure searches and refinements (the caller's among them). Their results
  // join the graph in a fixed order, so the poses are the same to the bit whatever this is.
  int threads = 2;
  // Every robot's first node held where its odometry put it, as the graph's first node is: the robots
  // start in the common map frame (as the station's do: their start poses are known). Otherwise only
  // the first node is held and a teammate's track floats, tied to the others by loop closures alone.
  bool anchor_robot_starts = true;
  GraphOptions graph;
};

struct SlamStats {
  std::size_t nodes = 0, submaps = 0, searches = 0, closures = 0, optimizations = 0;
  std::size_t tracked = 0;  // closures refined from a followed one, without a search
  std::size_t rematches = 0;  // closures added by the second search at the end
  std::size_t retired = 0;    // submaps retired (SlamOptions::retire_after_submaps)
  std::size_t kept_returns = 0;  // nodes whose returns are kept for the second search
  std::size_t still = 0;         // nodes not searched: their robot stood still (SlamOptions::still_translation_m)
  std::size_t memory_bytes = 0;  // the submaps' grids and search levels and the kept returns, now
  struct Calibration {
    std::uint8_t robot = 0;
    OdometryCalibration odometry;
  };
  // Each robot's odometry as the graph calibrated it (GraphOptions::calibrate_odometry), by robot id;
  // empty when not calibrated.
  std::vector<Calibration> calibrations;
  std::size_t local_searches = 0, local_found = 0;  // local SLAM's searches, and those that placed the scan (local_search_score)
  std::size_t local_declined = 0;  // scans below local_search_score not searched: their robot's share was too high (local_search_max_share)
  std::size_t coasted = 0;  // scans local SLAM placed from the robot's last motion rather than the odometry's (coast_guess)
};

// The options for tilted lasers' returns (fusion/planar_returns.hpp: a node is a robot's wall returns
// over a quarter of a second, each scan one stripe across the walls near it). Such a node sees a short new
// piece of wall past the end of what its submap holds: matched on its own, local SLAM pulls those
// returns back onto the known piece and falls behind the robot, in translation and in yaw. Local SLAM's pull towards the odometry's prediction is
// 100 per metre and 400 per radian here (3 and 1 by default): it follows the odometry over a node and corrects what the walls
// show clearly; the loop closures take out the drift (docs/slam.md "Tilted lasers"). Between such
// nodes (a few centimetres, a few degrees) local SLAM's motion, the odometry's with what the walls
// showed clearly corrected, is held at 10⁵ per metre and per radian (10⁴ by default), and the
// odometry's at 10⁴ per metre and 10⁵ per radian, its rotation less so the more it turned (σ + 0.3 %
// of the turn; the wheels slip in turns): a node's few wall returns say little about its motion on
// their own, and held less stiffly, the chain gives to its closures' shared bias along a wall they
// cannot place. So the closures take out the drift, slowly, and local SLAM gives the motion from node
// to node. Each robot's odometry is calibrated in the graph (GraphOptions::calibrate_odometry,
// calibrate_local_links): held that stiffly, a wheel slip of 2 % would otherwise swell every loop the
// robot drives by 2 %. The calibration waits for the robot's first loop (calibration_loop_m 10 m): before
// one, nothing measures it, and a free calibration only lets the graph follow local SLAM's own drift.
// With the odometry's systematic errors taken out that way, the loop closures need not pull as hard: their Huber scale is
// 5 (10 by default), which keeps good odometry from being dragged by the closures' own small biases.
[[nodiscard]] SlamOptions tilted_laser_options(SlamOptions base = {});

class PlanarSlam {
 public:
  explicit PlanarSlam(SlamOptions options = {});
  ~PlanarSlam();
  PlanarSlam(const PlanarSlam&) = delete;
  PlanarSlam& operator=(const PlanarSlam&) = delete;

  // One scan of `robot`: its time (ns, any epoch; a robot's scans in time order), its odometry
  // (map_from_robot) and its returns in the robot frame (metres). Returns the scan's node.
  std::size_t add_scan(std::uint8_t robot, std::int64_t stamp_ns, const Pose2& odometry, const std::vector<Vec2>& points);
  // The last optimisation, over every node.
  void finish();
  // Every node's pose as an optimisation now would put it, solved on a copy of the graph: the graph, its
  // next searches and its poses stay as they were (a live view between the optimisations of the graph
  // itself, which happen at fixed node counts so that the result does not depend on when this is called).
  [[nodiscard]] std::vector<Pose2> estimate() const;

  [[nodiscard]] Pose2 pose(std::size_t node) const { return graph_.nodes()[node]; }
  // The node's pose in its robot's local SLAM frame (scan-to-submap matching alone, no loop closure).
  [[nodiscard]] Pose2 local_pose(std::size_t node) const { return node_local_[node]; }
  [[nodiscard]] SlamStats stats() const;
  // The graph itself: its nodes, submaps and constraints (loop closures among them), as optimised last.
  [[nodiscard]] const PoseGraph& graph() const { return graph_; }

 private:
  struct Submap;
  struct Robot;
  Robot& robot(std::uint8_t id);
  void insert(Robot& r, std::size_t node, const Pose2& local, const std::vector<Vec2>& points);
  // Local SLAM's match of a scan on a submap from the odometry's prediction (submap frame).
  // `coast`: the robot's last motion again, a second guess (SlamOptions::coast_guess).
  [[nodiscard]] Pose2 match_locally(Robot& r, const Submap& m, const std::vector<Vec2>& points, const Pose2& odometry_guess,
                                    const std::optional<Pose2>& coast);
  void close_loops(Robot& r, std::size_t node, const std::vector<Vec2>& points);
  void retire_covered(std::size_t finished);
  [[nodiscard]] bool keep_returns(std::size_t node);
  void after_optimization();
  [[nodiscard]] std::optional<Constraint> make_closure(std::size_t submap, std::size_t node, const std::vector<Vec2>& points,
                                                      const Pose2& start) const;
  void rematch();
  // A closure of a robot's node with a submap it started at least calibration_loop_m of driving before:
  // its calibration is free from then on.
  void note_loop(const Constraint& closure);

  SlamOptions options_;
  PoseGraph graph_;
  std::vector<std::unique_ptr<Submap>> submaps_;  // index = the graph's submap index
  std::vector<std::unique_ptr<Robot>> robots_;
  std::vector<Pose2> node_local_;
  std::vector<std::uint8_t> node_robot_;
  std::vector<double> node_driven_m_;  // each node's robot's driven distance at it
  // The kept nodes' returns (empty for the others), for rematch(): single precision, thinned to one a
  // rematch_thin_m square (kept_returns()).
  std::vector<std::vector<std::array<float, 2>>> node_points_;
  std::map<std::pair<std::int64_t, std::int64_t>, int> kept_per_cell_;  // rematch_cell_m squares -> nodes kept there
  std::size_t retired_ = 0, kept_returns_ = 0;
  std::size_t searches_ = 0, tracked_ = 0, rematches_ = 0, still_ = 0;
  std::size_t local_searches_ = 0, local_found_ = 0, local_declined_ = 0, coasted_ = 0;
};

}  // namespace teamscan::posegraph
