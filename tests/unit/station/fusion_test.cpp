// FusionStage fed directly (no DDS) with a small survey: for every method, the model written from the
// core's memory gives every point the decision `teamscan eval` gives it (the core fed in time order),
// whatever order the poses and scans arrive in; the model write is atomic; the teamscan/map voxels
// account for every point; the wire flags map to the data set's; the [fusion] config keys parse.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <set>
#include <numeric>

#include "common/dataset/pcd.hpp"
#include "common/scan_points.hpp"
#include "groundstation/fusion/evaluation.hpp"
#include "groundstation/station/config.hpp"
#include "groundstation/station/fusion.hpp"
#include "teamscan.h"
#include "tests/bench/mapping/synthetic_survey.hpp"

namespace teamscan::station {
namespace {

std::int32_t mm(double m) { return static_cast<std::int32_t>(std::lround(m * 1000.0)); }

// A survey already on the millimetre grid, so the stage sees exactly the data set's values.
Dataset survey() {
  bench::SurveyOptions o;
  o.duration_s = 3.0;
  o.room_m = 6.0;
  o.seed = 3;
  Dataset d = bench::synthetic_survey(o);
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
void feed(FusionStage& stage, const Dataset& d, std::size_t pose_delay = 0,
          const std::function<void(std::int64_t)>& after_scan = {}) {
  static StoredScan scan;
  std::size_t next_odom = 0;
  std::vector<const TrajectorySample*> late;
  std::int64_t clock_ns = 0;
  for (const ScanRecord& r : d.scans) {
    while (next_odom < d.odom.size() && d.odom[next_odom].stamp_ns <= r.stamp_ns) late.push_back(&d.odom[next_odom++]);
    while (late.size() > pose_delay * 2) {  // ~pose_delay scans late (two robots)
      clock_ns = std::max(clock_ns, late.front()->stamp_ns);
      stage.add_pose(pose_observation(*late.front(), clock_ns));
      late.erase(late.begin());
    }
    scan = StoredScan{};
    scan.robot_id = r.robot;
    scan.seq = r.scan;
    scan.stamp_ns = r.stamp_ns;
    clock_ns = std::max(clock_ns, r.stamp_ns);
    scan.recv_realtime_ns = clock_ns;
    scan.origin_x_mm = mm(r.origin.x);
    scan.origin_y_mm = mm(r.origin.y);
    scan.origin_z_mm = mm(r.origin.z);
    for (const LabelledPoint& p : d.points) {
      if (p.robot != r.robot || p.scan != r.scan) continue;
      scan.points[scan.count++] = StoredPoint{mm(p.x), mm(p.y), mm(p.z), p.beam, 0};
    }
    // One beam without an echo: stored by the station, never part of the model.
    scan.points[scan.count++] = StoredPoint{0, 0, 0, 400, kPointInvalid};
    stage.add_scan(scan);
    if (after_scan) after_scan(clock_ns);
  }
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
        mapping::decide_through_core(d, o.core.method, o.core.methods, o.core.tracker);
    const mapping::PreparedDataset prepared = mapping::prepare_dataset(d, o.core.tracker);
    auto filter = mapping::make_filter(o.core.method, o.core.methods);
    const std::vector<std::uint8_t> offline = mapping::run_offline(prepared, *filter);
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

      const std::vector<std::uint8_t> eval = mapping::decide_through_core(d, o.core.method, o.core.methods, o.core.tracker);
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

TEST(Fusion, MapVoxelsAccountForEveryPointAndFlagFullyRemovedVoxels) {
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
  EXPECT_EQ(hits, d.points.size());
  EXPECT_GT(flagged, 0u);
  EXPECT_LT(flagged, voxels.size());
  std::filesystem::remove_all(dir);
}

// One scan of `robot` with `seq` and three points, stamped `stamp_ns`.
StoredScan small_scan(std::uint32_t robot, std::uint32_t seq, std::int64_t stamp_ns) {
  StoredScan s{};
  s.robot_id = robot;
  s.seq = seq;
  s.stamp_ns = stamp_ns;
  s.recv_realtime_ns = stamp_ns + 1'000'000;
  for (std::uint16_t b = 0; b < 3; ++b) s.points[s.count++] = StoredPoint{1000 + 10 * b, 2000, 300, b, 0};
  return s;
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
  for (std::uint32_t seq = 1; seq <= 400; ++seq) f.add_scan(small_scan(1, seq, t0 + seq * kPeriod));
  for (std::uint32_t seq = 1; seq <= 50; ++seq) f.add_scan(small_scan(2, seq, t0 + seq * kPeriod));
  ASSERT_EQ(f.counters().scans, 450u);
  // Robot 1's history (the newest 300) delivered again, and robot 2's last scan: all duplicates.
  for (std::uint32_t seq = 101; seq <= 400; ++seq) f.add_scan(small_scan(1, seq, t0 + seq * kPeriod));
  f.add_scan(small_scan(2, 50, t0));
  EXPECT_EQ(f.counters().duplicates, 301u);
  EXPECT_EQ(f.counters().scans, 450u);
  EXPECT_EQ(f.counters().points, 450u * 3);
  // A gap filled late is new; the same scan again is not.
  f.add_scan(small_scan(2, 60, t0));
  f.add_scan(small_scan(2, 55, t0));
  f.add_scan(small_scan(2, 55, t0));
  EXPECT_EQ(f.counters().scans, 452u);
  EXPECT_EQ(f.counters().duplicates, 302u);
  // Robot 1 restarted: seq 1 again, far below its newest (more than the core's 1024-seq window).
  for (std::uint32_t seq = 401; seq <= 1500; ++seq) f.add_scan(small_scan(1, seq, t0 + seq * kPeriod));
  ASSERT_EQ(f.counters().scans, 452u + 1100u);
  f.add_scan(small_scan(1, 1, t0 + 500 * kPeriod));
  f.add_scan(small_scan(1, 2, t0 + 501 * kPeriod));
  EXPECT_EQ(f.counters().scans, 1554u);
  EXPECT_EQ(f.counters().duplicates, 302u);
  // Jumps larger than the bitmap forget the old window without confusing the new one.
  f.add_scan(small_scan(2, 5000, t0));
  f.add_scan(small_scan(2, 4999, t0));
  f.add_scan(small_scan(2, 5000, t0));
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
  EXPECT_EQ(c.fusion.method, "visibility");
  EXPECT_EQ(c.fusion.write_interval, std::chrono::milliseconds(2500));
  EXPECT_EQ(c.fusion.map_interval.count(), 0);
  const FusionOptions o = fusion_options_from_config(c.fusion, c.kalman);
  EXPECT_DOUBLE_EQ(o.core.methods.visibility.resolution_m, 0.05);
  EXPECT_DOUBLE_EQ(o.core.methods.combined_resolution_m, 0.05);
  EXPECT_NEAR(o.core.methods.direction.half_angle_rad, 5.0 * M_PI / 180.0, 1e-12);
  EXPECT_DOUBLE_EQ(o.core.methods.frequency.k, 0.5);
  EXPECT_EQ(o.all_points_pcd, "fused_all.pcd");
}

TEST(FusionConfig, DefaultsAreBestWithThePapersCombinedParameters) {
  GroundStationConfig c;
  const FusionOptions o = fusion_options_from_config(c.fusion, c.kalman);
  EXPECT_EQ(o.core.method, "best");  // docs/beyond.md: the recommended default
  EXPECT_DOUBLE_EQ(o.core.methods.combined_resolution_m, 0.1);
  EXPECT_NEAR(o.core.methods.combined_half_angle_rad, 7.0 * M_PI / 180.0, 1e-12);
  EXPECT_EQ(o.core.max_points_per_voxel, 64u);
  EXPECT_TRUE(o.all_points_pcd.empty());
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
  StoredScan s{};
  s.robot_id = 1;
  s.seq = 1;
  s.stamp_ns = t0;
  s.points[s.count++] = StoredPoint{1010, 2010, 310, 0, 0};
  s.points[s.count++] = StoredPoint{1020, 2020, 320, 1, 0};  // same 0.1 m voxel
  s.points[s.count++] = StoredPoint{5010, 2010, 310, 2, 0};
  f.add_scan(s);
  std::vector<teamscan_msg_MapVoxel> changed, full;
  f.map_voxels_changed(changed);
  ASSERT_EQ(changed.size(), 2u);
  EXPECT_EQ(changed[0].hits + changed[1].hits, 3u);
  f.map_voxels_changed(changed);
  EXPECT_TRUE(changed.empty());
  s.seq = 2;
  s.count = 1;  // one more point into the first voxel
  f.add_scan(s);
  f.map_voxels_changed(changed);
  ASSERT_EQ(changed.size(), 1u);
  EXPECT_EQ(changed[0].x_mm, 1050);
  EXPECT_EQ(changed[0].y_mm, 2050);
  EXPECT_EQ(changed[0].hits, 3u);  // the whole count, not the increment
  f.map_voxels(full);
  EXPECT_EQ(full.size(), 2u);
  EXPECT_EQ(f.map_total_voxels(), 2u);
  s.seq = 3;
  f.add_scan(s);
  f.clear_map_changes();  // a full publication covers the changes
  f.map_voxels_changed(changed);
  EXPECT_TRUE(changed.empty());
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace teamscan::station
