// The simulator end to end (in memory): scan timing from the baud, labels against geometry,
// determinism, client-side points against the truth, and ghosts in both shipped scenarios.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <unistd.h>

#include <string>
#include <vector>

#include "sim/simulator.hpp"

namespace teamscan::sim {
namespace {

Scenario load(const char* name) {
  const char* src = std::getenv("TEAMSCAN_SOURCE_DIR");
  const ScenarioLoad l = load_scenario_file(std::string{src ? src : "."} + "/sim/scenarios/" + name + ".toml");
  if (!l.scenario) {
    ADD_FAILURE() << l.error;
    return {};
  }
  return *l.scenario;
}

TEST(ScanTiming, PeriodFollowsTheMirrorAndTheBaud) {
  // §2.10: 181 values fit a 13.3 ms revolution at 500 kBd (372 bytes = 7.44 ms) ...
  EXPECT_EQ(lms_b0_telegram_bytes(181), 372u);
  EXPECT_EQ(lms_b0_telegram_bytes(361), 732u);
  EXPECT_EQ(lms_scan_period({180, 100}, 500000), kLmsRevolution);
  // ... 0.5° interlaces two revolutions ...
  EXPECT_EQ(lms_scan_period({180, 50}, 500000), 2 * kLmsRevolution);
  // ... and at 38400 baud 96.9 ms of telegram take 8 revolutions (≈ 9.4 scans/s, "~10 scans/s").
  EXPECT_EQ(lms_scan_period({180, 100}, 38400), 8 * kLmsRevolution);
  EXPECT_EQ(lms_scan_period({180, 50}, 38400), 8 * 2 * kLmsRevolution);  // 190.6 ms → 8 sweeps of 26.7 ms
  EXPECT_EQ(lms_scan_period({100, 25}, 500000), 4 * kLmsRevolution);
}

TEST(OdometryHistoryTest, InterpolatesAndClamps) {
  PoseHistory h;
  h.push(0, {0, 0, 0});
  h.push(100, {1, 2, 0.2});
  EXPECT_NEAR(h.at(50).x_m, 0.5, 1e-12);
  EXPECT_NEAR(h.at(25).theta_rad, 0.05, 1e-12);
  EXPECT_NEAR(h.at(-10).x_m, 0.0, 1e-12);
  EXPECT_NEAR(h.at(1000).y_m, 2.0, 1e-12);
}

// The direct simulation places beams with the robot's own interpolation: through a turn whose rate
// changes, its heading is the odometry history's, not the chord's.
TEST(OdometryHistoryTest, PlacesLikeTheRobotsOwnHistoryThroughATurn) {
  PoseHistory h;
  OdometryHistory<> robot;
  for (int i = 0; i < 4; ++i) {
    const Pose2 pose{0.03 * i, 0.0, 20.0 * 0.01 * i * i};  // heading 20 t² rad: the rate grows 4 rad/s a cycle
    h.push(i * 100'000'000LL, pose);
    ASSERT_TRUE(robot.push(Time::from_ns(i * 100'000'000LL), pose));
  }
  for (std::int64_t t_ns = 105'000'000; t_ns < 300'000'000; t_ns += 10'000'000) {
    const Result<Pose2> expected = robot.interpolate(Time::from_ns(t_ns));
    ASSERT_TRUE(expected.ok());
    EXPECT_DOUBLE_EQ(h.at(t_ns).theta_rad, expected->theta_rad) << t_ns;
    EXPECT_DOUBLE_EQ(h.at(t_ns).x_m, expected->x_m) << t_ns;
  }
  EXPECT_NEAR(h.at(150'000'000).theta_rad, 20.0 * 0.15 * 0.15, 1e-9);  // on the parabola; the chord says 0.5
}

// A short Lap2 run shared by the label tests.
const SimOutput& short_lap2() {
  static const SimOutput out = [] {
    SimOptions o;
    o.duration_s = 25.0;
    return simulate(load("lap2"), o);
  }();
  return out;
}

TEST(Labels, FloorPointsLieOnTheFloorWithinTheNoise) {
  const SimOutput& out = short_lap2();
  std::size_t floor = 0;
  double sum_abs = 0;
  for (const LabelledPoint& p : out.dataset.points) {
    if (p.label != PointClass::floor) continue;
    ++floor;
    EXPECT_NEAR(p.tz, 0.0f, 1e-5f);
    // Only the range noise (σ 5 mm) moves a floor point off z = 0: planar odometry leaves z alone.
    EXPECT_NEAR(p.z, 0.0f, 0.03f) << "robot " << int(p.robot) << " scan " << p.scan << " beam " << p.beam;
    sum_abs += std::abs(p.z);
  }
  ASSERT_GT(floor, 1000u);
  EXPECT_LT(sum_abs / static_cast<double>(floor), 0.005);
}

TEST(Labels, GhostPointsLieOnTheOtherRobotsBody) {
  const SimOutput& out = short_lap2();
  const Scenario sc = load("lap2");
  const TeamWorld team{sc};
  std::size_t ghosts = 0;
  for (const LabelledPoint& p : out.dataset.points) {
    if (!p.is_ghost()) continue;
    ++ghosts;
    ASSERT_NE(p.hit_robot, p.robot);
    const ScanRecord& scan = *std::find_if(out.dataset.scans.begin(), out.dataset.scans.end(), [&](const ScanRecord& s) {
      return s.robot == p.robot && s.scan == p.scan;
    });
    const std::size_t self = p.robot == sc.robots[0].id ? 0 : 1;
    const std::size_t other = 1 - self;
    const LaserVariant variant = sc.robots[self].variant;
    const double beam_s = static_cast<double>(scan.stamp_ns - sc.start_time_ns - variant.beam_age(p.beam).count()) * 1e-9;
    // The true hit point in the hit robot's frame at the beam's time lies on its body's surface.
    const Pose2 other_pose = team.motion(other).pose_at(beam_s);
    const Pose2 inv = other_pose.inverse();
    const Vec2 local = inv.apply({p.tx, p.ty});
    const RobotBody& body = team.body(other);
    const double eps = 1e-3;
    EXPECT_GE(local.x, body.bound_min_m.x - eps);
    EXPECT_LE(local.x, body.bound_max_m.x + eps);
    EXPECT_GE(local.y, body.bound_min_m.y - eps);
    EXPECT_LE(local.y, body.bound_max_m.y + eps);
    EXPECT_GE(p.tz, body.bound_min_m.z - eps);
    EXPECT_LE(p.tz, body.bound_max_m.z + eps);
    // The measured point is near the true one: odometry drift over 25 s stays within decimetres.
    EXPECT_LT(std::hypot(p.x - p.tx, p.y - p.ty), 0.3);
  }
  EXPECT_GT(ghosts, 0u);
}

TEST(ClientPath, WithoutNoiseThePointsEqualTheTruthToTheQuantisation) {
  Scenario sc = load("lap2");
  for (RobotSpec& r : sc.robots) {
    r.range_noise_mm = 0;
    r.odometry = {};
  }
  SimOptions o;
  o.duration_s = 10.0;
  const SimOutput out = simulate(sc, o);
  ASSERT_FALSE(out.dataset.points.empty());
  double worst = 0;
  std::size_t within_1cm = 0;
  for (const LabelledPoint& p : out.dataset.points) {
    const double err = std::sqrt((p.x - p.tx) * (p.x - p.tx) + (p.y - p.ty) * (p.y - p.ty) + (p.z - p.tz) * (p.z - p.tz));
    worst = std::max(worst, err);
    within_1cm += err < 0.01;
  }
  // THPOS counts of 2π/4096 rad (≤ 11 mm at 8 m), 1 mm odometry counts, 1 mm ranges and linear
  // interpolation between 100 ms SIPs: centimetre agreement. The worst case is a scan right at the
  // start, whose SIPs straddle the instant the robot starts driving (motion has no acceleration ramp).
  EXPECT_GT(static_cast<double>(within_1cm), 0.99 * static_cast<double>(out.dataset.points.size()));
  EXPECT_LT(worst, 0.05);
}

TEST(Determinism, SameSeedSameDataDifferentSeedDifferentData) {
  Scenario sc = load("lap2");
  SimOptions o;
  o.duration_s = 5.0;
  const SimOutput a = simulate(sc, o), b = simulate(sc, o);
  o.seed = 99;
  const SimOutput c = simulate(sc, o);
  ASSERT_EQ(a.dataset.points.size(), b.dataset.points.size());
  EXPECT_EQ(0, std::memcmp(a.dataset.points.data(), b.dataset.points.data(), a.dataset.points.size() * sizeof(LabelledPoint)));
  ASSERT_EQ(a.dataset.odom.size(), b.dataset.odom.size());
  for (std::size_t i = 0; i < a.dataset.odom.size(); ++i) EXPECT_EQ(a.dataset.odom[i].pose.x_m, b.dataset.odom[i].pose.x_m);
  bool differs = a.dataset.points.size() != c.dataset.points.size();
  for (std::size_t i = 0; !differs && i < a.dataset.points.size(); ++i) differs = a.dataset.points[i].x != c.dataset.points[i].x;
  EXPECT_TRUE(differs);
  EXPECT_EQ(c.dataset.seed, 99u);
}

// The long-run registration scenario: built in, ten minutes of two robots looping through the ring
// corridor; deterministic (its scans over a short stretch, its dead reckoning over the whole run); and
// odometry alone ends more than 2 m off for every robot (the drift the registration has to undo).
TEST(Scenarios, LoopsTenMinutesDriftMoreThanTwoMetres) {
  const std::vector<std::string> names = builtin_scenario_names();
  EXPECT_NE(std::find(names.begin(), names.end(), "loops2-drift"), names.end());
  const ScenarioLoad byname = resolve_scenario("loops2-drift");
  ASSERT_TRUE(byname.scenario) << byname.error;
  const Scenario& sc = *byname.scenario;
  ASSERT_EQ(sc.robots.size(), 2u);
  EXPECT_DOUBLE_EQ(sc.duration_s.value_or(0.0), 600.0);

  SimOptions shortrun;
  shortrun.device_streams = false;
  shortrun.duration_s = 2.0;
  const SimOutput a = simulate(sc, shortrun), b = simulate(sc, shortrun);
  ASSERT_GT(a.dataset.points.size(), 0u);
  ASSERT_EQ(a.dataset.points.size(), b.dataset.points.size());
  EXPECT_EQ(0, std::memcmp(a.dataset.points.data(), b.dataset.points.data(), a.dataset.points.size() * sizeof(LabelledPoint)));

  SimOptions odometry;
  odometry.device_streams = false;
  odometry.scans = false;
  const SimOutput full = simulate(sc, odometry), again = simulate(sc, odometry);
  EXPECT_TRUE(full.dataset.points.empty());
  EXPECT_TRUE(full.dataset.scans.empty());
  ASSERT_EQ(full.dataset.odom.size(), again.dataset.odom.size());
  ASSERT_EQ(full.dataset.odom.size(), full.dataset.truth.size());
  for (std::size_t i = 0; i < full.dataset.odom.size(); ++i) {
    ASSERT_EQ(full.dataset.odom[i].pose.x_m, again.dataset.odom[i].pose.x_m) << i;
    ASSERT_EQ(full.dataset.odom[i].pose.y_m, again.dataset.odom[i].pose.y_m) << i;
    ASSERT_EQ(full.dataset.odom[i].pose.theta_rad, again.dataset.odom[i].pose.theta_rad) << i;
  }
  // Each robot's last odometry pose against its truth at the same instant (odom and truth are written
  // row for row, one per SIP cycle).
  for (const RobotSpec& r : sc.robots) {
    double end_error_m = -1.0, path_m = 0.0;
    const TrajectorySample* prev = nullptr;
    for (std::size_t i = 0; i < full.dataset.odom.size(); ++i) {
      if (full.dataset.odom[i].robot != r.id) continue;
      const Pose2& o = full.dataset.odom[i].pose;
      const TrajectorySample& t = full.dataset.truth[i];
      ASSERT_EQ(t.robot, r.id);
      ASSERT_EQ(t.stamp_ns, full.dataset.odom[i].stamp_ns);
      if (prev) path_m += std::hypot(t.pose.x_m - prev->pose.x_m, t.pose.y_m - prev->pose.y_m);
      prev = &t;
      end_error_m = std::hypot(o.x_m - t.pose.x_m, o.y_m - t.pose.y_m);
    }
    EXPECT_GT(end_error_m, 2.0) << "robot " << int{r.id};
    EXPECT_GT(path_m, 150.0) << "robot " << int{r.id};  // about seven laps of the 26 m ring
  }
}

TEST(Scenarios, BothShippedScenariosHaveGhostsFromBothRobots) {
  for (const char* name : {"lap2", "fig8"}) {
    const SimOutput out = simulate(load(name), {});
    ASSERT_EQ(out.stats.size(), 2u);
    std::uint64_t points = 0, ghosts = 0;
    for (const RobotStats& s : out.stats) {
      std::printf("[%s] robot %d: %llu scans, %llu points, %llu ghosts\n", name, s.id,
                  static_cast<unsigned long long>(s.scans), static_cast<unsigned long long>(s.points),
                  static_cast<unsigned long long>(s.ghosts));
      EXPECT_GT(s.ghosts, 0u) << name << " robot " << int(s.id);
      points += s.points;
      ghosts += s.ghosts;
    }
    std::printf("[%s] ghost share %.3f %% of %llu points (duration %.1f s)\n", name, 100.0 * ghosts / points,
                static_cast<unsigned long long>(points), out.dataset.duration_s);
  }
}

TEST(Scenarios, ThreeRobotsWithFurnitureAndPauses) {
  const SimOutput out = simulate(load("team3"), {});
  ASSERT_EQ(out.stats.size(), 3u);
  std::size_t furniture = 0;
  for (const LabelledPoint& p : out.dataset.points) furniture += p.label == PointClass::furniture;
  EXPECT_GT(furniture, 0u);
  // Robot 2 scans 0.5° over 38400 baud: a 732-byte telegram takes 190.6 ms (§2.10), so at most one
  // scan per 190.6 ms, and the scanner sends the newest complete scan (one per 26.7 ms) when free.
  const double tx_s = to_seconds(serial_transmission_time(732, 38400));
  EXPECT_LE(static_cast<double>(out.stats[1].scans), 60.0 / tx_s + 1);
  EXPECT_GE(static_cast<double>(out.stats[1].scans), 60.0 / (tx_s + 2 * 0.02667) - 1);
  // Robot 3 pauses at 10..15 s: its true pose does not change then.
  const auto& truth = out.dataset.truth;
  const TrajectorySample* a = nullptr;
  const TrajectorySample* b = nullptr;
  for (const auto& t : truth) {
    if (t.robot != 3) continue;
    const std::int64_t t0 = load("team3").start_time_ns;
    if (std::abs(t.stamp_ns - t0 - 11'000'000'000) < 60'000'000) a = &t;
    if (std::abs(t.stamp_ns - t0 - 14'000'000'000) < 60'000'000) b = &t;
  }
  ASSERT_TRUE(a && b);
  EXPECT_EQ(a->pose.x_m, b->pose.x_m);
  EXPECT_EQ(a->v_mps, 0.0);
}

}  // namespace
}  // namespace teamscan::sim

#include <filesystem>
#include <fstream>
#include <sstream>

namespace teamscan::sim {
namespace {

std::string slurp(const std::filesystem::path& p) {
  std::ifstream in{p, std::ios::binary};
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

TEST(Determinism, SameSeedGivesByteIdenticalFiles) {
  const auto base = std::filesystem::temp_directory_path() / ("teamscan_sim_det_" + std::to_string(::getpid()));
  Scenario sc = load("team3");
  SimOptions o;
  o.duration_s = 4.0;
  std::vector<std::string> captures[2];
  int k = 0;
  for (const char* run : {"a", "b"}) {
    const SimOutput out = simulate(sc, o);
    ASSERT_TRUE(write_dataset((base / run).string(), out.dataset).ok());
    for (const RobotCaptures& c : out.captures) {
      captures[k].push_back(format_capture(c.arcos));
      captures[k].push_back(format_capture(c.lms200));
    }
    ++k;
  }
  ASSERT_EQ(captures[0].size(), 6u);  // three robots, two devices each
  EXPECT_TRUE(captures[0] == captures[1]) << "captures differ between two runs with the same seed";
  for (const char* f : {"dataset.toml", "points.pcd", "scans.csv", "truth.csv", "odom.csv"}) {
    const std::string a = slurp(base / "a" / f), b = slurp(base / "b" / f);
    EXPECT_FALSE(a.empty()) << f;
    EXPECT_TRUE(a == b) << f << " differs between two runs with the same seed";
  }
  std::filesystem::remove_all(base);
}

}  // namespace
}  // namespace teamscan::sim
