// Scenario TOML: the shipped files load, defaults apply, and malformed input names the key.
#include <gtest/gtest.h>

#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>
#include <string>

#include "sim/scenario.hpp"

namespace teamscan::sim {
namespace {

std::string scenario_dir() {
  const char* src = std::getenv("TEAMSCAN_SOURCE_DIR");
  return std::string{src ? src : "."} + "/sim/scenarios/";
}

TEST(Scenario, ShippedScenariosLoad) {
  for (const char* name : {"lap2", "fig8", "team3"}) {
    const ScenarioLoad load = load_scenario_file(scenario_dir() + name + ".toml");
    ASSERT_TRUE(load.scenario.has_value()) << load.error;
    EXPECT_EQ(load.scenario->name, name);
    EXPECT_GE(load.scenario->robots.size(), 2u);
  }
  const ScenarioLoad lap2 = load_scenario_file(scenario_dir() + "lap2.toml");
  ASSERT_TRUE(lap2.scenario);
  const Scenario& s = *lap2.scenario;
  ASSERT_EQ(s.robots.size(), 2u);
  EXPECT_EQ(s.robots[0].role, "down-laser");
  EXPECT_EQ(s.robots[1].role, "up-laser");
  EXPECT_GT(s.robots[0].mount_rpy_rad[1], 0.0);  // pitched down
  EXPECT_LT(s.robots[1].mount_rpy_rad[1], 0.0);  // pitched up
  ASSERT_TRUE(s.robots[1].start_phase.has_value());
  EXPECT_DOUBLE_EQ(*s.robots[1].start_phase, 0.5);
  const ScenarioLoad team3 = load_scenario_file(scenario_dir() + "team3.toml");
  ASSERT_TRUE(team3.scenario);
  EXPECT_EQ(team3.scenario->robots.size(), 3u);
  EXPECT_EQ(team3.scenario->furniture.size(), 3u);
  EXPECT_EQ(team3.scenario->robots[2].pauses.size(), 2u);
  EXPECT_EQ(team3.scenario->robots[1].variant.beams(), 361);
}

TEST(Scenario, DriftScenariosLoadWithTheirSkidSteerTerms) {
  for (const char* name : {"lap2-drift", "corridor2", "team3-drift", "loops2-drift"}) {
    const ScenarioLoad load = load_scenario_file(scenario_dir() + name + ".toml");
    ASSERT_TRUE(load.scenario.has_value()) << load.error;
    EXPECT_EQ(load.scenario->name, name);
    for (const RobotSpec& r : load.scenario->robots) EXPECT_GT(r.odometry.slip, 0.0) << name;
  }
  const ScenarioLoad lap2 = load_scenario_file(scenario_dir() + "lap2-drift.toml");
  ASSERT_TRUE(lap2.scenario);
  const OdometryNoise& o = lap2.scenario->robots[0].odometry;
  EXPECT_DOUBLE_EQ(o.slip, 0.02);
  EXPECT_DOUBLE_EQ(o.turn_slip, 0.005);
  EXPECT_NEAR(o.drift_rad_per_m, 0.25 * kPi / 180.0, 1e-15);
  EXPECT_NEAR(o.heading_walk_rad_per_sqrt_m, 0.05 * kPi / 180.0, 1e-15);
  EXPECT_DOUBLE_EQ(*lap2.scenario->duration_s, 180.0);
  const ScenarioLoad bad = parse_scenario("[[robot]]\n[robot.track]\n[robot.odometry]\nslip_percent = 80\n", "bad.toml");
  EXPECT_FALSE(bad.scenario);
  EXPECT_NE(bad.error.find("robot[0].odometry.slip_percent:"), std::string::npos) << bad.error;
}

TEST(Scenario, MinimalFileGetsDefaults) {
  const ScenarioLoad load = parse_scenario("[[robot]]\n[robot.track]\nkind = \"oval\"\n", "min.toml");
  ASSERT_TRUE(load.scenario) << load.error;
  const RobotSpec& r = load.scenario->robots[0];
  EXPECT_EQ(r.id, 1);
  EXPECT_EQ(r.name, "robot1");
  EXPECT_EQ(r.subclass, "p3at-sh");
  EXPECT_EQ(r.variant.beams(), 181);
  EXPECT_EQ(r.lms_baud, 500000u);
  EXPECT_DOUBLE_EQ(r.range_noise_mm, 5.0);
  EXPECT_DOUBLE_EQ(r.max_turn_rate_deg_s, 140.0);
  EXPECT_EQ(r.track.spline, Track::Spline::uniform);
  EXPECT_EQ(load.scenario->name, "min");
  const ScenarioLoad set = parse_scenario(
      "[[robot]]\nmax_turn_rate_deg_s = 0\n[robot.track]\nkind = \"waypoints\"\npoints_m = [[0, 0], [1, 0]]\nspline = \"centripetal\"\n",
      "set.toml");
  ASSERT_TRUE(set.scenario) << set.error;
  EXPECT_DOUBLE_EQ(set.scenario->robots[0].max_turn_rate_deg_s, 0.0);
  EXPECT_EQ(set.scenario->robots[0].track.spline, Track::Spline::centripetal);
}

struct BadCase {
  const char* toml;
  const char* key;
};

TEST(Scenario, MalformedInputNamesTheKey) {
  const BadCase cases[] = {
      {"[room]\nsize_m = [9, 7]\n[[robot]]\n[robot.track]\n", "room.size_m"},
      {"[room]\nsize_m = [20, 7, 3]\n[[robot]]\n[robot.track]\n", "room.size_m"},
      {"[[robot]]\nspeed_mps = \"fast\"\n[robot.track]\n", "robot[0].speed_mps"},
      {"[[robot]]\n[robot.track]\n[[robot]]\nsped_mps = 1\n[robot.track]\n", "robot[1].sped_mps"},
      {"[[robot]]\n[robot.track]\nkind = \"square\"\n", "robot[0].track.kind"},
      {"[[robot]]\n[robot.track]\n[robot.laser]\nresolution_deg = 0.3\n", "robot[0].laser.resolution_deg"},
      {"[[robot]]\n[robot.track]\n[robot.laser]\nresolution_deg = 0.25\n", "robot[0].laser.resolution_deg"},
      {"[[robot]]\n[robot.track]\n[robot.laser]\nbaud = 115200\n", "robot[0].laser.baud"},
      {"[[robot]]\n[robot.track]\nkind = \"waypoints\"\npoints_m = [[0, 0]]\n", "robot[0].track.points_m"},
      {"[[robot]]\npauses = [{ at_s = 1 }]\n[robot.track]\n", "robot[0].pauses[0].for_s"},
      {"[[robot]]\nid = 40\n[robot.track]\n", "robot[0].id"},
      {"[[robot]]\nmax_turn_rate_deg_s = -5\n[robot.track]\n", "robot[0].max_turn_rate_deg_s"},
      {"[[robot]]\n[robot.track]\nkind = \"waypoints\"\npoints_m = [[0, 0], [1, 0]]\nspline = \"bezier\"\n", "robot[0].track.spline"},
      {"[[robot]]\n", "robot[0].track"},
      {"[[robot]]\n[robot.track]\n[[robot]]\nid = 1\n[robot.track]\n", "robot[1].id"},
      {"[[furniture]]\nkind = \"box\"\nsize_m = [1, 1, 1]\n[[robot]]\n[robot.track]\n", "furniture[0].center_m"},
      {"colour = 3\n[[robot]]\n[robot.track]\n", "colour"},
      {"seed = 1\n", "robot"},
  };
  for (const BadCase& c : cases) {
    const ScenarioLoad load = parse_scenario(c.toml, "bad.toml");
    EXPECT_FALSE(load.scenario.has_value()) << c.toml;
    EXPECT_NE(load.error.find(std::string{c.key} + ":"), std::string::npos) << "error: " << load.error << "\nwanted key " << c.key;
    EXPECT_NE(load.error.find("bad.toml"), std::string::npos) << load.error;
  }
}

TEST(Scenario, SyntaxErrorGivesLineNumber) {
  const ScenarioLoad load = parse_scenario("name = \"x\"\nseed = = 3\n", "broken.toml");
  EXPECT_FALSE(load.scenario.has_value());
  EXPECT_NE(load.error.find("broken.toml:2"), std::string::npos) << load.error;
}

TEST(Scenario, ResolveByNameAndUnknownName) {
  const ScenarioLoad byname = resolve_scenario("lap2");
  ASSERT_TRUE(byname.scenario) << byname.error;
  EXPECT_EQ(byname.scenario->name, "lap2");
  const ScenarioLoad unknown = resolve_scenario("nosuchscenario");
  EXPECT_FALSE(unknown.scenario);
  EXPECT_NE(unknown.error.find("nosuchscenario"), std::string::npos);
}

// A data set written where the simulator runs (`teamscan sim lap2 --out lap2`) is a directory named
// like the scenario: the name still means the scenario, and a directory given as a path is refused.
TEST(Scenario, ADirectoryOfTheSameNameDoesNotHideTheScenario) {
  namespace fs = std::filesystem;
  const fs::path here = fs::temp_directory_path() / ("scenario_test_" + std::to_string(::getpid()));
  fs::create_directories(here / "lap2");
  const fs::path before = fs::current_path();
  fs::current_path(here);
  const ScenarioLoad byname = resolve_scenario("lap2");
  const ScenarioLoad bypath = resolve_scenario("./lap2");
  fs::current_path(before);
  fs::remove_all(here);
  ASSERT_TRUE(byname.scenario) << byname.error;
  EXPECT_EQ(byname.scenario->name, "lap2");
  EXPECT_FALSE(bypath.scenario);
  EXPECT_NE(bypath.error.find("a directory, not a scenario file"), std::string::npos) << bypath.error;
}

}  // namespace
}  // namespace teamscan::sim

namespace teamscan::sim {
namespace {

TEST(Scenario, MutatedFilesNeverCrashAndAlwaysExplain) {
  // 3000 deterministic mutations of lap2.toml (byte changes, deletions, insertions of TOML-ish
  // characters): every one either loads or gives a non-empty message.
  const char* src = std::getenv("TEAMSCAN_SOURCE_DIR");
  std::ifstream in{std::string{src ? src : "."} + "/sim/scenarios/lap2.toml"};
  std::ostringstream ss;
  ss << in.rdbuf();
  const std::string base = ss.str();
  ASSERT_FALSE(base.empty());
  std::mt19937_64 rng{12345};
  const std::string alphabet = "[]{}=\".,-+0123456789eE \n#abcxyz_";
  std::size_t loaded = 0;
  for (int n = 0; n < 3000; ++n) {
    std::string text = base;
    const int edits = 1 + static_cast<int>(rng() % 4);
    for (int e = 0; e < edits && !text.empty(); ++e) {
      const std::size_t at = rng() % text.size();
      switch (rng() % 3) {
        case 0: text[at] = alphabet[rng() % alphabet.size()]; break;
        case 1: text.erase(at, 1 + rng() % 8); break;
        default: text.insert(at, 1, alphabet[rng() % alphabet.size()]); break;
      }
    }
    const ScenarioLoad load = parse_scenario(text, "mutated.toml");
    if (load.scenario) {
      ++loaded;
      EXPECT_FALSE(load.scenario->robots.empty());
    } else {
      EXPECT_FALSE(load.error.empty());
    }
  }
  std::printf("mutated scenarios: %zu of 3000 still load\n", loaded);
}

}  // namespace
}  // namespace teamscan::sim
