// Offline evaluation on a small synthetic labelled data set: determinism, JSON shape, live vs offline,
// the tracker feeding the robot filters, method parsing, and the DynamicMap export layout.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <random>
#include <string>
#include <utility>
#include <vector>

#include <unistd.h>

#include "groundstation/mapping/dynamicmap_export.hpp"
#include "groundstation/fusion/evaluation.hpp"
#include "tools/demo/eval_report.hpp"
#include "tests/bench/mapping/synthetic_survey.hpp"

namespace teamscan::mapping {
using demo::report_json;  // the reports are written by the tools
using demo::report_markdown;
using namespace fusion;  // the evaluation (groundstation/fusion/evaluation.hpp)
}  // namespace teamscan::mapping

namespace teamscan::mapping {
namespace {

constexpr std::int64_t kTick = 100'000'000;  // 10 Hz

// Robot 1 stands at (0.5, 2) facing +x and scans the floor, the wall at x = 4 and robot 2, which
// drives along y = 2 from x = 1.5 at 0.2 m/s. Robot 2 scans the floor and the ceiling.
Dataset synthetic_dataset(std::uint64_t seed) {
  Dataset d;
  d.scenario = "synthetic";
  d.seed = seed;
  d.room_m[0] = d.room_m[1] = 4.0;
  d.room_m[2] = 2.5;
  for (std::uint8_t id : {1, 2}) {
    DatasetRobot r;
    r.id = id;
    r.name = "robot" + std::to_string(id);
    r.mount_xyz_m[2] = 0.4;
    r.mount_rpy_rad[1] = id == 1 ? 0.3 : -0.3;
    d.robots.push_back(r);
  }
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(0.0, 4.0), body(-0.15, 0.15), hz(0.1, 0.45);
  std::normal_distribution<double> noise(0.0, 0.003);
  auto robot2_at = [](std::int64_t t_ns) { return Pose2{1.5 + 0.2 * static_cast<double>(t_ns) * 1e-9, 2.0, 0.0}; };
  for (int i = 0; i <= 40; ++i) {
    const std::int64_t t = i * kTick;
    d.odom.push_back({1, t, Pose2{0.5, 2.0, 0.0}, 0.0, 0.0});
    d.odom.push_back({2, t, robot2_at(t), 0.2, 0.0});
  }
  d.truth = d.odom;
  auto add = [&](std::uint8_t robot, std::uint32_t scan, PointClass c, double x, double y, double z) {
    LabelledPoint p;
    p.robot = robot;
    p.scan = scan;
    p.beam = static_cast<std::uint16_t>(d.points.size() % 181);
    p.label = c;
    p.hit_robot = c == PointClass::robot ? 2 : 0;
    p.x = static_cast<float>(x);
    p.y = static_cast<float>(y);
    p.z = static_cast<float>(z);
    p.tx = p.x;
    p.ty = p.y;
    p.tz = p.z;
    d.points.push_back(p);
  };
  for (std::uint32_t s = 0; s < 35; ++s) {
    const std::int64_t t = static_cast<std::int64_t>(s) * kTick + kTick / 2;  // between two poses
    for (std::uint8_t robot : {1, 2}) {
      ScanRecord r;
      r.robot = robot;
      r.scan = s;
      r.stamp_ns = t + robot;  // distinct stamps
      r.pose = robot == 1 ? Pose2{0.5, 2.0, 0.0} : robot2_at(t);
      r.true_pose = r.pose;
      r.origin = {r.pose.x_m, r.pose.y_m, 0.4};
      d.scans.push_back(r);
    }
    const Pose2 p2 = robot2_at(t);
    for (int k = 0; k < 40; ++k) add(1, s, PointClass::floor, u(rng), u(rng), noise(rng));
    for (int k = 0; k < 8; ++k) add(1, s, PointClass::robot, p2.x_m + body(rng), p2.y_m + body(rng), hz(rng));
    for (int k = 0; k < 6; ++k) add(1, s, PointClass::wall, 4.0, u(rng), 0.6 * u(rng));
    for (int k = 0; k < 30; ++k) add(2, s, PointClass::floor, u(rng), u(rng), noise(rng));
    for (int k = 0; k < 10; ++k) add(2, s, PointClass::ceiling, u(rng), u(rng), 2.5 + noise(rng));
  }
  return d;
}

EvalOptions all_methods() {
  EvalOptions o;
  auto methods = parse_methods("all", std::nullopt, std::nullopt);
  EXPECT_TRUE(methods.ok());
  o.methods = methods.value();
  o.ransac.iterations = 200;
  return o;
}

TEST(Evaluation, ParseMethodsExpandsThePaperSettings) {
  auto all = parse_methods("all", std::nullopt, std::nullopt);
  ASSERT_TRUE(all.ok());
  std::vector<std::string> names;
  for (const auto& m : all.value()) names.push_back(m.name);
  EXPECT_EQ(names, (std::vector<std::string>{"frequency@0.05m", "frequency@0.10m", "visibility@0.05m", "visibility@0.10m",
                                             "position", "direction@5.0deg", "direction@7.0deg", "combined@7.0deg,0.10m"}));
  auto one = parse_methods("visibility,direction", 0.1, 6.0);
  ASSERT_TRUE(one.ok());
  ASSERT_EQ(one.value().size(), 2u);
  EXPECT_DOUBLE_EQ(one.value()[0].options.visibility.resolution_m, 0.1);
  EXPECT_NEAR(one.value()[1].options.direction.half_angle_rad, 6.0 * kPi / 180.0, 1e-12);
  EXPECT_FALSE(parse_methods("visibility,bogus", std::nullopt, std::nullopt).ok());
  EXPECT_FALSE(parse_methods("", std::nullopt, std::nullopt).ok());
  EXPECT_FALSE(parse_methods("visibility", -0.1, std::nullopt).ok());
  EXPECT_FALSE(parse_methods("direction", std::nullopt, 95.0).ok());
}

TEST(Evaluation, ProgressRisesThroughEveryMethodAndTable1) {
  const Dataset d = synthetic_dataset(5);
  EvalOptions o = all_methods();
  std::vector<std::pair<std::string, double>> seen;
  o.progress = [&](const std::string& stage, double fraction) { seen.emplace_back(stage, fraction); };
  const EvalReport r = evaluate(d, o).value();
  ASSERT_FALSE(seen.empty());
  EXPECT_EQ(seen.front().second, 0.0);
  for (std::size_t i = 1; i < seen.size(); ++i) EXPECT_GE(seen[i].second, seen[i - 1].second) << seen[i].first;
  for (const auto& [stage, fraction] : seen) {
    EXPECT_GE(fraction, 0.0);
    EXPECT_LT(fraction, 1.0);
  }
  // Every method is named while it is decided and while its metrics are computed, and table 1 in between.
  for (const MethodResult& m : r.methods) {
    EXPECT_TRUE(std::any_of(seen.begin(), seen.end(), [&](const auto& p) { return p.first == m.name + " (fusion core)"; })) << m.name;
    EXPECT_TRUE(std::any_of(seen.begin(), seen.end(), [&](const auto& p) { return p.first == m.name + " (metrics, floor plane)"; }))
        << m.name;
  }
  EXPECT_TRUE(std::any_of(seen.begin(), seen.end(), [](const auto& p) { return p.first.rfind("table 1", 0) == 0; }));
  // Within a method's decisions it reports more than once (about every 1 % of the time line).
  EXPECT_GT(seen.size(), 3 * r.methods.size());
}

TEST(Evaluation, IsDeterministicForASeed) {
  const Dataset d = synthetic_dataset(5);
  const EvalOptions o = all_methods();
  const std::string a = report_json(evaluate(d, o).value(), "cmd");
  const std::string b = report_json(evaluate(d, o).value(), "cmd");
  EXPECT_EQ(a, b);
  EvalOptions other = o;
  other.ransac.seed = 2;
  // A different RANSAC seed changes at most the plane figures, never the removal counts.
  const EvalReport r1 = evaluate(d, o).value(), r2 = evaluate(d, other).value();
  for (std::size_t i = 0; i < r1.methods.size(); ++i) EXPECT_EQ(r1.methods[i].removed, r2.methods[i].removed);
}

TEST(Evaluation, JsonHasTheIssuesKeysPerMethod) {
  const Dataset d = synthetic_dataset(5);
  const std::string json = report_json(evaluate(d, all_methods()).value(), "teamscan eval x");
  for (const char* key : {"\"name\"", "\"params\"", "\"ghost_removed_pct\"", "\"other_removed_pct\"",
                          "\"plane_error_improvement_pct\"", "\"plane_inlier_improvement_pct\"", "\"SA\"", "\"DA\"",
                          "\"AA\"", "\"HA\"", "\"kept_by_class\"", "\"table1\"", "\"counts\"", "\"floor\"",
                          "\"furniture\"", "\"command\": \"teamscan eval x\""})
    EXPECT_NE(json.find(key), std::string::npos) << key;
  // One "ghost_removed_pct" per method: 8 methods for "all".
  std::size_t n = 0;
  for (std::size_t at = json.find("\"ghost_removed_pct\""); at != std::string::npos; at = json.find("\"ghost_removed_pct\"", at + 1)) ++n;
  EXPECT_EQ(n, 8u);
}

TEST(Evaluation, TrackerFedRobotFiltersFindTheMovingTeammate) {
  const Dataset d = synthetic_dataset(9);
  EvalOptions o;
  o.methods = parse_methods("position,direction", std::nullopt, 7.0).value();
  const EvalReport r = evaluate(d, o).value();
  ASSERT_EQ(r.methods.size(), 2u);
  std::uint64_t ghosts = 35 * 8;
  EXPECT_EQ(r.ghosts, ghosts);
  // Ghosts lie within 0.15·√2 ≈ 0.21 m of robot 2's centre < σ = 0.35 m: all found by position.
  EXPECT_EQ(r.methods[0].removal.ghosts_removed, ghosts);
  // Robot 1 looks at robot 2 from ≥ 1 m: ±0.15 m across is ≤ 8.5°, so most but not all are in a 7° cone.
  EXPECT_GT(r.methods[1].removal.da, 50.0);
  EXPECT_LT(r.methods[1].removal.da, 100.0);
  // Robot 2's own scans never remove anything for robot 1, which is behind it (not ahead along L).
  EXPECT_GT(r.methods[1].removal.sa, 90.0);
}

TEST(Evaluation, LiveAndOfflineAgreeForRobotFiltersAndMapFiltersConvergeAtTheEnd) {
  const Dataset d = synthetic_dataset(3);
  const PreparedDataset prepared = prepare_dataset(d, {});
  ASSERT_EQ(prepared.scans.size(), 70u);
  ASSERT_EQ(prepared.points.size(), d.points.size());
  for (const char* m : {"position", "direction"}) {
    auto f = make_filter(m, {});
    EXPECT_EQ(run_live(prepared, *f), run_offline(prepared, *f)) << m;
  }
  // Visibility live: a point's decision only uses the map so far, so the last scan decides the same.
  auto f = make_filter("visibility", {});
  const auto live = run_live(prepared, *f);
  const auto offline = run_offline(prepared, *f);
  const PreparedScan& last = prepared.scans.back();
  for (std::size_t i = last.first; i < last.first + last.count; ++i)
    EXPECT_EQ(live[prepared.source_index[i]], offline[prepared.source_index[i]]);
}

TEST(Evaluation, MarkdownHasTheTableTheParametersAndTheCommand) {
  const Dataset d = synthetic_dataset(5);
  const std::string md = report_markdown(evaluate(d, all_methods()).value(), "teamscan eval DIR --seed 1");
  EXPECT_NE(md.find("| method | % ghost | % other |"), std::string::npos);
  EXPECT_NE(md.find("**Table 1**"), std::string::npos);
  EXPECT_NE(md.find("RANSAC: threshold 0.02 m, 200 iterations, seed 1"), std::string::npos);
  EXPECT_NE(md.find("Reproduce: `teamscan eval DIR --seed 1`"), std::string::npos);
}

TEST(DynamicMapExport, WritesOnePcdPerScanWithViewpointAndALabelledGroundTruth) {
  const Dataset d = synthetic_dataset(4);
  const std::string dir = ::testing::TempDir() + "/mapping_export_" + std::to_string(::getpid());
  auto summary = export_dynamicmap(d, dir);
  ASSERT_TRUE(summary.ok());
  EXPECT_EQ(summary.value().frames, 70u);
  EXPECT_EQ(summary.value().points, d.points.size());
  EXPECT_EQ(summary.value().dynamic_points, 35u * 8u);
  ASSERT_TRUE(std::filesystem::exists(dir + "/pcd/000000.pcd"));
  ASSERT_TRUE(std::filesystem::exists(dir + "/pcd/000069.pcd"));
  EXPECT_FALSE(std::filesystem::exists(dir + "/pcd/000070.pcd"));
  // First frame: robot 1 at (0.5, 2, 0.4), mount pitch 0.3 rad → q = (cos 0.15, 0, sin 0.15, 0).
  std::ifstream f0(dir + "/pcd/000000.pcd");
  std::string line, viewpoint, points;
  while (std::getline(f0, line) && line != "DATA binary") {
    if (line.rfind("VIEWPOINT", 0) == 0) viewpoint = line;
    if (line.rfind("POINTS", 0) == 0) points = line;
  }
  double v[7];
  ASSERT_EQ(std::sscanf(viewpoint.c_str(), "VIEWPOINT %lf %lf %lf %lf %lf %lf %lf", &v[0], &v[1], &v[2], &v[3], &v[4], &v[5], &v[6]), 7);
  EXPECT_NEAR(v[0], 0.5, 1e-6);
  EXPECT_NEAR(v[1], 2.0, 1e-6);
  EXPECT_NEAR(v[2], 0.4, 1e-6);
  EXPECT_NEAR(v[3], std::cos(0.15), 1e-6);
  EXPECT_NEAR(v[4], 0.0, 1e-6);
  EXPECT_NEAR(v[5], std::sin(0.15), 1e-6);
  EXPECT_NEAR(v[6], 0.0, 1e-6);
  EXPECT_EQ(points, "POINTS 54");  // robot 1's scan: 40 floor + 8 ghost + 6 wall
  // Binary payload: exactly 54 × 3 floats after the header.
  const auto size = std::filesystem::file_size(dir + "/pcd/000000.pcd");
  std::ifstream again(dir + "/pcd/000000.pcd", std::ios::binary);
  std::string all((std::istreambuf_iterator<char>(again)), std::istreambuf_iterator<char>());
  EXPECT_EQ(size - (all.find("DATA binary\n") + 12), 54u * 12u);
  // gt_cloud: intensity field, label 1 exactly for the ghosts.
  std::ifstream gt(dir + "/gt_cloud.pcd", std::ios::binary);
  std::string gt_all((std::istreambuf_iterator<char>(gt)), std::istreambuf_iterator<char>());
  EXPECT_NE(gt_all.find("FIELDS x y z intensity\n"), std::string::npos);
  const std::size_t data = gt_all.find("DATA binary\n") + 12;
  ASSERT_EQ(gt_all.size() - data, d.points.size() * 16);
  for (std::size_t i = 0; i < d.points.size(); ++i) {
    float label = -1;
    std::memcpy(&label, gt_all.data() + data + i * 16 + 12, 4);
    ASSERT_EQ(label, d.points[i].is_ghost() ? 1.0f : 0.0f) << i;
  }
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace teamscan::mapping

// ---- properties on a ray-cast survey (tests/bench/mapping/synthetic_survey.hpp) ----
namespace teamscan::mapping {
namespace {

const Dataset& survey() {
  static const Dataset d = [] {
    bench::SurveyOptions o;
    o.duration_s = 8.0;
    return bench::synthetic_survey(o);
  }();
  return d;
}

std::vector<std::uint8_t> removed_by(const std::string& method, const MethodOptions& options) {
  const PreparedDataset p = prepare_dataset(survey(), {});
  auto f = make_filter(method, options);
  return run_offline(p, *f);
}

TEST(SurveyProperties, SurveyHasGhostsAndEveryClass) {
  const RemovalMetrics m = removal_metrics(survey().points, std::vector<std::uint8_t>(survey().points.size(), 0));
  EXPECT_GT(m.ghosts, 50u);
  for (PointClass c : {PointClass::floor, PointClass::wall, PointClass::ceiling, PointClass::furniture})
    EXPECT_GT(m.by_class[static_cast<std::size_t>(c)].total, 0u) << static_cast<int>(c);
}

TEST(SurveyProperties, VisibilityKeepsExactlyEachColumnsLowestVoxel) {
  MethodOptions o;
  o.visibility.resolution_m = 0.1;
  const auto removed = removed_by("visibility", o);
  VoxelMap map(0.1);
  for (const LabelledPoint& p : survey().points) map.insert({p.x, p.y, p.z});
  for (std::size_t i = 0; i < removed.size(); ++i) {
    const LabelledPoint& p = survey().points[i];
    const VoxelKey k = map.key_of({p.x, p.y, p.z});
    ASSERT_EQ(removed[i] != 0, *map.column_lowest_z(k.x, k.y) < k.z) << i;
  }
}

TEST(SurveyProperties, FrequencyRemovesExactlyTheVoxelsBelowTheMean) {
  MethodOptions o;
  o.frequency.resolution_m = 0.05;
  const auto removed = removed_by("frequency", o);
  VoxelMap map(0.05);
  for (const LabelledPoint& p : survey().points) map.insert({p.x, p.y, p.z});
  // Mean recomputed here by a plain pass over the voxels (not the map's running sums).
  double sum = 0;
  std::size_t n = 0;
  map.for_each_voxel([&](VoxelKey, std::uint32_t c) { sum += c; ++n; });
  const double mean = sum / static_cast<double>(n);
  for (std::size_t i = 0; i < removed.size(); ++i) {
    const LabelledPoint& p = survey().points[i];
    ASSERT_EQ(removed[i] != 0, static_cast<double>(map.count_at({p.x, p.y, p.z})) < mean) << i;
  }
}

TEST(SurveyProperties, CombinedRemovesEverythingDirectionRemovesAndMore) {
  MethodOptions o;
  const auto direction = removed_by("direction", o);  // 7° default
  const auto combined = removed_by("combined", o);
  std::size_t extra = 0;
  for (std::size_t i = 0; i < direction.size(); ++i) {
    if (direction[i]) {
      ASSERT_TRUE(combined[i]) << i;
    }
    if (combined[i] && !direction[i]) ++extra;
  }
  EXPECT_GT(extra, 0u);
}

TEST(SurveyProperties, WiderConeRemovesASuperset) {
  MethodOptions five, seven;
  five.direction.half_angle_rad = 5.0 * kPi / 180.0;
  seven.direction.half_angle_rad = 7.0 * kPi / 180.0;
  const auto a = removed_by("direction", five), b = removed_by("direction", seven);
  for (std::size_t i = 0; i < a.size(); ++i)
    if (a[i]) {
      ASSERT_TRUE(b[i]) << i;
    }
}

}  // namespace
}  // namespace teamscan::mapping

namespace teamscan::mapping {
namespace {

TEST(EvaluationEdges, EmptyDataSetGivesNullsNotACrash) {
  const Dataset empty;
  EvalOptions o;
  o.methods = parse_methods("all", std::nullopt, std::nullopt).value();
  const EvalReport r = evaluate(empty, o).value();
  EXPECT_EQ(r.points, 0u);
  EXPECT_FALSE(r.table1.with_ghosts.found);
  const std::string json = report_json(r, "x");
  EXPECT_NE(json.find("\"DA\": null"), std::string::npos);
  EXPECT_NE(json.find("\"plane_error_improvement_pct\": null"), std::string::npos);
}

TEST(EvaluationEdges, NonFinitePointsAndScansMissingFromScansCsvAreHandled) {
  Dataset d = synthetic_dataset(2);
  LabelledPoint bad = d.points.front();
  bad.x = NAN;
  d.points.push_back(bad);
  LabelledPoint orphan = d.points.front();
  orphan.scan = 999;  // no scans.csv row
  d.points.push_back(orphan);
  EvalOptions o;
  o.methods = parse_methods("all", std::nullopt, std::nullopt).value();
  const EvalReport r = evaluate(d, o).value();
  EXPECT_EQ(r.orphan_points, 1u);
  EXPECT_EQ(r.points, d.points.size());
  for (const MethodResult& m : r.methods) EXPECT_EQ(m.removed.size(), d.points.size());
  EXPECT_TRUE(r.table1.with_ghosts.found);
}

}  // namespace
}  // namespace teamscan::mapping
