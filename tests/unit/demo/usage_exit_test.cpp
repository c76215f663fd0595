// Exit codes of the three programs' command lines: every usage error (unknown option, missing or
// malformed value, no subcommand) exits 2, --help and --version exit 0.
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <string>
#include <utility>
#include <vector>

namespace {

std::string binary(const char* relative) {
  const char* dir = std::getenv("TEAMSCAN_BINARY_DIR");
  return std::string{dir ? dir : "."} + "/" + relative;
}

// Exit status of `command` (its output discarded).
int exit_status(const std::string& command) {
  const int status = std::system((command + " >/dev/null 2>&1").c_str());
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

struct Program {
  const char* relative;
  std::vector<const char*> usage_errors;
};

const Program kPrograms[] = {
    {"tools/teamscan/teamscan",
     {"", "--no-such-option", "no-such-subcommand", "demo --no-such-option", "demo --speed -1", "demo --robots x",
      "demo --link-loss x", "demo --link-loss 101", "demo --shadow 1:2", "demo --shadow 9:1:1",
      "demo --shadow 1:5:10 --shadow 1:10:10", "eval", "eval /nonexistent --no-such-option", "render", "render x.pcd --out y.png --view bogus",
      "render x.pcd --out y.png --size 3x3", "sim lap2 --duration"}},
    {"groundstation/station/teamscan-groundstation", {"--no-such-option", "--domain 999", "--config"}},
    {"onboard/daemon/teamscan-onboard", {"--no-such-option", "", "--config"}},
};

TEST(UsageExit, EveryUsageErrorExitsTwo) {
  for (const Program& p : kPrograms) {
    const std::string bin = binary(p.relative);
    if (!std::filesystem::exists(bin)) GTEST_SKIP() << "not built: " << bin;
    for (const char* args : p.usage_errors) EXPECT_EQ(exit_status(bin + " " + args), 2) << p.relative << " " << args;
  }
}

TEST(UsageExit, HelpAndVersionExitZero) {
  for (const Program& p : kPrograms) {
    const std::string bin = binary(p.relative);
    if (!std::filesystem::exists(bin)) GTEST_SKIP() << "not built: " << bin;
    EXPECT_EQ(exit_status(bin + " --help"), 0) << p.relative;
    EXPECT_EQ(exit_status(bin + " --version"), 0) << p.relative;
  }
}

}  // namespace
