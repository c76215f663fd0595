// Radio faults through the full system (teamscan demo's link faults, docs/radio.md): every process in a
// network namespace of its own with the radio site config (deploy/cyclonedds-site.xml), 20 % of the
// datagrams every process sends dropped for the whole run, and two shadows per robot at different times
// (each robot's link down, then up). Store and forward keeps everything: no scan is lost, and each
// robot is whole again (nothing left to back-fill) within 60 s of each return. The namespaces are gone
// afterwards, whatever the outcome. Root on a machine that allows network namespaces only: skipped
// (and reported skipped by ctest) otherwise, with the reason.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <string>

#include "tests/hil/e2e/e2e_support.hpp"

namespace teamscan::e2e {
namespace {

// `ip netns list` lines that start with `prefix`.
std::string namespaces_named(const std::string& prefix) {
  std::string found;
  if (std::FILE* p = ::popen("ip netns list 2>/dev/null", "r")) {
    char line[256];
    while (std::fgets(line, sizeof line, p))
      if (std::string{line}.rfind(prefix, 0) == 0) found += line;
    ::pclose(p);
  }
  return found;
}

// Whether this machine lets us make a network namespace (a container may refuse even root): empty if
// so, else what `ip` said.
std::string netns_refusal(const std::string& prefix) {
  const std::string probe = prefix + "probe";
  std::string said;
  if (std::FILE* p = ::popen(("ip netns add " + probe + " 2>&1").c_str(), "r")) {
    char line[256];
    while (std::fgets(line, sizeof line, p)) said += line;
    if (::pclose(p) == 0) {
      (void)std::system(("ip netns delete " + probe + " 2>/dev/null").c_str());
      return "";
    }
  }
  return said.empty() ? "ip netns add failed" : said;
}

// Deletes what a killed demo may have left (the demo deletes its own namespaces itself).
void delete_namespaces(const std::string& prefix) {
  for (const char* ns : {"station", "robot1", "robot2", "hub"})
    (void)std::system(("ip netns delete " + prefix + ns + " 2>/dev/null").c_str());
}

TEST(E2eLinkFaults, LossOnEveryLinkAndTwoShadowsPerRobotLoseNothing) {
  if (::geteuid() != 0) GTEST_SKIP() << "network namespaces need root";
  const char* env_prefix = std::getenv("TEAMSCAN_NETNS_PREFIX");
  const std::string prefix = std::string{env_prefix ? env_prefix : "tse2e"} + std::to_string(::getpid()) + "-";
  if (const std::string why = netns_refusal(prefix); !why.empty())
    GTEST_SKIP() << "this machine refuses network namespaces: " << why;
  const std::string dir =
      std::filesystem::temp_directory_path().string() + "/teamscan-e2e-links-" + std::to_string(::getpid());
  const int rc = run_demo(dir,
                          "--scenario lap2 --duration 70 --bringup 4 --method direction --link-loss 20 "
                          "--shadow 1:4:10 --shadow 1:24:10 --shadow 2:10:10 --shadow 2:30:10 --netns-prefix " +
                              prefix);
  const std::string left = namespaces_named(prefix);
  delete_namespaces(prefix);
  EXPECT_EQ(left, "") << "the demo left network namespaces behind";
  const std::string log = demo_log(dir);
  const std::string s = read_file(dir + "/summary.json");
  ASSERT_FALSE(s.empty()) << "exit " << rc << "\n" << log;

  EXPECT_EQ(json_number(s, "loss_permille", s.find("\"link_faults\"")), 200) << s;
  EXPECT_EQ(json_value(s, "none_lost"), "true") << log;
  for (int id : {1, 2}) {
    const std::size_t r = robot_entry(s, id);
    ASSERT_NE(r, std::string::npos) << s;
    EXPECT_EQ(json_number(s, "missing", r), 0) << "robot " << id << "\n" << s;
    EXPECT_EQ(json_number(s, "poses_missing", r), 0) << "robot " << id << "\n" << s;
    EXPECT_GT(json_number(s, "poses", r), 500) << "robot " << id << "\n" << s;
    EXPECT_GE(json_number(s, "seq_last", r), json_number(s, "last_status_published", r)) << s;
    EXPECT_EQ(json_number(s, "shadows", r), 2) << s;
    EXPECT_EQ(json_value(s, "whole_again", r), "true") << "robot " << id << " never whole again\n" << log;
    EXPECT_LE(json_number(s, "whole_after_s_max", r), 60.0) << s;
    EXPECT_GT(json_number(s, "buffered_max", r), 0) << "robot " << id << " buffered nothing in its shadows\n" << s;
  }
  // The summary an operator reads says so too.
  EXPECT_NE(read_file(dir + "/demo.out").find(" 0 missing from their sequence numbers, 0 poses missing: nothing lost"),
            std::string::npos)
      << log;
  EXPECT_EQ(json_value(s, "clean_exit"), "true") << log;
  if (!HasFailure()) std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace teamscan::e2e
