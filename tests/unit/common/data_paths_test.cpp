// find_data_file (common/data_paths.hpp): an installed program finds share/teamscan beside its bin/
// (checked by copying this test binary into a fake install prefix and running it there), a build tree
// falls back to the source tree, and a missing file names every place looked in. Also --version's parts.
#include <gtest/gtest.h>

#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>

#include "common/data_paths.hpp"
#include "common/version.hpp"

namespace teamscan {
namespace {

namespace fs = std::filesystem;

// Not a check: the copied binary runs it (disabled in normal runs) and prints what it finds for the probe.
TEST(DataPathsChild, DISABLED_PrintProbe) {
  const DataFile f = find_data_file("probe/probe.txt", "no/such/source/file");
  std::printf("PROBE=%s\n", f.path.c_str());
}

TEST(DataPaths, InstalledProgramFindsShareBesideItsBin) {
  const fs::path prefix = fs::path(::testing::TempDir()) / ("teamscan_prefix_" + std::to_string(::getpid()));
  fs::remove_all(prefix);
  fs::create_directories(prefix / "bin");
  fs::create_directories(prefix / "share" / "teamscan" / "probe");
  std::ofstream(prefix / "share" / "teamscan" / "probe" / "probe.txt") << "x";
  const fs::path copy = prefix / "bin" / "data_paths_probe";
  fs::copy_file(fs::read_symlink("/proc/self/exe"), copy);
  const std::string cmd =
      copy.string() + " --gtest_also_run_disabled_tests --gtest_filter=DataPathsChild.DISABLED_PrintProbe";
  FILE* p = ::popen(cmd.c_str(), "r");
  ASSERT_NE(p, nullptr);
  std::string out;
  char buf[512];
  while (std::fgets(buf, sizeof buf, p) != nullptr) out += buf;
  const int status = ::pclose(p);
  EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << out;
  const std::string expected = "PROBE=" + (prefix / "share" / "teamscan" / "probe" / "probe.txt").lexically_normal().string();
  EXPECT_NE(out.find(expected + "\n"), std::string::npos) << out;
  fs::remove_all(prefix);
}

TEST(DataPaths, BuildTreeFallsBackToTheSourceTree) {
  const DataFile f = find_data_file("no-such-installed-name.xml", "deploy/cyclonedds-lo.xml");
  ASSERT_FALSE(f.path.empty()) << f.searched;
  EXPECT_TRUE(f.path.ends_with("/deploy/cyclonedds-lo.xml")) << f.path;
  EXPECT_TRUE(fs::is_regular_file(f.path));
}

TEST(DataPaths, MissingFileNamesEveryPlaceLookedIn) {
  const DataFile f = find_data_file("scenarios/nosuch.toml", "sim/scenarios/nosuch.toml");
  EXPECT_TRUE(f.path.empty());
  EXPECT_NE(f.searched.find("share/teamscan/scenarios/nosuch.toml"), std::string::npos) << f.searched;
  EXPECT_NE(f.searched.find("sim/scenarios/nosuch.toml"), std::string::npos) << f.searched;
  EXPECT_EQ(std::count(f.searched.begin(), f.searched.end(), ','), 2) << f.searched;
}

TEST(Version, NamesTheProjectVersionAndACommit) {
  EXPECT_STREQ(version(), TEAMSCAN_PROJECT_VERSION);  // project(VERSION) in CMakeLists.txt
  const std::string commit = git_commit();
  EXPECT_TRUE(commit == "unknown" || (commit.size() >= 12 && commit.find_first_not_of("0123456789abcdef") >= 12)) << commit;
}

}  // namespace
}  // namespace teamscan
