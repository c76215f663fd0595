// `teamscan eval` and `teamscan export` end to end through the data set files (common/dataset): the
// JSON is byte-identical for a seed, the pose graph's flags place the scans as they say, and the
// export's ground truth reads back with the labels.
#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include <sys/wait.h>
#include <unistd.h>

#include "common/dataset/dataset.hpp"
#include "common/dataset/pcd.hpp"
#include "tests/bench/mapping/synthetic_survey.hpp"

namespace teamscan::mapping {
namespace {

std::string slurp(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

class Cli : public ::testing::Test {
 protected:
  void SetUp() override {
    const char* bin = std::getenv("TEAMSCAN_BINARY_DIR");
    tool_ = std::string(bin ? bin : "build/dev") + "/tools/teamscan/teamscan";
    if (!std::filesystem::exists(tool_)) GTEST_SKIP() << "teamscan tool not built: " << tool_;
    dir_ = ::testing::TempDir() + "/mapping_cli_" + std::to_string(::getpid());
    std::filesystem::create_directories(dir_);
    bench::SurveyOptions o;
    o.duration_s = 6.0;
    dataset_ = bench::synthetic_survey(o);
    ASSERT_TRUE(write_dataset(dir_ + "/ds", dataset_).ok());
  }
  void TearDown() override {
    if (!dir_.empty()) std::filesystem::remove_all(dir_);
  }
  int run(const std::string& args) {
    const std::string cmd = "timeout 60 " + tool_ + " " + args + " > " + dir_ + "/stdout.txt 2> " + dir_ + "/stderr.txt";
    return std::system(cmd.c_str());
  }
  std::string tool_, dir_;
  Dataset dataset_;
};

TEST_F(Cli, EvalJsonIsIdenticalForASeedAndTheReportFolderIsWritten) {
  ASSERT_EQ(run("eval " + dir_ + "/ds --seed 7 --json " + dir_ + "/a.json"), 0) << slurp(dir_ + "/stderr.txt");
  ASSERT_EQ(run("eval " + dir_ + "/ds --seed 7 --json " + dir_ + "/b.json --out " + dir_ + "/report"), 0);
  const std::string a = slurp(dir_ + "/a.json");
  EXPECT_FALSE(a.empty());
  EXPECT_EQ(a, slurp(dir_ + "/b.json"));
  EXPECT_EQ(a, slurp(dir_ + "/report/report.json"));
  const std::string md = slurp(dir_ + "/report/report.md");
  EXPECT_NE(md.find("| combined@7.0deg,0.10m |"), std::string::npos);
  EXPECT_NE(md.find("Reproduce: `teamscan eval " + dir_ + "/ds --method all --seed 7`"), std::string::npos);
  // Pictures from tools/render: one per method plus the whole cloud, each a PNG.
  if (md.find("Pictures (top view") != std::string::npos) {
    const std::string file = "synthetic_oval_10m-position-top.png";  // scenario with '-' made '_'
    const std::string png = slurp(dir_ + "/report/" + file);
    ASSERT_GE(png.size(), 8u);
    EXPECT_EQ(png.substr(0, 8), std::string("\x89PNG\r\n\x1a\n", 8));
    EXPECT_NE(md.find("![position](" + file + ")"), std::string::npos);
  }
  // The table goes to stdout too.
  EXPECT_NE(slurp(dir_ + "/stdout.txt").find("| position |"), std::string::npos);
}

// The value of the report's first "placed_by" (what placed the scans the metrics read), "" if none.
std::string placed_by(const std::string& json) {
  const std::size_t key = json.find("\"placed_by\"");
  if (key == std::string::npos) return "";
  const std::size_t open = json.find('"', json.find(':', key) + 1);
  const std::size_t close = json.find('"', open + 1);
  return open == std::string::npos || close == std::string::npos ? "" : json.substr(open + 1, close - open - 1);
}

// The pose graph is on by default; --no-registration is odometry alone, --no-pose-graph the registration's
// or odometry's placement, --no-registration --pose-graph the graph over odometry; contradictions refused.
TEST_F(Cli, EvalRunsThePoseGraphByDefaultAndOdometryAloneWithNoRegistration) {
  const std::string json = dir_ + "/r.json";
  const auto placed = [&](const std::string& flags) {
    const int rc = run("eval " + dir_ + "/ds --method position -q --json " + json + " " + flags);
    EXPECT_EQ(rc, 0) << flags << ": " << slurp(dir_ + "/stderr.txt");
    return placed_by(slurp(json));
  };
  EXPECT_EQ(placed(""), "pose_graph");
  EXPECT_NE(slurp(dir_ + "/stderr.txt").find("pose graph: "), std::string::npos);
  EXPECT_EQ(placed("--no-registration"), "odometry");
  EXPECT_EQ(slurp(dir_ + "/stderr.txt").find("pose graph: "), std::string::npos);
  EXPECT_EQ(placed("--no-registration --pose-graph"), "pose_graph");
  EXPECT_EQ(placed("--no-pose-graph"), "odometry");
  EXPECT_EQ(placed("--registration --no-pose-graph"), "registration");
  EXPECT_EQ(placed("--registration"), "pose_graph");
  EXPECT_NE(run("eval " + dir_ + "/ds --pose-graph --no-pose-graph"), 0);
  EXPECT_NE(run("eval " + dir_ + "/ds --registration --no-registration"), 0);
}

TEST_F(Cli, EvalRejectsBadArgumentsAndBadFolders) {
  EXPECT_NE(run("eval " + dir_ + "/ds --method bogus"), 0);
  EXPECT_NE(slurp(dir_ + "/stderr.txt").find("unknown method"), std::string::npos);
  EXPECT_NE(run("eval " + dir_ + "/ds --half-angle 75"), 0);
  std::filesystem::create_directories(dir_ + "/empty");
  EXPECT_NE(run("eval " + dir_ + "/empty"), 0);
}

// `teamscan calibrate` writes the odometry priors that `teamscan eval --calibration` takes (a robot's
// rates start from them: eval's robot table shows where they end); bad priors are refused with exit 2.
TEST_F(Cli, CalibrateWritesPriorsThatEvalTakesAndBadPriorsAreRefused) {
  auto exit_code = [](int status) { return WIFEXITED(status) ? WEXITSTATUS(status) : -1; };
  ASSERT_EQ(run("calibrate " + dir_ + "/ds --min-path 0 --min-accepted 0 --out " + dir_ + "/calib.toml"), 0)
      << slurp(dir_ + "/stderr.txt");
  const std::string calib = slurp(dir_ + "/calib.toml");
  EXPECT_NE(calib.find("\nid = 1\n"), std::string::npos) << calib;
  EXPECT_NE(calib.find("scale_sigma_percent = "), std::string::npos) << calib;
  ASSERT_EQ(run("eval " + dir_ + "/ds --method position --registration --calibration " + dir_ + "/calib.toml"), 0)
      << slurp(dir_ + "/stderr.txt");
  EXPECT_NE(slurp(dir_ + "/stdout.txt").find("--registration --calibration " + dir_ + "/calib.toml"), std::string::npos);
  // A prior far from the truth (this survey has exact odometry) shows in the rates at the end.
  ASSERT_EQ(run("eval " + dir_ + "/ds --method position --registration --prior-scale-percent -20 --prior-scale-sigma-percent 0.01"), 0)
      << slurp(dir_ + "/stderr.txt");
  EXPECT_NE(slurp(dir_ + "/stdout.txt").find("| -20.0"), std::string::npos) << slurp(dir_ + "/stdout.txt");

  EXPECT_EQ(exit_code(run("eval " + dir_ + "/ds --registration --prior-scale-sigma-percent 0")), 2);
  EXPECT_NE(slurp(dir_ + "/stderr.txt").find("the scale's σ must be in (0, 50 %]"), std::string::npos) << slurp(dir_ + "/stderr.txt");
  EXPECT_EQ(exit_code(run("eval " + dir_ + "/ds --registration --prior-turn-percent nan")), 2);
  EXPECT_EQ(exit_code(run("eval " + dir_ + "/ds --registration --prior-scale-percent 60")), 2);
  EXPECT_EQ(exit_code(run("eval " + dir_ + "/ds --prior-scale-percent -2")), 2);  // without --registration
  EXPECT_NE(slurp(dir_ + "/stderr.txt").find("need --registration"), std::string::npos);
  {
    std::ofstream bad(dir_ + "/bad.toml");
    bad << "[[registration.robot]]\nid = 1\nscale_sigma_percent = -1\n";
  }
  EXPECT_EQ(exit_code(run("eval " + dir_ + "/ds --registration --calibration " + dir_ + "/bad.toml")), 2);
  EXPECT_NE(slurp(dir_ + "/stderr.txt").find("registration.robot (id 1): the scale's σ"), std::string::npos)
      << slurp(dir_ + "/stderr.txt");
  EXPECT_NE(run("calibrate " + dir_ + "/nosuchdir"), 0);
}

TEST_F(Cli, ExportWritesTheDynamicMapLayoutThatReadsBack) {
  ASSERT_EQ(run("export " + dir_ + "/ds --format dynamicmap --out " + dir_ + "/dm"), 0) << slurp(dir_ + "/stderr.txt");
  auto gt = read_pcd(dir_ + "/dm/gt_cloud.pcd");
  ASSERT_TRUE(gt.ok()) << gt.error().what;
  ASSERT_EQ(gt.value().size(), dataset_.points.size());
  const int intensity = gt.value().field("intensity");
  ASSERT_GE(intensity, 0);
  for (std::size_t i = 0; i < dataset_.points.size(); ++i)
    ASSERT_EQ(gt.value().columns[static_cast<std::size_t>(intensity)][i], dataset_.points[i].is_ghost() ? 1.0 : 0.0) << i;
  auto frame = read_pcd(dir_ + "/dm/pcd/000000.pcd");
  ASSERT_TRUE(frame.ok());
  EXPECT_EQ(frame.value().size(), dataset_.scans.front().points);
  EXPECT_NE(run("export " + dir_ + "/ds --format kitti --out " + dir_ + "/x"), 0);
}

}  // namespace
}  // namespace teamscan::mapping
