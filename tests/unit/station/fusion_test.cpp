// FusionStage fed directly (no DDS) with a small survey: for every method, the model written from the
// core's memory gives every point the decision `teamscan eval` gives it (the core fed in time order),
// whatever order the poses and scans arrive in; the model write is atomic; the teamscan/map voxels
// account for every point; the wire flags map to the data set's; the [fusion] config keys parse.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <deque>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iterator>
#include <map>
#include <memory>
#include <set>
#include <thread>
#include <numeric>

#include <pthread.h>
#include <sched.h>
#include <sys/resource.h>
#include <sys/syscall.h>
#include <unistd.h>

#include "common/dataset/pcd.hpp"
#include "common/scan_points.hpp"
#include "groundstation/fusion/evaluation.hpp"
#include "groundstation/station/config.hpp"
#include "groundstation/station/fusion.hpp"
#include "groundstation/station/pose_history_team_source.hpp"
#include "groundstation/station/station.hpp"
#include "groundstation/trajectory/tum.hpp"
#include "onboard/bridge/bridge.hpp"
#include "onboard/core/pipeline.hpp"
#include "onboard/core/team_validation.hpp"
#include "teamscan.h"
#include "tests/bench/mapping/synthetic_survey.hpp"
#include "tests/support/odometry_drift.hpp"
#include "tests/support/onboard_config_fixture.hpp"

namespace teamscan::station {
namespace {

std::int32_t mm(double m) { return static_cast<std::int32_t>(std::lround(m * 1000.0)); }

// The registration as these tests run it: a short window, frequent matches, a small map to start from.
fusion::CoreRunOptions registered_run() {
  fusion::CoreRunOptions run;
  run.registration = true;
  run.registration_options.window_s = 1.0;
  run.registration_options.match_every_s = 0.3;
  run.registration_options.min_map_features = 20;
  return run;
}

// A survey already on the millimetre grid, so the stage sees exactly the data set's values.
// `drift_robot`: that robot's odometry (poses, scan origins and points) drifts from the truth by a
// growing (x, y, yaw) per second, about the room's centre, so the registration has something to correct.
Dataset survey(double duration_s = 3.0, std::uint8_t drift_robot = 0) {
  bench::SurveyOptions o;
  o.duration_s = duration_s;
  o.room_m = 6.0;
  o.seed = 3;
  Dataset d = bench::synthetic_survey(o);
  if (drift_robot != 0) test::add_odometry_drift(d, drift_robot);
  for (LabelledPoint& p : d.points) {
    p.x = static_cast<float>(mm(p.x) * 1e-3);
    p.y = static_cast<float>(mm(p.y) * 1e-3);
    p.z = static_cast<float>(mm(p.z) * 1e-3);
  }
  for (ScanRecord& r : d.scans) r.origin = {mm(r.origin.x) * 1e-3, mm(r.origin.y) * 1e-3, mm(r.origin.z) * 1e-3};
  // Odometry with zero speed and on the mm/µrad grid, so the extrapolated own pose is the pose itself.
  for (TrajectorySample& s : d.odom) {
    s.pose = Pose2{mm(s.pose.x_m) * 1e-3, mm(s.pose.y_m) * 1e-3, std::lround(s.pose.theta_rad * 1e6) * 1e-6};
    s.v_mps = 0;
    s.w_radps = 0;
  }
  for (ScanRecord& r : d.scans) {
    for (const TrajectorySample& s : d.odom)
      if (s.robot == r.robot && s.stamp_ns == r.stamp_ns) r.pose = s.pose;
  }
  return d;
}

PoseObservation pose_observation(const TrajectorySample& s, std::int64_t received_ns) {
  PoseObservation p;
  p.robot_id = s.robot;
  p.stamp = Time::from_ns(s.stamp_ns);
  p.received = Time::from_ns(received_ns);
  p.x_m = s.pose.x_m;
  p.y_m = s.pose.y_m;
  p.yaw_rad = s.pose.theta_rad;
  return p;
}

// Feeds the stage as the robots send it. `pose_delay` > 0: every pose arrives that many scans late
// (after scans stamped later than it), so the core must hold those scans for their team state.
// `after_scan(arrival_ns)`: called after each scan is handed over.
// `robot2_scan_delay` > 0: robot 2's scans arrive that many scans late (after robot 1's later-stamped
// scans, as over a slower link).
void feed(FusionStage& stage, const Dataset& d, std::size_t pose_delay = 0,
          const std::function<void(std::int64_t)>& after_scan = {}, std::size_t robot2_scan_delay = 0) {
  static ScanPoints scan;
  std::size_t next_odom = 0;
  std::vector<const TrajectorySample*> late;
  std::int64_t clock_ns = 0;
  std::deque<std::unique_ptr<ScanPoints>> late_scans;  // robot 2's, waiting
  auto hand_over = [&](const ScanPoints& sc) {
    Receipt receipt;
    receipt.recv_realtime_ns = clock_ns;
    stage.add_scan(sc, receipt);
    if (after_scan) after_scan(clock_ns);
  };
  for (const ScanRecord& r : d.scans) {
    while (next_odom < d.odom.size() && d.odom[next_odom].stamp_ns <= r.stamp_ns) late.push_back(&d.odom[next_odom++]);
    while (late.size() > pose_delay * 2) {  // ~pose_delay scans late (two robots)
      clock_ns = std::max(clock_ns, late.front()->stamp_ns);
      stage.add_pose(pose_observation(*late.front(), clock_ns));
      late.erase(late.begin());
    }
    scan = ScanPoints{};
    scan.robot_id = r.robot;
    scan.seq = r.scan;
    scan.stamp = Time::from_ns(r.stamp_ns);
    clock_ns = std::max(clock_ns, r.stamp_ns);
    scan.origin_x_mm = mm(r.origin.x);
    scan.origin_y_mm = mm(r.origin.y);
    scan.origin_z_mm = mm(r.origin.z);
    for (const LabelledPoint& p : d.points) {
      if (p.robot != r.robot || p.scan != r.scan) continue;
      scan.points[scan.count++] = ScanPoint{mm(p.x), mm(p.y), mm(p.z), p.beam, 0};
    }
    // One beam without an echo: stored by the station, never part of the model.
    scan.points[scan.count++] = ScanPoint{0, 0, 0, 400, kPointInvalid};
    if (robot2_scan_delay > 0 && r.robot == 2) {
      late_scans.push_back(std::make_unique<ScanPoints>(scan));
    } else {
      hand_over(scan);
      if (late_scans.size() > robot2_scan_delay / 2) {  // robot 1's scans pass it: about the delay in scans
        hand_over(*late_scans.front());
        late_scans.pop_front();
      }
    }
  }
  for (auto& sc : late_scans) hand_over(*sc);
  for (const TrajectorySample* s : late) stage.add_pose(pose_observation(*s, clock_ns));
  while (next_odom < d.odom.size()) stage.add_pose(pose_observation(d.odom[next_odom++], clock_ns));
  stage.flush();
}

std::string temp_dir() {
  char tmpl[] = "/tmp/teamscan-station-fusion-XXXXXX";
  return ::mkdtemp(tmpl);
}

class FusionMethods : public ::testing::TestWithParam<const char*> {};

// The station's model (the core fed in arrival order, poses late) gives every point the decision of
// `teamscan eval` (the core fed the data set in time order), bit for bit, and so does the filter run
// scan by scan in the old offline order (observe all, then classify all).
TEST_P(FusionMethods, ModelDecisionsEqualEvalWhateverTheArrivalOrder) {
  const Dataset d = survey();
  for (std::size_t pose_delay : {std::size_t{0}, std::size_t{3}}) {
    const std::string dir = temp_dir();
    FusionOptions o;
    o.core.method = GetParam();
    o.core.max_points_per_voxel = 100000;  // every point in the model
    o.all_points_pcd = "fused_all.pcd";
    auto stage = FusionStage::create(o, dir);
    ASSERT_TRUE(stage.ok());
    feed(**stage, d, pose_delay);
    EXPECT_EQ((*stage)->counters().points, d.points.size());  // the invalid beams are not points
    EXPECT_EQ((*stage)->core().held_scans(), 0u);
    EXPECT_EQ((*stage)->core().counters().scans_forced, 0u);  // released by the poses, never by hold_s

    const std::vector<std::uint8_t> eval =
        fusion::decide_through_core(d, o.core.method, o.core.methods, o.core.tracker).value();
    const fusion::PreparedDataset prepared = fusion::prepare_dataset(d, o.core.tracker);
    auto filter = mapping::make_filter(o.core.method, o.core.methods);
    const std::vector<std::uint8_t> offline = fusion::run_offline(prepared, *filter);
    ASSERT_EQ(eval, offline);

    ASSERT_TRUE((*stage)->write_model().ok());
    auto all = read_pcd(dir + "/fused_all.pcd");
    ASSERT_TRUE(all.ok());
    ASSERT_EQ(all->size(), d.points.size());
    const int fr = all->field("robot"), fs = all->field("scan"), fb = all->field("beam"), fk = all->field("keep");
    ASSERT_GE(fk, 0);
    std::map<std::tuple<int, std::uint32_t, int>, std::uint8_t> decided;
    for (std::size_t i = 0; i < all->size(); ++i) {
      auto col = [&](int f) { return all->columns[static_cast<std::size_t>(f)][i]; };
      decided[{static_cast<int>(col(fr)), static_cast<std::uint32_t>(col(fs)), static_cast<int>(col(fb))}] = col(fk) == 0.0 ? 1 : 0;
    }
    std::size_t removed = 0;
    for (std::size_t i = 0; i < d.points.size(); ++i) {
      ASSERT_EQ((decided[{d.points[i].robot, d.points[i].scan, d.points[i].beam}]), eval[i]) << "point " << i << " pose_delay " << pose_delay << " robot " << int(d.points[i].robot) << " scan " << d.points[i].scan;
      removed += eval[i];
    }
    EXPECT_GT(removed, 0u);
    auto kept = read_pcd(dir + "/fused.pcd");
    ASSERT_TRUE(kept.ok());
    EXPECT_EQ(kept->size(), d.points.size() - removed);
    EXPECT_FALSE(std::filesystem::exists(dir + "/fused.pcd.tmp"));
    std::filesystem::remove_all(dir);
  }
}

// The decision lag (fusion.team_lag_s): the team at a scan's stamp t comes from poses stamped <= t - lag,
// so with a lag of a pose period a scan whose poses come in time order is decided on arrival instead of
// waiting for every robot's next pose; and the decisions still equal eval's (the same lag) whatever the
// arrival order.
TEST_P(FusionMethods, DecisionLagDecidesOnArrivalAndStillEqualsEval) {
  // Poses at a fraction of the scan rate, as a Pioneer's SIPs (10 Hz) against the laser's 75 Hz.
  Dataset d = survey();
  {
    std::vector<TrajectorySample> thinned;
    std::map<std::uint8_t, std::size_t> n;
    for (const TrajectorySample& s : d.odom)
      if (n[s.robot]++ % 8 == 0) thinned.push_back(s);
    d.odom = thinned;
  }
  double pose_period_s = 1.0;
  for (std::size_t i = 1; i < d.odom.size(); ++i)
    if (d.odom[i].robot == d.odom[i - 1].robot)
      pose_period_s = std::min(pose_period_s, static_cast<double>(d.odom[i].stamp_ns - d.odom[i - 1].stamp_ns) * 1e-9);
  for (double lag_s : {0.0, 1.5 * pose_period_s}) {
    for (std::size_t pose_delay : {std::size_t{0}, std::size_t{1}}) {  // on time; a pose period late
      const std::string dir = temp_dir();
      FusionOptions o;
      o.pose_graph.reset();  // the lag decides a scan on arrival; a graph's core releases in stamp order
      o.core.method = GetParam();
      o.core.max_points_per_voxel = 100000;
      o.core.tracker.team_lag_s = lag_s;
      o.all_points_pcd = "fused_all.pcd";
      auto stage = FusionStage::create(o, dir);
      ASSERT_TRUE(stage.ok());
      std::int64_t first_ns = INT64_MIN;
      std::size_t held_after_startup = 0;  // scans still held right after arriving, past the start-up hold
      feed(**stage, d, pose_delay, [&](std::int64_t arrival_ns) {
        if (first_ns == INT64_MIN) first_ns = arrival_ns;
        if (arrival_ns - first_ns > static_cast<std::int64_t>((o.core.hold_s + 0.1) * 1e9))
          held_after_startup += (*stage)->core().held_scans();
      });
      if (pose_delay == 0 && lag_s > 0) {
        EXPECT_EQ(held_after_startup, 0u) << "lag " << lag_s;
      }
      if (pose_delay == 0 && lag_s == 0) {
        EXPECT_GT(held_after_startup, 0u);  // each waits for the next poses
      }
      // (The scans after the last pose are released by the final flush: forced, as offline.)

      const std::vector<std::uint8_t> eval = fusion::decide_through_core(d, o.core.method, o.core.methods, o.core.tracker).value();
      ASSERT_TRUE((*stage)->write_model().ok());
      auto all = read_pcd(dir + "/fused_all.pcd");
      ASSERT_TRUE(all.ok());
      ASSERT_EQ(all->size(), d.points.size());
      const int fr = all->field("robot"), fs = all->field("scan"), fb = all->field("beam"), fk = all->field("keep");
      std::map<std::tuple<int, std::uint32_t, int>, std::uint8_t> decided;
      for (std::size_t i = 0; i < all->size(); ++i) {
        auto col = [&](int f) { return all->columns[static_cast<std::size_t>(f)][i]; };
        decided[{static_cast<int>(col(fr)), static_cast<std::uint32_t>(col(fs)), static_cast<int>(col(fb))}] = col(fk) == 0.0 ? 1 : 0;
      }
      for (std::size_t i = 0; i < d.points.size(); ++i)
        ASSERT_EQ((decided[{d.points[i].robot, d.points[i].scan, d.points[i].beam}]), eval[i]) << "point " << i << " lag " << lag_s;
      std::filesystem::remove_all(dir);
    }
  }
}

INSTANTIATE_TEST_SUITE_P(AllMethods, FusionMethods,
                         ::testing::Values("frequency", "visibility", "position", "direction", "combined", "tracked",
                                           "freespace", "best"));

// Registration on (CoreOptions::registration): robot 2's odometry drifts; the core corrects it from the
// matches, and the station's model (poses late, arrival order) still decides every point as
// `teamscan eval --registration` (the core fed in time order), bit for bit; the corrected poses are
// closer to the truth than the odometry.
TEST(FusionRegistration, ModelDecisionsEqualEvalWithRegistrationOn) {
  const Dataset d = survey(12.0, 2);
  fusion::CoreRunOptions run = registered_run();
  for (const char* method : {"best", "position"}) {
    const fusion::CoreRun eval = fusion::run_through_core(d, method, mapping::MethodOptions{}, run).value();
    ASSERT_EQ(eval.robots.size(), 2u);
    EXPECT_GT(eval.robots[1].accepted, 3u) << method;
    // The drifting robot's scans: pose error as the core placed them against odometry alone.
    double before = 0, after = 0;
    std::size_t n = 0;
    for (std::size_t i = 0; i < d.scans.size(); ++i) {
      const ScanRecord& r = d.scans[i];
      if (r.robot != 2 || r.stamp_ns < 8'000'000'000 || !eval.scan_decided[i]) continue;
      before += std::hypot(r.pose.x_m - r.true_pose.x_m, r.pose.y_m - r.true_pose.y_m);
      after += std::hypot(eval.scan_poses[i].x_m - r.true_pose.x_m, eval.scan_poses[i].y_m - r.true_pose.y_m);
      ++n;
    }
    ASSERT_GT(n, 0u);
    EXPECT_LT(after, 0.5 * before) << method << ": mean error " << after / n << " m, odometry " << before / n << " m";
    // Poses late, and robot 2's scans late behind robot 1's (the release order, and with it each
    // match's reference, must still be the stamp order: the scan watermark).
    for (auto [pose_delay, scan_delay] : {std::pair<std::size_t, std::size_t>{0, 0}, {3, 0}, {0, 6}, {3, 6}}) {
      const std::string dir = temp_dir();
      FusionOptions o;
      o.core.method = method;
      o.core.max_points_per_voxel = 100000;
      o.core.registration = true;
      o.core.registration_options = run.registration_options;
      o.all_points_pcd = "fused_all.pcd";
      auto stage = FusionStage::create(o, dir);
      ASSERT_TRUE(stage.ok());
      feed(**stage, d, pose_delay, {}, scan_delay);
      EXPECT_GT((*stage)->core().counters().registration_corrections, 0u);
      EXPECT_EQ((*stage)->core().counters().scans_out_of_stamp_order, 0u);
      ASSERT_TRUE((*stage)->write_model().ok());
      auto all = read_pcd(dir + "/fused_all.pcd");
      ASSERT_TRUE(all.ok());
      ASSERT_EQ(all->size(), d.points.size());
      const int fr = all->field("robot"), fs = all->field("scan"), fb = all->field("beam"), fk = all->field("keep");
      const int fx = all->field("x");
      std::map<std::tuple<int, std::uint32_t, int>, std::pair<std::uint8_t, float>> decided;
      for (std::size_t i = 0; i < all->size(); ++i) {
        auto col = [&](int f) { return all->columns[static_cast<std::size_t>(f)][i]; };
        decided[{static_cast<int>(col(fr)), static_cast<std::uint32_t>(col(fs)), static_cast<int>(col(fb))}] = {
            col(fk) == 0.0 ? 1 : 0, static_cast<float>(col(fx))};
      }
      for (std::size_t i = 0; i < d.points.size(); ++i) {
        const auto& [removed, x] = decided[{d.points[i].robot, d.points[i].scan, d.points[i].beam}];
        ASSERT_EQ(removed, eval.removed[i]) << method << " point " << i << " pose_delay " << pose_delay << " scan_delay " << scan_delay;
        ASSERT_EQ(x, eval.placed[i].x) << method << " point " << i << " pose_delay " << pose_delay << " scan_delay " << scan_delay;  // the same correction
      }
      std::filesystem::remove_all(dir);
    }
  }
}

// The pose graph as the core's back end ([pose_graph]): the station feeds it the primary core's
// releases, whatever order the samples arrive in, and its robot<N>.graph.tum files at the end are those
// of `teamscan eval --pose-graph` (the back end fed the same core's releases in time order), to the byte.
TEST(FusionPoseGraph, TheStationsGraphTrajectoriesAreEvals) {
  const Dataset d = survey(12.0, 2);
  fusion::CoreRunOptions run = registered_run();
  fusion::GraphBackend eval_graph;
  run.graph = &eval_graph;
  ASSERT_TRUE(fusion::run_through_core(d, "best", mapping::MethodOptions{}, run).ok());
  eval_graph.finish();
  std::map<std::uint8_t, std::vector<trajectory::StampedPose>> expected;
  for (const fusion::GraphScanPose& p : eval_graph.poses()) expected[p.robot].push_back({(p.stamp_ns + 500) / 1000, p.graph});
  ASSERT_EQ(expected.size(), 2u);
  EXPECT_EQ(eval_graph.counters().scans, d.scans.size());
  EXPECT_GT(eval_graph.graph_stats().nodes, 0u);
  for (auto [pose_delay, scan_delay] : {std::pair<std::size_t, std::size_t>{0, 0}, {3, 6}}) {
    const std::string dir = temp_dir();
    FusionOptions o;
    o.core.method = "best";
    o.core.registration = true;
    o.core.registration_options = run.registration_options;
    o.pose_graph = fusion::GraphBackendOptions{};
    auto stage = FusionStage::create(o, dir);
    ASSERT_TRUE(stage.ok());
    ASSERT_NE((*stage)->graph(), nullptr);
    feed(**stage, d, pose_delay, {}, scan_delay);
    ASSERT_TRUE((*stage)->write_graph_trajectories().ok());
    for (const auto& [robot, poses] : expected) {
      std::ifstream in(dir + "/robot" + std::to_string(robot) + ".graph.tum", std::ios::binary);
      const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
      EXPECT_EQ(text, trajectory::tum_text(poses)) << "robot " << int{robot} << " pose_delay " << pose_delay << " scan_delay " << scan_delay;
    }
    std::filesystem::remove_all(dir);
  }
  // With the graph turned off ([pose_graph] enabled = false): no back end, nothing written.
  const std::string dir = temp_dir();
  FusionOptions off;
  off.pose_graph.reset();
  auto stage = FusionStage::create(off, dir);
  ASSERT_TRUE(stage.ok());
  EXPECT_EQ((*stage)->graph(), nullptr);
  EXPECT_TRUE((*stage)->write_graph_trajectories().ok());
  EXPECT_FALSE(std::filesystem::exists(dir + "/robot1.graph.tum"));
  std::filesystem::remove_all(dir);
}

TEST(FusionConfig, ThePoseGraphIsOnByDefaultAndOffByEnabledFalse) {
  ConfigError e;
  GroundStationConfig absent;
  ASSERT_TRUE(parse_groundstation_config("[fusion]\nmethod = \"best\"\n", "t.toml", absent, e)) << e.message;
  ASSERT_TRUE(absent.fusion.pose_graph) << "on without a [pose_graph] section";
  EXPECT_EQ(absent.fusion.pose_graph->estimate_every_s, 5.0) << "the live map follows the graph every 5 s";
  EXPECT_TRUE(absent.fusion.follow_rigidly);
  EXPECT_DOUBLE_EQ(absent.fusion.follow_min_shift_m, 0.02);
  EXPECT_DOUBLE_EQ(absent.fusion.exact_follow_share, 0.25);
  EXPECT_DOUBLE_EQ(absent.fusion.exact_follow_max_s, 10.0);
  EXPECT_TRUE(absent.fusion.pose_graph->cpus.empty());
  GroundStationConfig c;
  ASSERT_TRUE(parse_groundstation_config("[pose_graph]\n", "t.toml", c, e)) << e.message;
  ASSERT_TRUE(c.fusion.pose_graph);
  EXPECT_DOUBLE_EQ(c.fusion.pose_graph->returns.min_height_m, fusion::PlanarReturnOptions{}.min_height_m);
  EXPECT_EQ(c.fusion.pose_graph->estimate_every_s, 5.0);
  GroundStationConfig s;
  ASSERT_TRUE(parse_groundstation_config("[pose_graph]\nmin_height_m = 0.3\nmax_height_m = 1.5\nnode_s = 0.5\nfollow_s = 2\n"
                                         "follow_rigidly = false\nfollow_min_shift_m = 0.05\nexact_follow_share = 0.5\nexact_follow_max_s = 30\ncpus = [0]\n", "t.toml", s, e))
      << e.message;
  ASSERT_TRUE(s.fusion.pose_graph);
  EXPECT_DOUBLE_EQ(s.fusion.pose_graph->returns.min_height_m, 0.3);
  EXPECT_DOUBLE_EQ(s.fusion.pose_graph->returns.max_height_m, 1.5);
  EXPECT_DOUBLE_EQ(s.fusion.pose_graph->returns.tilted_node_s, 0.5);
  EXPECT_DOUBLE_EQ(s.fusion.pose_graph->estimate_every_s, 2.0);
  EXPECT_FALSE(s.fusion.follow_rigidly);
  EXPECT_DOUBLE_EQ(s.fusion.follow_min_shift_m, 0.05);
  EXPECT_DOUBLE_EQ(s.fusion.exact_follow_share, 0.5);
  EXPECT_DOUBLE_EQ(s.fusion.exact_follow_max_s, 30.0);
  GroundStationConfig every;
  ASSERT_TRUE(parse_groundstation_config("[pose_graph]\nfollow_min_shift_m = 0\n", "t.toml", every, e)) << e.message;
  EXPECT_EQ(every.fusion.follow_min_shift_m, 0.0) << "0: every estimate moves the model";
  GroundStationConfig rigid_only;
  ASSERT_TRUE(parse_groundstation_config("[pose_graph]\nexact_follow_share = 0\n", "t.toml", rigid_only, e)) << e.message;
  EXPECT_EQ(rigid_only.fusion.exact_follow_share, 0.0) << "0: rigid follows only";
  EXPECT_EQ(s.fusion.pose_graph->cpus, (std::vector<int>{0}));
  GroundStationConfig off;
  ASSERT_TRUE(parse_groundstation_config("[pose_graph]\nenabled = false\nnode_s = 0.5\n", "t.toml", off, e)) << e.message;
  EXPECT_FALSE(off.fusion.pose_graph);
  for (const char* bad : {"[pose_graph]\nnode_s = 0\n", "[pose_graph]\nmin_height_m = 1.0\nmax_height_m = 0.5\n",
                          "[pose_graph]\nmagic = 1\n", "[pose_graph]\nenabled = 1\n", "[pose_graph]\ncpus = [-1]\n",
                          "[pose_graph]\nfollow_s = -1\n", "[pose_graph]\nfollow_min_shift_m = -0.1\n",
                          "[pose_graph]\nfollow_rigidly = 1\n", "[pose_graph]\nexact_follow_share = 1.5\n",
                          "[pose_graph]\nexact_follow_share = -0.25\n", "[pose_graph]\nexact_follow_max_s = -1\n"}) {
    GroundStationConfig b;
    EXPECT_FALSE(parse_groundstation_config(bad, "t.toml", b, e)) << bad;
    EXPECT_EQ(e.message.rfind("pose_graph.", 0), 0u) << e.message;
  }
}

// The station→robot loop with the real registration: the fusion stage's corrections go to the Kalman
// team source (CorrectionShare, as main.cpp wires it), teamscan/team carries the drifting robot's
// correction as the core applies it at the publication time (team_member_from): between two matches the
// drift rates' extrapolation, not the last match's offset; every step of the published sequence is one
// the robot takes (correction_step_ok: 2 m / 30°), and that robot's pipeline takes the last one into use
// (decode_team, on_team): the correction it applies is the core's, to the mm and µrad.
TEST(FusionRegistration, TheTeamCarriesTheCorrectionTheCoreAppliesAtThePublicationTime) {
  const Dataset d = survey(12.0, 2);
  FusionOptions o;
  o.core.method = "best";
  o.core.registration = true;
  o.core.registration_options.window_s = 1.0;
  o.core.registration_options.match_every_s = 0.3;
  o.core.registration_options.min_map_features = 20;
  const std::string dir = temp_dir();
  auto stage = FusionStage::create(o, dir);
  ASSERT_TRUE(stage.ok());
  PoseHistoryTeamSource team{(*stage)->core().poses()};  // the station's one tracker: the core's history
  CorrectionShare share;
  const onboard::TeamCheckLimits limits;
  std::array<TeamMemberEstimate, kMaxRobots> estimates{};
  OdomCorrection published;             // robot 2's correction on the last team published
  std::uint64_t accepted_before = 0;    // the registration's accepted matches at that publication
  Pose2 at_last_match;                  // the correction the core applied when its last match was accepted
  std::size_t publications = 0, changed = 0, extrapolated = 0, steps_refused = 0;
  double largest_step_mm = 0;
  // A team publication at `at_ns`: the correction handed over, the estimate in its wire form.
  const auto publish = [&](std::int64_t at_ns) {
    share.share((*stage)->core(), team, Time::from_ns(at_ns));
    const std::size_t n = team.estimate(Time::from_ns(at_ns), estimates);
    const TeamMemberEstimate* e = nullptr;
    for (std::size_t i = 0; i < n; ++i)
      if (estimates[i].robot_id == 2) e = &estimates[i];
    ASSERT_NE(e, nullptr);
    ++publications;
    const registration::RobotCorrection* c = (*stage)->core().registration()->correction(2);
    const std::uint64_t accepted = c != nullptr ? c->accepted : 0;
    const fusion::PoseHistory::Correction* applied = (*stage)->core().poses().correction_at(2, at_ns);
    if (applied == nullptr) {
      EXPECT_TRUE(e->correction.none());
      return;
    }
    // What the core applies at this time, in wire form: the same values, its σ.
    const OdomCorrection core = OdomCorrection::from_pose(applied->map_from_odom, e->correction.seq);
    ASSERT_FALSE(e->correction.none());
    EXPECT_EQ(e->correction.x_mm, core.x_mm) << at_ns;
    EXPECT_EQ(e->correction.y_mm, core.y_mm) << at_ns;
    EXPECT_EQ(e->correction.yaw_urad, core.yaw_urad) << at_ns;
    EXPECT_EQ(e->correction_sigma_m, applied->position_sigma_m);
    if (accepted != accepted_before && c != nullptr && c->matched) at_last_match = c->map_from_odom;
    const bool values_changed = e->correction.x_mm != published.x_mm || e->correction.y_mm != published.y_mm ||
                                e->correction.yaw_urad != published.yaw_urad;
    if (values_changed) {
      ++changed;
      EXPECT_NE(e->correction.seq, published.seq);  // a new number for new values
      if (!onboard::correction_step_ok(published, e->correction, limits)) ++steps_refused;
      largest_step_mm = std::max(largest_step_mm, std::hypot(e->correction.x_mm - published.x_mm, e->correction.y_mm - published.y_mm));
      // No match since the last publication, and still it moved: the rates' extrapolation, away from
      // the last match's correction.
      const OdomCorrection held = OdomCorrection::from_pose(at_last_match, 0);
      if (accepted == accepted_before && accepted > 0 &&
          (e->correction.x_mm != held.x_mm || e->correction.y_mm != held.y_mm || e->correction.yaw_urad != held.yaw_urad))
        ++extrapolated;
    }
    published = e->correction;
    accepted_before = accepted;
  };
  // A team publication after every scan the station took (the loop publishes at 10 Hz, between samples).
  feed(**stage, d, 0, [&](std::int64_t arrival_ns) { publish(arrival_ns); });
  publish(d.odom.back().stamp_ns);  // what the final flush released
  const registration::RobotCorrection* c = (*stage)->core().registration()->correction(2);
  ASSERT_NE(c, nullptr);
  ASSERT_GT(c->accepted, 3u);
  EXPECT_GT(changed, c->accepted);       // more changes than matches: the extrapolation between them
  EXPECT_GT(extrapolated, 10u) << changed << " changes of " << publications << " publications, " << c->accepted << " matches";
  EXPECT_EQ(steps_refused, 0u) << "largest step " << largest_step_mm << " mm";
  EXPECT_LT(largest_step_mm, 120.0);     // within the registration's own step bound (12 cm at these σ)
  EXPECT_GT(std::abs(published.x_mm) + std::abs(published.y_mm), 20);  // the drift was corrected (≈ 10 cm by 12 s)

  // The last team state on the wire (the core's tracks), to the drifting robot's pipeline (its own clock:
  // the survey's, moved to 2027).
  constexpr std::int64_t kEpochNs = 1'800'000'000'000'000'000;
  const std::int64_t end_ns = d.odom.back().stamp_ns;
  static teamscan_msg_TeamState wire;
  wire.count = static_cast<std::uint8_t>(team.estimate(Time::from_ns(end_ns), estimates));
  ASSERT_EQ(wire.count, 2);
  for (std::size_t i = 0; i < wire.count; ++i) {
    team_member_from(estimates[i], false, wire.members[i]);
    wire.members[i].valid_ns += kEpochNs;
  }
  const teamscan_msg_TeamMember& m = wire.members[1];
  ASSERT_EQ(m.robot_id, 2u);
  const OdomCorrection expected = OdomCorrection::from_pose((*stage)->core().poses().map_from_odom(2, end_ns), published.seq);
  EXPECT_EQ(m.corr_seq, published.seq);
  EXPECT_EQ(m.corr_x_mm, expected.x_mm);
  EXPECT_EQ(m.corr_y_mm, expected.y_mm);
  EXPECT_EQ(m.corr_yaw_urad, expected.yaw_urad);
  EXPECT_EQ(m.corr_sigma_mm,
            static_cast<std::uint32_t>(std::lround(1000.0 * std::sqrt(std::max(c->covariance(0, 0), c->covariance(1, 1))))));
  std::string msg;
  auto config = onboard::parse_onboard_config(test::pipeline_test_config_toml(2, false), msg);
  ASSERT_TRUE(config.ok()) << msg;
  auto robot = onboard::OnboardPipeline::create(config.value());
  ASSERT_TRUE(robot.ok());
  onboard::TeamSnapshot snapshot;
  ASSERT_TRUE(onboard::decode_team(wire, snapshot));
  ASSERT_TRUE(robot->on_team(snapshot, Time::from_ns(end_ns + kEpochNs)).ok());
  EXPECT_EQ(robot->applied_correction().seq, expected.seq);
  EXPECT_EQ(robot->applied_correction().x_mm, expected.x_mm);
  EXPECT_EQ(robot->applied_correction().yaw_urad, expected.yaw_urad);
  EXPECT_EQ(robot->counters().corrections_applied, 1u);
  std::filesystem::remove_all(dir);
}

// A correction holds from a stamp on, whatever was added before it: the poses stamped at or after it
// are corrected (and their tracks folded again) whether they arrived before or after the correction.
// A scan's own pose between its robot's poses: a heading quadratic in time (a turn speeding up) is met
// exactly by the parabola through the pose before and the two around the scan, once the later one is
// there; before it arrives (or across a gap in the odometry) the last pose is moved on with its rate.
TEST(PoseHistoryScanPose, BetweenThePosesOnceTheNextIsThereElseMovedOn) {
  fusion::PoseHistory h(fusion::PoseHistoryOptions{});
  auto theta = [](double t) { return 2.0 * t * t; };  // the rate grows from 0 to 0.8 rad/s in 0.2 s
  auto pose = [&](double t, std::int64_t stamp_ns) {
    return fusion::PoseInput{1, stamp_ns, stamp_ns, Pose2{t, 0.0, theta(t)}, 1.0, 4.0 * t};
  };
  ASSERT_TRUE(h.add(pose(0.0, 0)));
  ASSERT_TRUE(h.add(pose(0.1, 100'000'000)));
  const std::int64_t scan_ns = 150'000'000;
  // Only the pose before: moved on from 0.1 s with its rate 0.4 rad/s.
  const auto moved_on = h.scan_pose(1, scan_ns);
  ASSERT_TRUE(moved_on.found);
  EXPECT_NEAR(moved_on.odom.theta_rad, theta(0.1) + 0.4 * 0.05, 1e-12);
  // The next pose there: between, exact for a quadratic heading and position.
  ASSERT_TRUE(h.add(pose(0.2, 200'000'000)));
  const auto between = h.scan_pose(1, scan_ns);
  EXPECT_NEAR(between.odom.theta_rad, theta(0.15), 1e-12);
  EXPECT_NEAR(between.odom.x_m, 0.15, 1e-12);
  EXPECT_NEAR(between.map_from_robot.theta_rad, theta(0.15), 1e-12);
  // A gap in the odometry (the next pose 0.5 s later): moved on from the pose before, as without it.
  ASSERT_TRUE(h.add(pose(0.7, 700'000'000)));
  const auto across_gap = h.scan_pose(1, 400'000'000);
  EXPECT_NEAR(across_gap.odom.theta_rad, theta(0.2) + 0.8 * 0.2, 1e-12);
  EXPECT_NEAR(across_gap.odom.x_m, 0.2 + std::cos(theta(0.2)) * 0.2, 1e-12);
}

TEST(PoseHistoryCorrection, AppliesByStampNotByArrival) {
  const Pose2 c{0.1, -0.05, 0.02};
  auto pose = [](std::int64_t k) {
    return fusion::PoseInput{1, k * 100'000'000, k * 100'000'000, Pose2{0.1 * k, 0.02 * k, 0.01 * k}, 0.5, 0.1};
  };
  fusion::PoseHistory before{fusion::PoseHistoryOptions{}}, after{fusion::PoseHistoryOptions{}};
  for (std::int64_t k = 0; k < 20; ++k) ASSERT_TRUE(before.add(pose(k)));
  before.set_map_from_odom(1, 1'000'000'000, c);  // after every pose arrived
  for (std::int64_t k = 0; k < 10; ++k) ASSERT_TRUE(after.add(pose(k)));
  after.set_map_from_odom(1, 1'000'000'000, c);  // before the later ones arrived
  for (std::int64_t k = 10; k < 20; ++k) ASSERT_TRUE(after.add(pose(k)));
  for (std::int64_t t : {std::int64_t{500'000'000}, std::int64_t{1'000'000'000}, std::int64_t{1'450'000'000}, std::int64_t{1'950'000'000}}) {
    const auto a = before.scan_pose(1, t), b = after.scan_pose(1, t);
    ASSERT_TRUE(a.found && b.found);
    EXPECT_EQ(a.map_from_robot.x_m, b.map_from_robot.x_m);
    EXPECT_EQ(a.map_from_robot.theta_rad, b.map_from_robot.theta_rad);
    const mapping::TeamState ta = before.team_at(t), tb = after.team_at(t);
    ASSERT_EQ(ta.robots.size(), 1u);
    EXPECT_EQ(ta.robots[0].position_m.x, tb.robots[0].position_m.x);
    EXPECT_EQ(ta.robots[0].position_m.y, tb.robots[0].position_m.y);
    // Before the stamp: odometry; from it on: the correction on the odometry.
    const Pose2 expected = t < 1'000'000'000 ? a.odom : c * a.odom;
    EXPECT_NEAR(a.map_from_robot.x_m, expected.x_m, 1e-12);
    EXPECT_NEAR(a.map_from_robot.y_m, expected.y_m, 1e-12);
  }
  // With a σ, the correction is a measurement for the track: its drift restarts from that σ at the
  // first pose stamped at or after the correction, whether that pose came before or after it.
  fusion::PoseHistoryOptions drifting;
  drifting.tracker.drift_m_per_m = 0.05;
  fusion::PoseHistory early{drifting}, late{drifting}, none{drifting};
  for (std::int64_t k = 0; k < 20; ++k) {
    ASSERT_TRUE(early.add(pose(k)));
    ASSERT_TRUE(none.add(pose(k)));
  }
  early.set_map_from_odom(1, 1'500'000'000, c, 0.004, 0.001, true);
  none.set_map_from_odom(1, 1'500'000'000, c, 0.004, 0.001);  // σ carried, a change of frame only
  for (std::int64_t k = 0; k < 15; ++k) ASSERT_TRUE(late.add(pose(k)));
  late.set_map_from_odom(1, 1'500'000'000, c, 0.004, 0.001, true);
  for (std::int64_t k = 15; k < 20; ++k) ASSERT_TRUE(late.add(pose(k)));
  const mapping::RobotEstimate e = early.team_at(1'900'000'000).robots.at(0), l = late.team_at(1'900'000'000).robots.at(0),
                               n = none.team_at(1'900'000'000).robots.at(0);
  EXPECT_EQ(e.drift_cov_m2(0, 0), l.drift_cov_m2(0, 0));
  EXPECT_EQ(e.position_m.x, l.position_m.x);
  EXPECT_LT(std::sqrt(e.drift_cov_m2(0, 0)), 0.018);  // 4 mm + 5 % of 0.25 m + 0.001 rad at 0.5 m
  EXPECT_GT(std::sqrt(n.drift_cov_m2(0, 0)), 0.05 * 0.5 * 1.8);          // odometry alone: 5 % of 0.9 m
  EXPECT_LT(e.drift_cov_m2(0, 0), 0.25 * n.drift_cov_m2(0, 0));
  EXPECT_EQ(before.map_from_odom(1, 999'999'999).x_m, 0.0);
  EXPECT_EQ(before.map_from_odom(1, 1'000'000'000).x_m, c.x_m);
  EXPECT_FALSE(before.corrected(2));
}

TEST(Fusion, MapVoxelsAccountForEveryModelPointAndFlagFullyRemovedVoxels) {
  const Dataset d = survey();
  const std::string dir = temp_dir();
  FusionOptions o;
  o.core.method = "combined";
  o.map_resolution_m = 0.2;
  auto stage = FusionStage::create(o, dir);
  ASSERT_TRUE(stage.ok());
  feed(**stage, d);
  std::vector<teamscan_msg_MapVoxel> voxels;
  (*stage)->map_voxels(voxels);
  ASSERT_FALSE(voxels.empty());
  EXPECT_EQ((*stage)->map_resolution_mm(), 200u);
  std::uint64_t hits = 0, flagged = 0;
  for (const teamscan_msg_MapVoxel& v : voxels) {
    hits += v.hits;
    flagged += v.flags;
    // Centres on the 0.2 m grid: 100 mm + k·200 mm.
    EXPECT_EQ(((v.x_mm % 200) + 200) % 200, 100);
    EXPECT_EQ(((v.z_mm % 200) + 200) % 200, 100);
  }
  EXPECT_EQ(hits, (*stage)->core().counters().stored_points);  // the model's points, not the received ones
  EXPECT_GT(flagged, 0u);
  EXPECT_LT(flagged, voxels.size());
  std::filesystem::remove_all(dir);
}

// The live map (teamscan/map, the view, ROS 2 map_cloud) at a core instant, as the fused model store holds
// it then: per voxel of the map resolution the model's points binned (positions as the core corrected
// them), its class (every point removed at release) and its robot (of the first point stored).
struct MapVoxelFigures {
  std::uint32_t hits = 0, kept = 0;  // kept: 1 if any point in the voxel was kept at release
  std::uint8_t robot = 0;
  bool operator==(const MapVoxelFigures&) const = default;
};
std::map<std::uint64_t, MapVoxelFigures> model_binned(const FusionStage& stage) {
  std::map<std::uint64_t, MapVoxelFigures> out;
  stage.core().for_each_model_point([&](const fusion::ModelPoint& m, bool) {
    const std::uint64_t key = stage.live_map().key_of(m.p);
    if (key == LiveMap::kOutOfRange) return;
    MapVoxelFigures& v = out[key];
    if (v.hits == 0) v.robot = m.robot;
    ++v.hits;
    if (m.removed_at_release == 0) v.kept = 1;  // on the wire: kept or not (flags)
  });
  return out;
}
std::map<std::uint64_t, MapVoxelFigures> live_map_published(const FusionStage& stage) {
  std::vector<teamscan_msg_MapVoxel> voxels;
  std::vector<std::uint8_t> robots;
  stage.map_voxels(voxels, &robots);
  std::map<std::uint64_t, MapVoxelFigures> out;
  for (std::size_t i = 0; i < voxels.size(); ++i) {
    const teamscan_msg_MapVoxel& v = voxels[i];
    const mapping::MapPoint centre{static_cast<float>(v.x_mm * 1e-3), static_cast<float>(v.y_mm * 1e-3),
                                   static_cast<float>(v.z_mm * 1e-3)};
    // kept: only "none" is on the wire (flags 1); hits: the count, not saturated in this survey.
    out[stage.live_map().key_of(centre)] = MapVoxelFigures{v.hits, v.flags == 0 ? 1u : 0u, robots[i]};
  }
  return out;
}

// How far robot 2's walls lie outside robot 1's in the model (metres): per wall of the survey's square
// room (the truth says which wall a point hit), robot 1's outermost kept point across the wall, and the
// largest distance any kept point of robot 2's on that wall lies beyond it. `beyond_10cm`: how many do.
struct WallOffset {
  double max_m = 0;
  std::size_t beyond_10cm = 0, points = 0;
};
WallOffset robot2_wall_offset(const FusionStage& stage, const Dataset& d, double room_m) {
  // Wall w: 0 x = 0, 1 x = room, 2 y = 0, 3 y = room; its outward coordinate (−x, x, −y, y).
  std::map<std::tuple<int, std::uint32_t, int>, int> wall;
  for (const LabelledPoint& p : d.points) {
    if (p.label != PointClass::wall) continue;
    const int w = std::abs(p.tx) < 1e-3 ? 0 : std::abs(p.tx - room_m) < 1e-3 ? 1 : std::abs(p.ty) < 1e-3 ? 2 : 3;
    wall[{p.robot, p.scan, p.beam}] = w;
  }
  auto outward = [](int w, const mapping::MapPoint& q) { return w == 0 ? -q.x : w == 1 ? q.x : w == 2 ? -q.y : q.y; };
  std::array<double, 4> robot1_out{-1e9, -1e9, -1e9, -1e9};
  std::vector<std::pair<int, double>> robot2;
  stage.core().for_each_model_point([&](const fusion::ModelPoint& m, bool removed) {
    const auto it = wall.find({m.robot, m.seq, m.beam});
    if (removed || it == wall.end()) return;
    const double o = outward(it->second, m.p);
    if (m.robot == 1) robot1_out[static_cast<std::size_t>(it->second)] = std::max(robot1_out[static_cast<std::size_t>(it->second)], o);
    if (m.robot == 2) robot2.emplace_back(it->second, o);
  });
  WallOffset out;
  for (const auto& [w, o] : robot2) {
    const double beyond = o - robot1_out[static_cast<std::size_t>(w)];
    out.max_m = std::max(out.max_m, beyond);
    out.beyond_10cm += beyond > 0.10 ? 1 : 0;
    ++out.points;
  }
  return out;
}

// The map the operator sees is the fused model: on a survey whose robot 2 drifts, with the registration
// on, at several instants of the core (during the feed and at the end) the live map's voxels are the
// model store's points binned, with the same keys, classes and robots, and it says which release it
// shows; robot 2's walls fall on robot 1's (none more than 10 cm outside). Without the registration the
// same walls are doubled (the check is not vacuous).
TEST(FusionRegistration, TheLiveMapIsTheModelAtTheCoresInstantAndItsWallsAreSingle) {
  const Dataset d = survey(12.0, 2);
  for (const bool registration : {true, false}) {
    const std::string dir = temp_dir();
    FusionOptions o;
    o.core.method = "best";
    o.core.registration = registration;
    o.core.registration_options.window_s = 1.0;
    o.core.registration_options.match_every_s = 0.3;
    o.core.registration_options.min_map_features = 20;
    auto created = FusionStage::create(o, dir);
    ASSERT_TRUE(created.ok());
    FusionStage& stage = **created;
    std::size_t scans = 0, compared = 0;
    feed(stage, d, 3, [&](std::int64_t) {
      if (++scans % 25 != 0 || !registration) return;
      EXPECT_EQ(stage.map_release(), stage.core().counters().scans_released);
      const auto model = model_binned(stage);
      ASSERT_EQ(live_map_published(stage), model) << "after " << scans << " scans";
      ++compared;
    });
    EXPECT_EQ(stage.map_release(), stage.core().counters().scans_released);
    const auto model = model_binned(stage);
    ASSERT_FALSE(model.empty());
    EXPECT_EQ(live_map_published(stage), model);
    std::size_t removed_voxels = 0;
    for (const auto& [key, v] : model) removed_voxels += v.kept == 0 ? 1 : 0;
    const WallOffset offset = robot2_wall_offset(stage, d, 6.0);
    ASSERT_GT(offset.points, 1000u);
    if (registration) {
      EXPECT_GT(compared, 2u);
      EXPECT_GT(stage.core().counters().registration_corrections, 0u);
      EXPECT_GT(removed_voxels, 0u) << "no removed voxel: the class comparison would be vacuous";
      EXPECT_LE(offset.max_m, 0.10) << "robot 2's wall outside robot 1's in the live map";
    } else {
      EXPECT_GT(offset.max_m, 0.10) << "odometry alone: the drift should double the walls (the check is vacuous)";
    }
    std::printf("registration %s: robot 2's walls at most %.3f m outside robot 1's (%zu of %zu points beyond 10 cm); "
                "%zu voxels (%zu removed)\n",
                registration ? "on" : "off", offset.max_m, offset.beyond_10cm, offset.points, model.size(), removed_voxels);
    std::filesystem::remove_all(dir);
  }
}

// The view's per-robot ghost figures are the core's: each released scan's removed points credited to
// that scan's robot, whichever robot's scan arrived last.
TEST(Fusion, TheCoresPerRobotCountersAddUpToItsTotals) {
  const Dataset d = survey();
  const std::string dir = temp_dir();
  FusionOptions o;
  o.core.method = "best";
  auto stage = FusionStage::create(o, dir);
  ASSERT_TRUE(stage.ok());
  feed(**stage, d);
  const fusion::CoreCounters& c = (*stage)->core().counters();
  std::uint64_t scans = 0, points = 0, removed = 0, stored = 0;
  std::map<std::uint32_t, std::uint64_t> points_by_robot;
  for (const LabelledPoint& p : d.points) ++points_by_robot[p.robot];
  for (std::uint32_t r = 1; r <= 2; ++r) {
    const fusion::RobotCounters& rc = (*stage)->core().robot_counters(r);
    EXPECT_EQ(rc.points, points_by_robot[r]) << "robot " << r;
    scans += rc.scans_released;
    points += rc.points;
    removed += rc.removed_at_release;
    stored += rc.stored_points;
  }
  EXPECT_EQ(scans, c.scans_released);
  EXPECT_EQ(points, c.points);
  EXPECT_EQ(removed, c.removed_at_release);
  EXPECT_EQ(stored, c.stored_points);
  EXPECT_GT(removed, 0u);
  std::filesystem::remove_all(dir);
}

// Hands `f` one scan of `robot` with `seq` and three points, stamped `stamp_ns`, received 1 ms later.
void add_small_scan(FusionStage& f, std::uint32_t robot, std::uint32_t seq, std::int64_t stamp_ns) {
  static ScanPoints s;
  s = ScanPoints{};
  s.robot_id = robot;
  s.seq = seq;
  s.stamp = Time::from_ns(stamp_ns);
  for (std::uint16_t b = 0; b < 3; ++b) s.points[s.count++] = ScanPoint{1000 + 10 * b, 2000, 300, b, 0};
  Receipt receipt;
  receipt.recv_realtime_ns = stamp_ns + 1'000'000;
  f.add_scan(s, receipt);
}

TEST(Fusion, HistoryReplaysAreNotFusedTwiceButRestartsAre) {
  const std::string dir = temp_dir();
  FusionOptions o;
  o.core.method = "direction";
  o.core.hold_s = 0;  // scans without poses: decided at arrival
  o.latency_log_csv = "fused_latency.csv";
  auto stage = FusionStage::create(o, dir);
  ASSERT_TRUE(stage.ok());
  FusionStage& f = **stage;
  const std::int64_t t0 = 1'700'000'000'000'000'000;
  constexpr std::int64_t kPeriod = 13'333'333;  // 75 Hz
  for (std::uint32_t seq = 1; seq <= 400; ++seq) add_small_scan(f, 1, seq, t0 + seq * kPeriod);
  for (std::uint32_t seq = 1; seq <= 50; ++seq) add_small_scan(f, 2, seq, t0 + seq * kPeriod);
  ASSERT_EQ(f.counters().scans, 450u);
  // Robot 1's history (the newest 300) delivered again, and robot 2's last scan: all duplicates.
  for (std::uint32_t seq = 101; seq <= 400; ++seq) add_small_scan(f, 1, seq, t0 + seq * kPeriod);
  add_small_scan(f, 2, 50, t0);
  EXPECT_EQ(f.counters().duplicates, 301u);
  EXPECT_EQ(f.counters().scans, 450u);
  EXPECT_EQ(f.counters().points, 450u * 3);
  // A gap filled late is new; the same scan again is not.
  add_small_scan(f, 2, 60, t0);
  add_small_scan(f, 2, 55, t0);
  add_small_scan(f, 2, 55, t0);
  EXPECT_EQ(f.counters().scans, 452u);
  EXPECT_EQ(f.counters().duplicates, 302u);
  // Robot 1 restarted: seq 1 again, far below its newest (more than the core's 1024-seq window).
  for (std::uint32_t seq = 401; seq <= 1500; ++seq) add_small_scan(f, 1, seq, t0 + seq * kPeriod);
  ASSERT_EQ(f.counters().scans, 452u + 1100u);
  add_small_scan(f, 1, 1, t0 + 500 * kPeriod);
  add_small_scan(f, 1, 2, t0 + 501 * kPeriod);
  EXPECT_EQ(f.counters().scans, 1554u);
  EXPECT_EQ(f.counters().duplicates, 302u);
  // Jumps larger than the bitmap forget the old window without confusing the new one.
  add_small_scan(f, 2, 5000, t0);
  add_small_scan(f, 2, 4999, t0);
  add_small_scan(f, 2, 5000, t0);
  EXPECT_EQ(f.counters().scans, 1556u);
  EXPECT_EQ(f.counters().duplicates, 303u);
  // Every fused scan has one latency sample (stamp -> fused) and one stored sample (stamp -> received).
  EXPECT_EQ(f.fused_latency().count(), 1556u);
  EXPECT_EQ(f.stored_latency().count(), 1556u + 303u);
  EXPECT_GE(f.stored_latency().quantile_ns(0.5), 1'000'000);
  EXPECT_LE(f.stored_latency().quantile_ns(0.5), 1'000'000 + LatencyHistogram::kBucketNs);
  ASSERT_TRUE(f.write_latency().ok());
  EXPECT_TRUE(std::filesystem::exists(dir + "/latency.csv"));
  // The per-scan log (flushed by write_latency): a header and one line per fused scan, never a replay.
  std::ifstream log(dir + "/fused_latency.csv");
  std::string line;
  std::getline(log, line);
  EXPECT_EQ(line, "robot,seq,stamp_ns,received_ns,fused_ns");
  std::size_t lines = 0;
  std::set<std::pair<unsigned, unsigned>> scans;
  while (std::getline(log, line)) {
    unsigned robot = 0, seq = 0;
    long long stamp = 0, received = 0, fused = 0;
    ASSERT_EQ(std::sscanf(line.c_str(), "%u,%u,%lld,%lld,%lld", &robot, &seq, &stamp, &received, &fused), 5) << line;
    EXPECT_EQ(received, stamp + 1'000'000);
    ++lines;
    scans.insert({robot, seq});
  }
  EXPECT_EQ(lines, 1556u);
  EXPECT_EQ(scans.size(), 1554u);  // robot 1 seq 1 and 2 fused twice: before and after its restart
  std::filesystem::remove_all(dir);
}

TEST(Fusion, AllPointsModelCarriesTheLiveDecisions) {
  const Dataset d = survey();
  const std::string dir = temp_dir();
  FusionOptions o;  // combined: decisions at release (the map so far) differ from the final ones
  o.core.method = "combined";
  o.core.max_points_per_voxel = 100000;
  o.all_points_pcd = "fused_all.pcd";
  auto stage = FusionStage::create(o, dir);
  ASSERT_TRUE(stage.ok());
  feed(**stage, d);
  ASSERT_TRUE((*stage)->write_model().ok());
  auto all = read_pcd(dir + "/fused_all.pcd");
  ASSERT_TRUE(all.ok());
  const int live = all->field("live_keep"), keep = all->field("keep");
  ASSERT_GE(live, 0);
  std::uint64_t removed = 0, differ = 0;
  for (std::size_t i = 0; i < all->size(); ++i) {
    removed += all->columns[static_cast<std::size_t>(live)][i] == 0.0 ? 1 : 0;
    differ += all->columns[static_cast<std::size_t>(live)][i] != all->columns[static_cast<std::size_t>(keep)][i] ? 1 : 0;
  }
  EXPECT_EQ(removed, (*stage)->counters().live_removed);
  EXPECT_GT(removed, 0u);
  EXPECT_GT(differ, 0u);  // the map part was revised as the map grew
  std::filesystem::remove_all(dir);
}

TEST(Fusion, WriteIntoAMissingFolderFailsAsAValueAndIsCounted) {
  FusionOptions o;
  auto stage = FusionStage::create(o, "/nonexistent/teamscan/station");
  ASSERT_TRUE(stage.ok());
  EXPECT_FALSE((*stage)->write_model().ok());
  EXPECT_EQ((*stage)->counters().write_failures, 1u);
}

TEST(Fusion, UnknownMethodIsRejected) {
  FusionOptions o;
  o.core.method = "magic";
  EXPECT_FALSE(FusionStage::create(o, "/tmp").ok());
}

TEST(FusionConfig, KeysParseIntoOptions) {
  GroundStationConfig c;
  ConfigError e;
  ASSERT_TRUE(parse_groundstation_config(
      "[fusion]\nmethod = \"visibility\"\nresolution_m = 0.05\nhalf_angle_deg = 5.0\nwrite_interval_s = 2.5\n"
      "write_all_points = true\nmap_interval_s = 0.0\nfrequency_k = 0.5\n",
      "t.toml", c, e))
      << e.message;
  EXPECT_EQ(c.fusion.core.method, "visibility");
  EXPECT_EQ(c.fusion.write_interval, std::chrono::milliseconds(2500));
  EXPECT_EQ(c.fusion.map_interval.count(), 0);
  const FusionOptions o = c.fusion;
  EXPECT_DOUBLE_EQ(o.core.methods.visibility.resolution_m, 0.05);
  EXPECT_DOUBLE_EQ(o.core.methods.combined_resolution_m, 0.05);
  EXPECT_NEAR(o.core.methods.direction.half_angle_rad, 5.0 * M_PI / 180.0, 1e-12);
  EXPECT_DOUBLE_EQ(o.core.methods.frequency.k, 0.5);
  EXPECT_EQ(o.all_points_pcd, "fused_all.pcd");
}

TEST(FusionConfig, DefaultsAreBestWithThePapersCombinedParameters) {
  GroundStationConfig c;
  const FusionOptions o = c.fusion;
  EXPECT_EQ(o.core.method, "best");  // docs/beyond.md: the recommended default
  EXPECT_DOUBLE_EQ(o.core.methods.combined_resolution_m, 0.1);
  EXPECT_NEAR(o.core.methods.combined_half_angle_rad, 7.0 * M_PI / 180.0, 1e-12);
  EXPECT_EQ(o.core.max_points_per_voxel, 8u);
  EXPECT_TRUE(o.all_points_pcd.empty());
}

TEST(FusionConfig, RegistrationIsOffByDefaultAndOnByKeyOrSection) {
  GroundStationConfig c;
  EXPECT_FALSE(c.fusion.core.registration);
  ConfigError e;
  ASSERT_TRUE(parse_groundstation_config("[fusion]\nregistration = true\n", "t.toml", c, e)) << e.message;
  EXPECT_TRUE(c.fusion.core.registration);
  GroundStationConfig s;
  ASSERT_TRUE(parse_groundstation_config("[registration]\nwindow_s = 2.0\nmatch_every_s = 0.25\nmin_map_features = 40\n", "t.toml", s, e))
      << e.message;
  const FusionOptions o = s.fusion;
  EXPECT_TRUE(o.core.registration);
  EXPECT_DOUBLE_EQ(o.core.registration_options.window_s, 2.0);
  EXPECT_DOUBLE_EQ(o.core.registration_options.match_every_s, 0.25);
  EXPECT_EQ(o.core.registration_options.min_map_features, 40u);
  GroundStationConfig off;
  ASSERT_TRUE(parse_groundstation_config("[registration]\nenabled = false\n", "t.toml", off, e)) << e.message;
  EXPECT_FALSE(off.fusion.core.registration);
  EXPECT_FALSE(parse_groundstation_config("[registration]\nwindow_s = 0\n", "t.toml", off, e));
  EXPECT_EQ(e.message.rfind("registration.window_s:", 0), 0u) << e.message;
  EXPECT_FALSE(parse_groundstation_config("[registration]\nmagic = 1\n", "t.toml", off, e));
  // The match thread: its delay and its CPUs.
  EXPECT_DOUBLE_EQ(o.core.registration_options.match_delay_s, registration::RegistrationOptions{}.match_delay_s);
  EXPECT_TRUE(o.core.registration_options.cpus.empty());
  GroundStationConfig m;
  ASSERT_TRUE(parse_groundstation_config("[registration]\nmatch_delay_s = 0\ncpus = [0, 1]\n", "t.toml", m, e)) << e.message;
  const FusionOptions mo = m.fusion;
  EXPECT_DOUBLE_EQ(mo.core.registration_options.match_delay_s, 0.0);
  EXPECT_EQ(mo.core.registration_options.cpus, (std::vector<int>{0, 1}));
  for (const char* bad : {"[registration]\nmatch_delay_s = -1\n", "[registration]\nmatch_delay_s = 11\n",
                          "[registration]\ncpus = 0\n", "[registration]\ncpus = [-1]\n", "[registration]\ncpus = [\"0\"]\n"}) {
    GroundStationConfig b;
    EXPECT_FALSE(parse_groundstation_config(bad, "t.toml", b, e)) << bad;
    EXPECT_EQ(e.message.rfind("registration.", 0), 0u) << e.message;
  }
}

TEST(FusionConfig, MinScanIntervalReachesTheCore) {
  GroundStationConfig c;
  EXPECT_DOUBLE_EQ(c.fusion.core.min_scan_interval_s,
                   fusion::CoreOptions{}.min_scan_interval_s);
  ConfigError e;
  ASSERT_TRUE(parse_groundstation_config("[fusion]\nmin_scan_interval_s = 0.02\n", "t.toml", c, e)) << e.message;
  EXPECT_DOUBLE_EQ(c.fusion.core.min_scan_interval_s, 0.02);
  for (const char* bad : {"[fusion]\nmin_scan_interval_s = -0.001\n", "[fusion]\nmin_scan_interval_s = 2.0\n",
                          "[fusion]\nmin_scan_interval_s = \"fast\"\n"}) {
    GroundStationConfig b;
    EXPECT_FALSE(parse_groundstation_config(bad, "t.toml", b, e)) << bad;
    EXPECT_EQ(e.message.rfind("fusion.min_scan_interval_s:", 0), 0u) << e.message;
  }
}

// The station's [registration] odometry priors (a calibration's [[registration.robot]] tables) reach the
// registration its fusion core runs: robot 2 starts from its own, the others from the default.
TEST(FusionConfig, TheOdometryPriorsReachTheCoresRegistration) {
  GroundStationConfig c;
  ConfigError e;
  ASSERT_TRUE(parse_groundstation_config("[registration]\nscale_sigma_percent = 1.5\n[[registration.robot]]\nid = 2\n"
                                         "scale_percent = -1.5\ndrift_deg_per_m = 0.2\n",
                                         "t.toml", c, e))
      << e.message;
  auto stage = FusionStage::create(c.fusion, temp_dir());
  ASSERT_TRUE(stage.ok());
  const registration::Registration* reg = (*stage)->core().registration();
  ASSERT_NE(reg, nullptr);
  EXPECT_DOUBLE_EQ(reg->options().prior_of(2).scale, -0.015);
  EXPECT_DOUBLE_EQ(reg->options().prior_of(2).drift_rad_per_m, 0.2 * M_PI / 180.0);
  EXPECT_DOUBLE_EQ(reg->options().prior_of(2).sigma_scale, 0.015);  // the default's σ, not set for robot 2
  EXPECT_DOUBLE_EQ(reg->options().prior_of(1).scale, 0.0);
  EXPECT_DOUBLE_EQ(reg->options().prior_of(1).sigma_scale, 0.015);
}

TEST(FusionConfig, BadValuesNameTheirKey) {
  GroundStationConfig c;
  ConfigError e;
  EXPECT_FALSE(parse_groundstation_config("[fusion]\nmethod = \"magic\"\n", "t.toml", c, e));
  EXPECT_EQ(e.message.rfind("fusion.method:", 0), 0u) << e.message;
  EXPECT_FALSE(parse_groundstation_config("[fusion]\nresolution_m = -1.0\n", "t.toml", c, e));
  EXPECT_EQ(e.message.rfind("fusion.resolution_m:", 0), 0u) << e.message;
  EXPECT_FALSE(parse_groundstation_config("[fusion]\nwrite_all_points = 1\n", "t.toml", c, e));
  EXPECT_EQ(e.message.rfind("fusion.write_all_points:", 0), 0u) << e.message;
  EXPECT_FALSE(parse_groundstation_config("[fusion]\nmethd = \"visibility\"\n", "t.toml", c, e));
  EXPECT_EQ(e.message.rfind("fusion.methd: unknown key", 0), 0u) << e.message;
}

TEST(FusionConfig, CompareMethodsAreKnownOtherThanThePrimaryAndListedOnce) {
  GroundStationConfig c;
  ConfigError e;
  ASSERT_TRUE(parse_groundstation_config("[fusion]\nmethod = \"best\"\ncompare_methods = [\"position\", \"direction\"]\n"
                                         "write_all_points = true\n", "t.toml", c, e))
      << e.message;
  ASSERT_EQ(c.fusion.compare_methods, (std::vector<std::string>{"position", "direction"}));
  EXPECT_DOUBLE_EQ(c.fusion.write_slice_ms, 2.0);
  FusionOptions o = c.fusion;
  EXPECT_EQ(o.compare_methods, c.fusion.compare_methods);
  GroundStationConfig sliced;
  ASSERT_TRUE(parse_groundstation_config("[fusion]\nwrite_slice_ms = 0.5\n", "t.toml", sliced, e)) << e.message;
  EXPECT_DOUBLE_EQ(sliced.fusion.write_slice_ms, 0.5);
  EXPECT_TRUE(sliced.fusion.writer_cpus.empty());  // default: the process's
  GroundStationConfig pinned;
  ASSERT_TRUE(parse_groundstation_config("[fusion]\nwriter_cpus = [0, 3]\n", "t.toml", pinned, e)) << e.message;
  EXPECT_EQ(pinned.fusion.writer_cpus, (std::vector<int>{0, 3}));
  const FusionOptions p = compared_options(o, "position");
  EXPECT_EQ(p.core.method, "position");
  EXPECT_EQ(p.kept_pcd, "fused.position.pcd");
  EXPECT_EQ(p.all_points_pcd, "fused_all.position.pcd");
  EXPECT_TRUE(p.compare_methods.empty());
  EXPECT_EQ(compared_options(o, "best").all_points_pcd, "fused_all.pcd");
  EXPECT_EQ(method_file_name("model", "tracked"), "model.tracked");
  GroundStationConfig d;
  EXPECT_TRUE(d.fusion.compare_methods.empty());  // default: none
  // The catch-up after a back-fill: its trigger and its slice per loop turn.
  EXPECT_EQ(d.fusion.catch_up_min_scans, 75u);
  EXPECT_DOUBLE_EQ(d.fusion.catch_up_quiet_s, 2.0);
  EXPECT_EQ(d.fusion.catch_up_slice_scans, 16u);
  GroundStationConfig cu;
  ASSERT_TRUE(parse_groundstation_config("[fusion]\ncatch_up_min_scans = 10\ncatch_up_quiet_s = 0.5\ncatch_up_slice_scans = 0\n",
                                         "t.toml", cu, e))
      << e.message;
  EXPECT_EQ(cu.fusion.catch_up_min_scans, 10u);
  EXPECT_DOUBLE_EQ(cu.fusion.catch_up_quiet_s, 0.5);
  EXPECT_EQ(cu.fusion.catch_up_slice_scans, 0u);

  const std::pair<const char*, const char*> bad[] = {
      {"[fusion]\ncompare_methods = [\"magic\"]\n", "fusion.compare_methods: must list methods among"},
      {"[fusion]\ncompare_methods = [\"best\"]\n", "fusion.compare_methods: \"best\" is fusion.method"},
      {"[fusion]\ncompare_methods = [\"position\", \"position\"]\n", "fusion.compare_methods: \"position\" is listed twice"},
      {"[fusion]\ncompare_methods = \"position\"\n", "fusion.compare_methods: must be an array of strings"},
      {"[fusion]\ncompare_methods = [1]\n", "fusion.compare_methods: must be an array of strings"},
      {"[fusion]\nwrite_slice_ms = -1\n", "fusion.write_slice_ms: must be in"},
      {"[fusion]\ncatch_up_slice_scans = -1\n", "fusion.catch_up_slice_scans: must be in"},
      {"[fusion]\ncatch_up_quiet_s = -1\n", "fusion.catch_up_quiet_s: must be in"},
      {"[fusion]\nwriter_cpus = 1\n", "fusion.writer_cpus: must be an array of integers"},
      {"[fusion]\nwriter_cpus = [\"1\"]\n", "fusion.writer_cpus: must be an array of integers"},
      {"[fusion]\nwriter_cpus = [-1]\n", "fusion.writer_cpus: each must be in [0, 1023], got -1"},
  };
  for (const auto& [text, message] : bad) {
    GroundStationConfig b;
    EXPECT_FALSE(parse_groundstation_config(text, "t.toml", b, e)) << text;
    EXPECT_EQ(e.message.rfind(message, 0), 0u) << e.message;
  }
  // The stage refuses them too (options built in code).
  FusionOptions f;
  f.compare_methods = {"magic"};
  EXPECT_FALSE(FusionStage::create(f, "/tmp").ok());
  f.compare_methods = {"best"};
  EXPECT_FALSE(FusionStage::create(f, "/tmp").ok());
  f.compare_methods = {"position", "position"};
  EXPECT_FALSE(FusionStage::create(f, "/tmp").ok());
}

// The streamed model file has the bytes common/dataset's PCD writer gives the same rows.
TEST(Fusion, StreamedModelFilesAreThePcdWritersBytes) {
  const Dataset d = survey();
  const std::string dir = temp_dir();
  FusionOptions o;
  o.core.method = "combined";
  o.core.max_points_per_voxel = 3;  // some capped
  o.all_points_pcd = "fused_all.pcd";
  auto stage = FusionStage::create(o, dir);
  ASSERT_TRUE(stage.ok());
  feed(**stage, d);
  ASSERT_TRUE((*stage)->write_model().ok());
  PcdCloud kept, every;
  kept.fields = {"x", "y", "z", "robot", "scan", "beam"};
  kept.columns.assign(6, {});
  every.fields = {"x", "y", "z", "robot", "scan", "beam", "keep", "live_keep"};
  every.columns.assign(8, {});
  (*stage)->core().for_each_model_point([&](const fusion::ModelPoint& m, bool removed) {
    const double row[8] = {m.p.x, m.p.y, m.p.z, double(m.robot), double(m.seq), double(m.beam), removed ? 0.0 : 1.0,
                           m.removed_at_release ? 0.0 : 1.0};
    for (std::size_t c = 0; c < 6 && !removed; ++c) kept.columns[c].push_back(row[c]);
    for (std::size_t c = 0; c < 8; ++c) every.columns[c].push_back(row[c]);
  });
  ASSERT_GT(kept.columns[0].size(), 0u);
  ASSERT_GT(every.columns[0].size(), kept.columns[0].size());
  const std::vector<PcdField> layout = {{"x", 4, 'F', 1},     {"y", 4, 'F', 1},    {"z", 4, 'F', 1},
                                        {"robot", 1, 'U', 1}, {"scan", 4, 'U', 1}, {"beam", 2, 'U', 1}};
  std::vector<PcdField> layout_all = layout;
  layout_all.push_back({"keep", 1, 'U', 1});
  layout_all.push_back({"live_keep", 1, 'U', 1});
  auto file = [](const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    return std::vector<std::uint8_t>(std::istreambuf_iterator<char>(in), {});
  };
  auto want_kept = encode_pcd(kept, layout);
  auto want_all = encode_pcd(every, layout_all);
  ASSERT_TRUE(want_kept.ok());
  ASSERT_TRUE(want_all.ok());
  EXPECT_EQ(file(dir + "/fused.pcd"), *want_kept);
  EXPECT_EQ(file(dir + "/fused_all.pcd"), *want_all);
  std::filesystem::remove_all(dir);
}

// request_write(): the snapshot in the caller's loop, in slices over several poll_write() turns, the
// files on the writer thread; requests while a write is in flight are counted and served by one write
// after it; the files are those of a synchronous write of the same state; a failing write is counted
// and reported, not thrown.
// A snapshot taken in slices while new scans arrive holds every point stored before it started, and no
// point twice.
TEST(Fusion, ASnapshotInSlicesHoldsEveryPointStoredBeforeItStarted) {
  const Dataset d = survey();
  const std::int64_t split_ns = d.scans[d.scans.size() / 2].stamp_ns;
  Dataset first = d, second = d;
  std::erase_if(first.scans, [&](const ScanRecord& r) { return r.stamp_ns >= split_ns; });
  std::erase_if(first.odom, [&](const TrajectorySample& t) { return t.stamp_ns >= split_ns; });
  std::erase_if(second.scans, [&](const ScanRecord& r) { return r.stamp_ns < split_ns; });
  std::erase_if(second.odom, [&](const TrajectorySample& t) { return t.stamp_ns < split_ns; });
  const std::string dir = temp_dir();
  FusionOptions o;
  o.core.method = "best";
  o.core.max_points_per_voxel = 100000;
  o.all_points_pcd = "fused_all.pcd";
  o.write_slice_ms = 0;
  auto stage = FusionStage::create(o, dir);
  ASSERT_TRUE(stage.ok());
  FusionStage& f = **stage;
  feed(f, first);
  const std::uint64_t stored_before = f.core().counters().stored_points;
  f.request_write();
  ASSERT_TRUE(f.write_in_flight());
  feed(f, second);  // new points into voxels taken and not yet taken, and new voxels
  ASSERT_GT(f.core().counters().stored_points, stored_before);
  f.wait_for_write();
  ASSERT_TRUE(f.poll_write());
  ASSERT_TRUE(f.last_write().ok);
  auto all = read_pcd(dir + "/fused_all.pcd");
  ASSERT_TRUE(all.ok());
  const int fr = all->field("robot"), fs = all->field("scan"), fb = all->field("beam");
  std::set<std::tuple<int, std::uint32_t, int>> rows;
  for (std::size_t i = 0; i < all->size(); ++i) {
    auto col = [&](int c) { return all->columns[static_cast<std::size_t>(c)][i]; };
    EXPECT_TRUE(rows.insert({static_cast<int>(col(fr)), static_cast<std::uint32_t>(col(fs)), static_cast<int>(col(fb))}).second);
  }
  std::size_t first_points = 0;
  for (const LabelledPoint& p : d.points) {
    if (std::none_of(first.scans.begin(), first.scans.end(), [&](const ScanRecord& r) { return r.robot == p.robot && r.scan == p.scan; }))
      continue;
    ++first_points;
    EXPECT_EQ(rows.count({p.robot, p.scan, p.beam}), 1u) << "robot " << int(p.robot) << " scan " << p.scan;
  }
  EXPECT_EQ(first_points, stored_before);
  EXPECT_LT(rows.size(), d.points.size());  // the voxels new since the start wait for the next write
  std::filesystem::remove_all(dir);
}

// The writer thread yields to the receive loop (fusion.hpp "Model writes"): the kernel reports it
// SCHED_IDLE at nice 19, while the loop's thread (this one) keeps its own policy and nice.
TEST(Fusion, TheWriterThreadRunsIdleClassAndTheLoopKeepsItsPriority) {
  const Dataset d = survey();
  const std::string dir = temp_dir();
  FusionOptions o;
  o.all_points_pcd = "fused_all.pcd";
  auto stage = FusionStage::create(o, dir);
  ASSERT_TRUE(stage.ok());
  FusionStage& f = **stage;
  EXPECT_EQ(f.writer_scheduling().policy, -1);  // no writer thread before the first periodic write
  int loop_policy = -1;
  sched_param loop_param{};
  ASSERT_EQ(pthread_getschedparam(pthread_self(), &loop_policy, &loop_param), 0);
  errno = 0;
  const int loop_nice = getpriority(PRIO_PROCESS, static_cast<id_t>(syscall(SYS_gettid)));
  ASSERT_EQ(errno, 0);
  ASSERT_NE(loop_policy, SCHED_IDLE);
  feed(f, d);
  f.request_write();
  f.wait_for_write();  // the writer has written the files, so it has set itself up
  ASSERT_TRUE(f.poll_write());
  ASSERT_TRUE(f.last_write().ok);
  EXPECT_TRUE(f.last_write().on_writer_thread);
  const ThreadScheduling w = f.writer_scheduling();
  EXPECT_EQ(w.policy, SCHED_IDLE);
  EXPECT_EQ(w.nice, 19);
  // Only the writer moved: the loop's thread is as it was.
  int policy_after = -1;
  sched_param param_after{};
  ASSERT_EQ(pthread_getschedparam(pthread_self(), &policy_after, &param_after), 0);
  EXPECT_EQ(policy_after, loop_policy);
  EXPECT_EQ(param_after.sched_priority, loop_param.sched_priority);
  errno = 0;
  EXPECT_EQ(getpriority(PRIO_PROCESS, static_cast<id_t>(syscall(SYS_gettid))), loop_nice);
  std::filesystem::remove_all(dir);
}

// fusion.writer_cpus: the writer thread runs on the CPUs asked for (here the last one this process may
// use), the loop's thread keeps its whole affinity.
TEST(Fusion, TheWriterThreadRunsOnTheWriterCpus) {
  const std::vector<int> allowed = current_thread_cpus();
  ASSERT_FALSE(allowed.empty());
  const Dataset d = survey();
  const std::string dir = temp_dir();
  FusionOptions o;
  o.writer_cpus = {allowed.back()};
  auto stage = FusionStage::create(o, dir);
  ASSERT_TRUE(stage.ok());
  FusionStage& f = **stage;
  feed(f, d);
  f.request_write();
  f.wait_for_write();
  ASSERT_TRUE(f.poll_write());
  ASSERT_TRUE(f.last_write().ok);
  const ThreadScheduling w = f.writer_scheduling();
  EXPECT_EQ(w.affinity_error, 0);
  EXPECT_EQ(w.cpus, o.writer_cpus);
  EXPECT_EQ(current_thread_cpus(), allowed);
  std::filesystem::remove_all(dir);
}

// The shutdown write while a periodic write is still being taken: the periodic one is abandoned (no
// file, no temporary left), the synchronous one written and counted.
TEST(Fusion, TheShutdownWriteReplacesAPeriodicWriteInProgress) {
  const Dataset d = survey();
  const std::string dir = temp_dir();
  FusionOptions o;
  o.core.max_points_per_voxel = 100000;
  o.all_points_pcd = "fused_all.pcd";
  o.write_slice_ms = 0;
  auto stage = FusionStage::create(o, dir);
  ASSERT_TRUE(stage.ok());
  FusionStage& f = **stage;
  feed(f, d);
  f.request_write();
  ASSERT_TRUE(f.write_in_flight());
  ASSERT_TRUE(f.write_model().ok());
  EXPECT_FALSE(f.write_in_flight());
  EXPECT_EQ(f.counters().writes, 1u);
  EXPECT_FALSE(f.last_write().on_writer_thread);
  EXPECT_FALSE(f.poll_write());  // nothing else finished
  auto all = read_pcd(dir + "/fused_all.pcd");
  ASSERT_TRUE(all.ok());
  EXPECT_EQ(all->size(), d.points.size());
  for (const auto& e : std::filesystem::directory_iterator(dir))
    EXPECT_EQ(e.path().string().find(".tmp"), std::string::npos) << e.path();
  std::filesystem::remove_all(dir);
}

TEST(Fusion, WritesOffTheLoopAreCoalescedAndEqualASynchronousWrite) {
  const Dataset d = survey();
  const std::string dir = temp_dir(), sync_dir = temp_dir();
  FusionOptions o;
  o.core.method = "best";
  o.core.max_points_per_voxel = 100000;
  o.all_points_pcd = "fused_all.pcd";
  o.compare_methods = {"position", "visibility"};
  o.write_slice_ms = 0;  // one step (64 model voxels of one core) per turn
  auto stage = FusionStage::create(o, dir);
  auto sync_stage = FusionStage::create(o, sync_dir);
  ASSERT_TRUE(stage.ok());
  ASSERT_TRUE(sync_stage.ok());
  std::vector<ModelWriteReport> reports;
  (*stage)->set_write_callback([&](const ModelWriteReport& r) { reports.push_back(r); });
  feed(**stage, d);
  feed(**sync_stage, d);
  FusionStage& f = **stage;
  f.request_write();
  ASSERT_TRUE(f.write_in_flight());  // the snapshot is still being taken
  // Two requests while it runs: counted, one write follows.
  f.request_write();
  f.request_write();
  EXPECT_EQ(f.counters().writes_coalesced, 2u);
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(60);
  while ((f.write_in_flight() || f.counters().writes < 2u) && std::chrono::steady_clock::now() < deadline) {
    (void)f.poll_write();  // one turn of the loop
    std::this_thread::sleep_for(std::chrono::microseconds(50));
  }
  (void)f.poll_write();
  EXPECT_FALSE(f.write_in_flight());
  EXPECT_EQ(f.counters().writes, 2u);
  EXPECT_EQ(f.counters().write_failures, 0u);
  ASSERT_EQ(reports.size(), 2u);
  EXPECT_TRUE(reports.back().on_writer_thread);
  const std::size_t voxels = f.core().model_voxels() + f.compared_core("position")->model_voxels() +
                             f.compared_core("visibility")->model_voxels();
  // Steps of 64 voxels, one per turn (a turn that finishes a core takes the next core's first step too).
  EXPECT_GE(reports.back().snapshot_slices, voxels / 64 - 2);
  EXPECT_LE(reports.back().snapshot_slices, (voxels + 63) / 64 + 3);
  EXPECT_GE(reports.back().snapshot_span_s, reports.back().snapshot_s * 0.5);
  EXPECT_EQ(reports.back().points, 3 * d.points.size());  // three cores, every point stored
  EXPECT_EQ(reports.back().kept + reports.back().removed, d.points.size());
  ASSERT_TRUE((*sync_stage)->write_model().ok());
  EXPECT_FALSE((*sync_stage)->last_write().on_writer_thread);
  auto file = [](const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    return std::vector<std::uint8_t>(std::istreambuf_iterator<char>(in), {});
  };
  for (const char* name : {"fused.pcd", "fused_all.pcd", "fused.position.pcd", "fused_all.position.pcd",
                           "fused.visibility.pcd", "fused_all.visibility.pcd"}) {
    const auto a = file(dir + "/" + name);
    EXPECT_FALSE(a.empty()) << name;
    EXPECT_EQ(a, file(sync_dir + "/" + name)) << name;
    EXPECT_FALSE(std::filesystem::exists(dir + "/" + name + ".tmp")) << name;
  }
  // The shutdown write after async ones: synchronous, counted.
  ASSERT_TRUE(f.write_model().ok());
  EXPECT_EQ(reports.size(), f.counters().writes);
  EXPECT_FALSE(reports.back().on_writer_thread);

  // A failing write off the loop: counted and reported with its error.
  auto bad = FusionStage::create(o, "/nonexistent/teamscan/station");
  ASSERT_TRUE(bad.ok());
  ModelWriteReport failed;
  (*bad)->set_write_callback([&](const ModelWriteReport& r) { failed = r; });
  (*bad)->request_write();
  (*bad)->wait_for_write();
  EXPECT_TRUE((*bad)->poll_write());
  EXPECT_EQ((*bad)->counters().write_failures, 1u);
  EXPECT_EQ((*bad)->counters().writes, 0u);
  EXPECT_FALSE(failed.ok);
  EXPECT_NE(std::string(failed.error.what).find("fused PCD"), std::string::npos) << failed.error.what;
  std::filesystem::remove_all(dir);
  std::filesystem::remove_all(sync_dir);
}

}  // namespace
}  // namespace teamscan::station

namespace teamscan::station {
namespace {

// teamscan/map publishes the changed voxels (main.cpp): each changed voxel once, with its whole count,
// then nothing until new points arrive; only the voxels the new points fell into.
TEST(Fusion, ChangedMapVoxelsAreThoseWithNewPointsSinceTheLastCall) {
  const std::string dir = temp_dir();
  FusionOptions o;
  o.core.method = "direction";
  o.core.hold_s = 0;  // scans without poses: decided at arrival
  auto stage = FusionStage::create(o, dir);
  ASSERT_TRUE(stage.ok());
  FusionStage& f = **stage;
  const std::int64_t t0 = 1'700'000'000'000'000'000;
  ScanPoints s{};
  s.robot_id = 1;
  s.seq = 1;
  s.stamp = Time::from_ns(t0);
  s.points[s.count++] = ScanPoint{1010, 2010, 310, 0, 0};
  s.points[s.count++] = ScanPoint{1020, 2020, 320, 1, 0};  // same 0.1 m voxel
  s.points[s.count++] = ScanPoint{5010, 2010, 310, 2, 0};
  f.add_scan(s, Receipt{});
  std::vector<teamscan_msg_MapVoxel> changed, full;
  f.map_voxels_changed(changed);
  ASSERT_EQ(changed.size(), 2u);
  EXPECT_EQ(changed[0].hits + changed[1].hits, 3u);
  f.map_voxels_changed(changed);
  EXPECT_TRUE(changed.empty());
  s.seq = 2;
  s.count = 1;  // one more point into the first voxel
  f.add_scan(s, Receipt{});
  f.map_voxels_changed(changed);
  ASSERT_EQ(changed.size(), 1u);
  EXPECT_EQ(changed[0].x_mm, 1050);
  EXPECT_EQ(changed[0].y_mm, 2050);
  EXPECT_EQ(changed[0].hits, 3u);  // the whole count, not the increment
  f.map_voxels(full);
  EXPECT_EQ(full.size(), 2u);
  EXPECT_EQ(f.map_total_voxels(), 2u);
  s.seq = 3;
  f.add_scan(s, Receipt{});
  f.clear_map_changes();  // a full publication covers the changes
  f.map_voxels_changed(changed);
  EXPECT_TRUE(changed.empty());
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace teamscan::station
