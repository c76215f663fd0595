// The fusion core's back end, the team's pose graph (fusion/graph_backend.hpp, planar_returns.hpp), on
// a simulated team of tilted-laser robots: lap2-drift's first 40 s simulated in-process (two robots,
// one laser pitched down and one up, both drifting). No floor or ceiling return goes into the graph; its
// poses beat odometry alone by a wide margin, fed the scans directly and through `teamscan eval`'s
// fusion core; the same releases give the same poses to the bit; a level laser's scan is a node.
#include <algorithm>
#include <chrono>
#include <thread>

#include <sched.h>
#include <cmath>
#include <cstddef>
#include <cstdio>
#include <cstring>
#include <map>
#include <set>
#include <vector>

#include <gtest/gtest.h>

#include "groundstation/fusion/core.hpp"
#include "groundstation/fusion/evaluation.hpp"
#include "groundstation/fusion/graph_backend.hpp"
#include "tests/unit/fusion/level_scan.hpp"
#include "groundstation/fusion/planar_returns.hpp"
#include "groundstation/fusion/time_line.hpp"
#include "groundstation/mapping/dataset_registration.hpp"
#include "sim/scenario.hpp"
#include "sim/simulator.hpp"

namespace teamscan {
namespace {

const Dataset& lap2_drift_start() {
  static const Dataset d = [] {
    const sim::ScenarioLoad l = sim::resolve_scenario("lap2-drift");
    if (!l.scenario) {
      ADD_FAILURE() << l.error;
      return Dataset{};
    }
    sim::SimOptions o;
    o.duration_s = 40.0;
    o.device_streams = false;  // the direct path: `teamscan sim --direct`
    return sim::simulate(*l.scenario, o).dataset;
  }();
  return d;
}

const fusion::PreparedDataset& prepared() {
  static const fusion::PreparedDataset p = fusion::prepare_dataset(lap2_drift_start(), mapping::TrackerOptions{});
  return p;
}

// The scans in time order, each released with its odometry pose (the core with the registration off).
std::vector<Pose2> graph_over_odometry(const fusion::PreparedDataset& p, const Dataset& d) {
  fusion::GraphBackend backend;
  for (std::size_t s = 0; s < p.scans.size(); ++s) {
    const mapping::ScanView v = p.view(s);
    fusion::FusedScan f;
    f.view = &v;
    f.odom_from_robot = v.map_from_robot;  // no correction: the released pose is the odometry's
    backend.add(f);
  }
  std::vector<Pose2> poses(d.scans.size());
  for (std::size_t i = 0; i < d.scans.size(); ++i) poses[i] = d.scans[i].pose;
  for (const fusion::GraphScanPose& g : backend.poses())
    for (std::size_t i = 0; i < d.scans.size(); ++i)
      if (d.scans[i].robot == g.robot && d.scans[i].scan == g.scan) poses[i] = g.graph;
  EXPECT_EQ(backend.counters().scans, p.scans.size());
  EXPECT_EQ(backend.counters().tilted_scans, backend.counters().scans);
  EXPECT_LT(backend.counters().nodes, p.scans.size() / 10);  // a node gathers a quarter of a second
  return poses;
}

TEST(GraphBackendReturns, NoFloorOrCeilingReturnIsTaken) {
  const Dataset& d = lap2_drift_start();
  const fusion::PreparedDataset& p = prepared();
  ASSERT_FALSE(d.points.empty());
  for (const DatasetRobot& r : d.robots) EXPECT_FALSE(fusion::level_laser(r)) << "robot " << int{r.id};
  std::vector<std::uint8_t> taken, taken_points(d.points.size(), 0);
  fusion::PlanarReturnCounts counts;
  std::size_t level_scans = 0;
  for (std::size_t s = 0; s < p.scans.size(); ++s) {
    const mapping::ScanView v = p.view(s);
    if (v.points.size() >= 2 && fusion::level_scan(v)) ++level_scans;
    fusion::take_planar_returns(v, true, fusion::PlanarReturnOptions{}, taken, counts);
    ASSERT_EQ(taken.size(), v.points.size());
    for (std::size_t j = 0; j < taken.size(); ++j) taken_points[p.source_index[p.scans[s].first + j]] = taken[j];
  }
  EXPECT_EQ(level_scans, 0u);  // a tilted laser's stripe is never taken for a level scan
  std::size_t floor_points = 0, floor_taken = 0, ceiling_taken = 0, wall_points = 0, wall_taken = 0, teammate_points = 0,
              teammate_taken = 0;
  for (std::size_t i = 0; i < d.points.size(); ++i) {
    const LabelledPoint& pt = d.points[i];
    if (pt.label == PointClass::floor) {
      ++floor_points;
      floor_taken += taken_points[i];
    }
    if (pt.label == PointClass::ceiling) ceiling_taken += taken_points[i];
    if (pt.label == PointClass::robot) {
      ++teammate_points;
      teammate_taken += taken_points[i];
    }
    if (pt.label == PointClass::wall) {
      ++wall_points;
      wall_taken += taken_points[i];
    }
  }
  EXPECT_GT(floor_points, 1000u);  // the down-laser sweeps the floor: there is floor to leave out
  EXPECT_EQ(floor_taken, 0u);
  EXPECT_EQ(ceiling_taken, 0u);
  // The walls are what the graph is made of: most of their returns are taken.
  EXPECT_GT(wall_taken, wall_points / 2);
  EXPECT_EQ(counts.kept + counts.flagged + counts.teammates + counts.out_of_band, p.points.size());
  // The teammate in view: its body's returns are left out.
  EXPECT_GT(counts.teammates, 0u);
  EXPECT_GT(teammate_points, 100u);
  EXPECT_LT(teammate_taken, teammate_points / 10);
  std::printf("teammate returns: %zu, taken %zu; %llu returns left out as inside a teammate's body\n", teammate_points, teammate_taken,
              static_cast<unsigned long long>(counts.teammates));
}

TEST(GraphBackend, BeatsOdometryAloneAndIsDeterministic) {
  const Dataset& d = lap2_drift_start();
  ASSERT_FALSE(d.truth.empty());
  const std::vector<Pose2> poses = graph_over_odometry(prepared(), d);
  ASSERT_EQ(poses.size(), d.scans.size());
  mapping::ErrorStats odo_m, odo_deg, graph_m, graph_deg, points;
  mapping::measure_errors(d, odo_m, odo_deg, points);
  mapping::measure_errors(d, graph_m, graph_deg, points, {}, poses);
  // Odometry alone drifts by tens of centimetres and several degrees in 40 s; the graph holds both
  // robots to a fraction of that.
  EXPECT_GT(odo_m.p99, 0.15);
  EXPECT_LT(graph_m.p99, 0.5 * odo_m.p99) << "graph p99 " << graph_m.p99 << " m, odometry " << odo_m.p99 << " m";
  EXPECT_LT(graph_deg.p99, 0.5 * odo_deg.p99) << "graph p99 " << graph_deg.p99 << "°, odometry " << odo_deg.p99 << "°";
  EXPECT_LT(graph_m.max, 0.15);
  // The same releases in the same order: the same poses to the bit (the searches ran on two threads).
  const std::vector<Pose2> again = graph_over_odometry(prepared(), d);
  ASSERT_EQ(again.size(), poses.size());
  EXPECT_EQ(std::memcmp(again.data(), poses.data(), poses.size() * sizeof(Pose2)), 0);
}

// An estimate holds the graph's nodes, their scans shared with the back end and with the estimates
// before it (a node's worth per node, not a pose per scan, however long the robots mapped), and gives
// each scan of those nodes its pose when asked: every scan once, in node order, each robot's newest where
// newest_scans() says. Once the robots stop and the graph took every node, the last estimate's scans are
// every scan the back end took.
TEST(GraphBackend, AnEstimateSharesItsNodesScansAndGivesEveryScansPose) {
  const fusion::PreparedDataset& p = prepared();
  fusion::GraphBackendOptions o;
  o.estimate_every_s = 1e-9;  // an estimate at every node
  fusion::GraphBackend backend(o);
  for (std::size_t s = 0; s < p.scans.size(); ++s) {
    const mapping::ScanView v = p.view(s);
    fusion::FusedScan f;
    f.view = &v;
    f.odom_from_robot = v.map_from_robot;
    backend.add(f);
  }
  std::shared_ptr<const fusion::GraphEstimate> first;
  for (int i = 0; i < 6000 && !first; ++i) {
    first = backend.latest();
    if (!first) std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  ASSERT_NE(first, nullptr) << "no estimate within a minute";
  const std::vector<fusion::GraphScanPose> all = backend.poses();  // finish(): the last node closed and taken
  const std::shared_ptr<const fusion::GraphEstimate> last = backend.latest();
  ASSERT_NE(last, nullptr);
  ASSERT_GE(last->graph_nodes.size(), first->graph_nodes.size());
  for (std::size_t k = 0; k < first->graph_nodes.size(); ++k)
    ASSERT_EQ(first->graph_nodes[k].scans, last->graph_nodes[k].scans) << "node " << k << "'s scans copied, not shared";
  const std::vector<fusion::GraphScanPose> poses = last->poses();
  std::size_t scans = 0;
  for (const fusion::EstimateNode& n : last->graph_nodes) scans += n.scans->size();
  EXPECT_EQ(poses.size(), scans);
  EXPECT_GT(poses.size(), p.scans.size() / 2);
  EXPECT_LE(poses.size(), all.size());
  std::set<std::pair<std::uint8_t, std::uint32_t>> keys;
  for (std::size_t i = 0; i < poses.size(); ++i) {
    EXPECT_TRUE(keys.emplace(poses[i].robot, poses[i].scan).second) << "a scan twice";
    EXPECT_EQ(poses[i].robot, all[i].robot);  // the back end's order: its nodes' in the order they closed
    EXPECT_EQ(poses[i].scan, all[i].scan);
  }
  const auto newest = last->newest_scans();
  for (std::uint8_t r : {std::uint8_t{1}, std::uint8_t{2}}) {
    const fusion::GraphScanPose* want = nullptr;
    for (const fusion::GraphScanPose& g : poses)
      if (g.robot == r && (want == nullptr || g.stamp_ns >= want->stamp_ns)) want = &g;
    ASSERT_NE(want, nullptr) << unsigned(r);
    ASSERT_TRUE(newest[r].has_value()) << unsigned(r);
    EXPECT_EQ(newest[r]->scan, want->scan) << unsigned(r);
    EXPECT_EQ(newest[r]->graph, want->graph) << unsigned(r) << ": to the bit, as poses() works it out";
    EXPECT_EQ(newest[r]->odom, want->odom) << unsigned(r);
  }
  EXPECT_FALSE(newest[3].has_value());
}

// `teamscan eval --pose-graph --registration`: the back end rides on the registered run's releases,
// taken back into the odometry's frame with the teammates where their odometry puts them: the graph is
// the one an unregistered run gives, to the bit.
TEST(GraphBackend, ThroughTheEvaluationWhateverCorrectedTheReleases) {
  const Dataset& d = lap2_drift_start();
  fusion::EvalOptions o;
  const auto methods = fusion::parse_methods("direction", std::nullopt, 7.0);
  ASSERT_TRUE(methods) << methods.error().what;
  o.methods = methods.value();
  o.registration = true;
  o.pose_graph = fusion::GraphBackendOptions{};
  const Result<fusion::EvalReport> r = fusion::evaluate(d, o);
  ASSERT_TRUE(r) << r.error().what;
  const fusion::EvalReport& report = r.value();
  ASSERT_EQ(report.graph_poses.size(), d.scans.size());
  EXPECT_EQ(report.graph_counters.scans, d.scans.size());
  EXPECT_GT(report.graph_stats.closures, 0u);
  mapping::ErrorStats odo_m, odo_deg, graph_m, graph_deg, points;
  mapping::measure_errors(d, odo_m, odo_deg, points);
  mapping::measure_errors(d, graph_m, graph_deg, points, {}, report.graph_poses);
  EXPECT_LT(graph_m.p99, 0.5 * odo_m.p99) << "graph p99 " << graph_m.p99 << " m, odometry " << odo_m.p99 << " m";
  EXPECT_LT(graph_deg.p99, 0.5 * odo_deg.p99);
  EXPECT_LT(graph_m.max, 0.15);
  EXPECT_GT(report.graph_counters.returns.teammates, 0u);

  o.registration = false;
  const Result<fusion::EvalReport> odometry = fusion::evaluate(d, o);
  ASSERT_TRUE(odometry) << odometry.error().what;
  ASSERT_EQ(odometry->graph_poses.size(), report.graph_poses.size());
  for (std::size_t i = 0; i < report.graph_poses.size(); ++i) {
    const Pose2& a = report.graph_poses[i];
    const Pose2& b = odometry->graph_poses[i];
    ASSERT_TRUE(a.x_m == b.x_m && a.y_m == b.y_m && a.theta_rad == b.theta_rad) << "scan row " << i;
  }
  EXPECT_EQ(odometry->graph_counters.returns.teammates, report.graph_counters.returns.teammates);
}

// What the graph is given does not depend on the corrections the core applies (the registration's, or
// the graph's own once the map follows it): a core whose robots carry large corrections (each its own,
// so the teammates move relative to one another in the map) releases the same returns in the
// odometry's frame, with the same teammates left out, as a core with none; the graphs are the same to
// the bit.
TEST(GraphBackend, TheCorrectionsInForceChangeNothingOfWhatItIsGiven) {
  const Dataset& d = lap2_drift_start();
  fusion::CoreOptions co;
  co.method = "direction";
  co.max_points_per_voxel = 0;
  co = fusion::with_graph_order(co);
  std::vector<fusion::GraphScanPose> poses[2];
  fusion::GraphBackendCounters counters[2];
  for (int k = 0; k < 2; ++k) {
    auto core = fusion::FusionCore::create(co);
    ASSERT_TRUE(core.ok()) << core.error().what;
    if (k == 1) {
      for (const DatasetRobot& r : d.robots)
        (*core)->poses().set_map_from_odom(r.id, d.scans.front().stamp_ns - 1'000'000'000,
                                           Pose2{0.4 * r.id, -0.3 * r.id, 0.05 * r.id});
    }
    fusion::GraphBackend backend;
    (*core)->set_release_callback([&](const fusion::FusedScan& f) { backend.add(f); });
    fusion::feed_in_time_order(d, **core);
    poses[k] = backend.poses();
    counters[k] = backend.counters();
  }
  EXPECT_EQ(counters[0].scans, d.scans.size());
  EXPECT_GT(counters[0].returns.teammates, 0u);
  EXPECT_EQ(counters[1].returns.teammates, counters[0].returns.teammates);
  EXPECT_EQ(counters[1].returns.kept, counters[0].returns.kept);
  ASSERT_EQ(poses[1].size(), poses[0].size());
  for (std::size_t i = 0; i < poses[0].size(); ++i) {
    const Pose2& a = poses[0][i].graph;
    const Pose2& b = poses[1][i].graph;
    ASSERT_TRUE(a.x_m == b.x_m && a.y_m == b.y_m && a.theta_rad == b.theta_rad) << "scan " << i;
  }
}

// `teamscan eval --pose-graph`: the graph's poses then place every scan of every method's run, so the
// cloud the metrics read, and the decisions on it, follow the graph.
TEST(GraphBackend, TheEvaluationsCloudFollowsTheGraph) {
  const Dataset& d = lap2_drift_start();
  fusion::EvalOptions o;
  const auto methods = fusion::parse_methods("frequency", 0.1, std::nullopt);
  ASSERT_TRUE(methods) << methods.error().what;
  o.methods = methods.value();
  o.pose_graph = fusion::GraphBackendOptions{};
  const Result<fusion::EvalReport> r = fusion::evaluate(d, o);
  ASSERT_TRUE(r) << r.error().what;
  const fusion::EvalReport& report = r.value();
  const mapping::RegistrationReport& g = report.registration;
  EXPECT_TRUE(g.by_graph);
  EXPECT_FALSE(g.enabled);
  ASSERT_EQ(report.graph_poses.size(), d.scans.size());
  ASSERT_EQ(report.scan_poses.size(), d.scans.size());
  // Each scan decided with its graph pose (up to the odometry's interpolation between its samples)...
  std::size_t decided = 0;
  double worst_m = 0.0, worst_rad = 0.0;
  for (std::size_t i = 0; i < d.scans.size(); ++i) {
    if (!report.scan_decided[i]) continue;
    ++decided;
    const Pose2 a = report.scan_poses[i], b = report.graph_poses[i];
    worst_m = std::max(worst_m, std::hypot(a.x_m - b.x_m, a.y_m - b.y_m));
    worst_rad = std::max(worst_rad, std::abs(normalize_angle(a.theta_rad - b.theta_rad)));
  }
  EXPECT_GT(decided, d.scans.size() * 9 / 10);
  EXPECT_LT(worst_m, 0.01) << "scan pose vs graph pose";
  EXPECT_LT(worst_rad, 0.002);
  // ...and its points moved with it: each point where the graph's pose puts it.
  std::map<std::pair<std::uint8_t, std::uint32_t>, std::size_t> row_of;
  for (std::size_t i = 0; i < d.scans.size(); ++i) row_of.emplace(std::make_pair(d.scans[i].robot, d.scans[i].scan), i);
  std::size_t checked = 0;
  for (std::size_t k = 0; k < d.points.size(); k += 97) {
    const LabelledPoint& p = d.points[k];
    const auto it = row_of.find({p.robot, p.scan});
    if (it == row_of.end() || !report.scan_decided[it->second]) continue;
    const Pose2 move = report.graph_poses[it->second] * d.scans[it->second].pose.inverse();
    const Vec2 expected = move.apply(Vec2{p.x, p.y});
    EXPECT_NEAR(report.placed[k].x, expected.x, 1e-3) << "point " << k;
    EXPECT_NEAR(report.placed[k].y, expected.y, 1e-3) << "point " << k;
    EXPECT_FLOAT_EQ(report.placed[k].z, p.z);
    ++checked;
  }
  EXPECT_GT(checked, 1000u);
  // The cloud the metrics read is the graph's: points and revisits far closer to the truth than
  // odometry's.
  EXPECT_LT(g.point_m_after.p99, 0.5 * g.point_m_before.p99) << g.point_m_after.p99 << " m vs " << g.point_m_before.p99;
  EXPECT_LT(g.consistency_after.median_m, 0.5 * g.consistency_before.median_m);
}

// The graph's thread stays below a station's loop: SCHED_BATCH, nice 10, on the CPUs it is given.
TEST(GraphBackend, ItsThreadRunsBatchAtNiceTenOnItsCpus) {
  fusion::GraphBackendOptions o;
  o.cpus = {0};
  fusion::GraphBackend backend(o);
  fusion::GraphThreadPlacement p;
  for (int i = 0; i < 200 && p.scheduling.policy == -1; ++i) {
    p = backend.placement();
    if (p.scheduling.policy == -1) std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  EXPECT_EQ(p.affinity_error, 0);
  EXPECT_EQ(p.scheduling.policy, SCHED_BATCH);
  EXPECT_EQ(p.scheduling.nice, 10);
  EXPECT_EQ(p.scheduling.cpus, (std::vector<int>{0}));
}

// Robot 1's level laser, its k-th scan of a 4 m × 3 m room (its corner at (-1, -1)) from `truth`
// (heading 0) released where `odometry` (heading 0) puts it.
void add_room_scan(fusion::GraphBackend& backend, int k, const Pose2& truth, const Pose2& odometry) {
  std::vector<mapping::MapPoint> points;
  for (int b = 0; b < 360; ++b) {
    const double a = b * M_PI / 180.0, c = std::cos(a), sn = std::sin(a);
    const double tx = std::abs(c) < 1e-9 ? 1e9 : ((c > 0 ? 3.0 : -1.0) - truth.x_m) / c;
    const double ty = std::abs(sn) < 1e-9 ? 1e9 : ((sn > 0 ? 2.0 : -1.0) - truth.y_m) / sn;
    const double r = std::min(tx, ty);
    points.push_back({static_cast<float>(odometry.x_m + r * c), static_cast<float>(odometry.y_m + r * sn), 0.3f});
  }
  fusion::testing::add_level_scan(backend, k, odometry, points);
}

// A level laser (an imported 2-D log): every scan its own node, none tilted.
TEST(GraphBackend, ALevelLasersScanIsANode) {
  fusion::GraphBackend backend;
  for (int k = 0; k < 20; ++k) add_room_scan(backend, k, {0.05 * k, 0.0, 0.0}, {0.05 * k, 0.0, 0.0});
  const std::vector<fusion::GraphScanPose>& poses = backend.poses();
  EXPECT_EQ(backend.counters().nodes, 20u);
  EXPECT_EQ(backend.counters().tilted_scans, 0u);
  EXPECT_EQ(backend.counters().returns.kept, 20u * 360u);
  ASSERT_EQ(poses.size(), 20u);
  for (std::size_t k = 0; k < poses.size(); ++k) {
    EXPECT_EQ(poses[k].scan, k);
    EXPECT_NEAR(poses[k].graph.x_m, 0.05 * static_cast<double>(k), 0.02);
    EXPECT_NEAR(poses[k].graph.y_m, 0.0, 0.02);
  }
}

// A level laser's graph takes GraphBackendOptions::level (`teamscan eval --pose-graph-local-search-score`
// and the like): the same room, its wheels slipping 25 cm at the thirteenth scan, searched for by local
// SLAM with the defaults and not with the search off (add_room_scan).
TEST(GraphBackend, ALevelLasersGraphTakesTheLevelOptions) {
  const auto run = [](const fusion::GraphBackendOptions& o) {
    fusion::GraphBackend backend(o);
    for (int k = 0; k < 24; ++k) add_room_scan(backend, k, {0.05 * k, 0.0, 0.0}, {0.05 * k + (k >= 12 ? 0.25 : 0.0), 0.0, 0.0});
    (void)backend.poses();
    return backend.graph_stats();
  };
  const posegraph::SlamStats searched = run({});
  EXPECT_GT(searched.local_searches, 0u) << "the slip leaves the scan below the search's score";
  EXPECT_GT(searched.local_found, 0u);
  fusion::GraphBackendOptions off;
  off.level.local_search_score = 0.0;
  const posegraph::SlamStats not_searched = run(off);
  EXPECT_EQ(not_searched.nodes, searched.nodes);
  EXPECT_EQ(not_searched.local_searches, 0u);
}

// The odometry turns 10 % too much and drives 2 % too far; the graph puts each node where the robot
// was at the node's last scan. Every scan of a robot's later node is then where the robot was to
// first order, its first scans included; carried back by the odometry from the node's last scan alone,
// the first scan of a node would be off by the node's whole odometry error. Two robots, interleaved:
// each spreads over its own previous node.
TEST(GraphBackendScanPoses, TheCorrectionIsSpreadOverTheNodesScans) {
  constexpr double kTurnRadps = 1.0, kSpeedMps = 0.5;
  const auto truth = [](double t, double side) { return Pose2{kSpeedMps * t, side, side * kTurnRadps * t}; };
  const auto odometry = [](double t, double side) { return Pose2{1.02 * kSpeedMps * t, side, side * 1.1 * kTurnRadps * t}; };
  constexpr int kScansPerNode = 19, kNodes = 4;
  constexpr double kScanS = 1.0 / 75.0;
  std::vector<std::vector<fusion::NodeScan>> scans(2 * kNodes);
  std::vector<fusion::NodeScans> nodes;
  for (int k = 0; k < kNodes; ++k)
    for (int robot = 1; robot <= 2; ++robot) {
      const double side = robot == 1 ? 1.0 : -1.0;
      std::vector<fusion::NodeScan>& mine = scans[static_cast<std::size_t>(2 * k + robot - 1)];
      for (int i = 0; i < kScansPerNode; ++i) {
        const int n = k * kScansPerNode + i;
        const double t = n * kScanS;
        mine.push_back({static_cast<std::uint32_t>(n), static_cast<std::int64_t>(std::llround(t * 1e9)), odometry(t, side)});
      }
      const double t_last = (k * kScansPerNode + kScansPerNode - 1) * kScanS;
      nodes.push_back({static_cast<std::uint8_t>(robot), odometry(t_last, side), truth(t_last, side), mine});
    }
  const std::vector<fusion::GraphScanPose> placed = fusion::scan_poses_on_nodes(nodes);
  ASSERT_EQ(placed.size(), static_cast<std::size_t>(2 * kNodes * kScansPerNode));
  double worst_later_m = 0, worst_later_rad = 0, worst_first_rad = 0;
  for (const fusion::GraphScanPose& p : placed) {
    const double side = p.robot == 1 ? 1.0 : -1.0;
    const Pose2 e = truth(static_cast<double>(p.stamp_ns) * 1e-9, side).inverse() * p.graph;
    const bool first_node = p.scan < static_cast<std::uint32_t>(kScansPerNode);
    (first_node ? worst_first_rad : worst_later_rad) = std::max(first_node ? worst_first_rad : worst_later_rad, std::abs(e.theta_rad));
    if (!first_node) worst_later_m = std::max(worst_later_m, std::hypot(e.x_m, e.y_m));
    if ((p.scan + 1) % kScansPerNode == 0) {  // a node's last scan: the node's pose
      const Pose2 node = truth(static_cast<double>(p.stamp_ns) * 1e-9, side);
      EXPECT_NEAR(p.graph.x_m, node.x_m, 1e-9);
      EXPECT_NEAR(p.graph.theta_rad, node.theta_rad, 1e-9);
    }
  }
  // A node spans 0.24 s: 0.024 rad of turn error over it, which the first node's first scan keeps.
  EXPECT_GT(worst_first_rad, 0.02);
  EXPECT_LT(worst_later_rad, 1e-6);  // the turn error grows with time: spread linearly, it is gone
  EXPECT_LT(worst_later_m, 1e-3);
}

}  // namespace
}  // namespace teamscan
