// `teamscan sim` end to end: writes a data set that reads back with the counts it printed, plus the
// captures; a malformed scenario stops it with a message naming the key.
#include <gtest/gtest.h>

#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "common/capture.hpp"
#include "common/dataset/dataset.hpp"

namespace {

namespace fs = std::filesystem;

std::string teamscan_binary() {
  const char* bin = std::getenv("TEAMSCAN_BINARY_DIR");
  return std::string{bin ? bin : "."} + "/tools/teamscan/teamscan";
}

// Runs a shell command, returns (exit status, stdout + stderr).
std::pair<int, std::string> run(const std::string& command) {
  std::string out;
  std::FILE* p = ::popen((command + " 2>&1").c_str(), "r");
  if (p == nullptr) return {-1, out};
  char buf[4096];
  while (std::fgets(buf, sizeof buf, p) != nullptr) out += buf;
  const int status = ::pclose(p);
  return {WIFEXITED(status) ? WEXITSTATUS(status) : -1, out};
}

TEST(TeamscanSim, WritesTheDataSetAndCaptures) {
  if (!fs::exists(teamscan_binary())) GTEST_SKIP() << "teamscan not built: " << teamscan_binary();
  const fs::path dir = fs::temp_directory_path() / ("teamscan_sim_cli_" + std::to_string(::getpid()));
  const auto [status, output] = run("timeout 120 " + teamscan_binary() + " sim lap2 --duration 3 --seed 5 -q --out " + dir.string());
  ASSERT_EQ(status, 0) << output;
  EXPECT_NE(output.find("robot 1:"), std::string::npos) << output;
  EXPECT_NE(output.find("x real time"), std::string::npos) << output;

  const teamscan::Result<teamscan::Dataset> ds = teamscan::read_dataset(dir.string());
  ASSERT_TRUE(ds.ok()) << ds.error().what;
  EXPECT_EQ(ds->scenario, "lap2");
  EXPECT_EQ(ds->seed, 5u);
  ASSERT_EQ(ds->robots.size(), 2u);
  // The printed total equals what was written.
  std::ostringstream total;
  total << "total: " << ds->points.size() << " points";
  EXPECT_NE(output.find(total.str()), std::string::npos) << output;
  for (int id : {1, 2}) {
    for (const char* dev : {"arcos", "lms200"}) {
      const fs::path cap = dir / "captures" / ("robot" + std::to_string(id) + "-" + dev + ".cap");
      const teamscan::Result<teamscan::Capture> c = teamscan::load_capture(cap.string());
      ASSERT_TRUE(c.ok()) << cap;
      EXPECT_FALSE(c->bytes(teamscan::CaptureDirection::rx).empty()) << cap;
    }
  }
  fs::remove_all(dir);
}

TEST(TeamscanSim, MalformedScenarioNamesTheKey) {
  if (!fs::exists(teamscan_binary())) GTEST_SKIP() << "teamscan not built: " << teamscan_binary();
  const fs::path file = fs::temp_directory_path() / ("teamscan_bad_" + std::to_string(::getpid()) + ".toml");
  std::ofstream{file} << "[[robot]]\n[robot.track]\nkind = \"oval\"\n[robot.laser]\nbaud = 115200\n";
  const auto [status, output] = run("timeout 60 " + teamscan_binary() + " sim " + file.string() + " --out /nonexistent/x");
  EXPECT_NE(status, 0);
  EXPECT_NE(output.find("robot[0].laser.baud"), std::string::npos) << output;
  const auto [status2, output2] = run("timeout 60 " + teamscan_binary() + " sim no_such_scenario --out /tmp/x");
  EXPECT_NE(status2, 0);
  EXPECT_NE(output2.find("no_such_scenario"), std::string::npos) << output2;
  fs::remove(file);
}

}  // namespace
