// Both daemons check their DDS Security bundle before DDS starts: a missing, expired, foreign or
// someone else's credential is a configuration error (exit 2, which the units' RestartPreventExitStatus
// covers) with a message naming the file and the reason; a good bundle passes --check-config.
#include <sys/wait.h>

#include <cstdio>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <string>

#include <gtest/gtest.h>

#include "tests/support/onboard_config_fixture.hpp"
#include "tests/support/test_domain.hpp"
#include "tools/pki/site_pki.hpp"

namespace fs = std::filesystem;

namespace {

std::int64_t now_s() { return static_cast<std::int64_t>(std::time(nullptr)); }

struct Outcome {
  int rc = -1;
  std::string out;  // stdout and stderr
};

Outcome run(const std::string& cmd) {
  Outcome r;
  FILE* p = ::popen((cmd + " 2>&1").c_str(), "r");
  char buf[512];
  while (p != nullptr && std::fgets(buf, sizeof buf, p) != nullptr) r.out += buf;
  const int st = p != nullptr ? ::pclose(p) : -1;
  r.rc = WIFEXITED(st) ? WEXITSTATUS(st) : -1;
  return r;
}

class DaemonCredentials : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("teamscan-daemon-creds-" + std::to_string(::getpid()));
    fs::remove_all(dir_);
    teamscan::pki::SiteOptions o;
    o.robots = 2;
    o.domain_min = o.domain_max = teamscan::test::test_domain_id();
    o.now_s = now_s();
    ASSERT_TRUE(teamscan::pki::create_site((dir_ / "site").string(), o).ok());
    std::ofstream(dir_ / "robot1.toml") << teamscan::test::pipeline_test_config_toml(1, true);
  }
  void TearDown() override { fs::remove_all(dir_); }
  Outcome station(const fs::path& bundle) const {
    return run(std::string(TEAMSCAN_GROUNDSTATION) + " --check-config --pki-dir " + bundle.string());
  }
  Outcome onboard(const fs::path& bundle) const {
    return run(std::string(TEAMSCAN_ONBOARD) + " --config " + (dir_ / "robot1.toml").string() + " --check-config --pki-dir " +
               bundle.string());
  }
  fs::path dir_;
};

TEST_F(DaemonCredentials, AGoodBundlePasses) {
  const Outcome s = station(dir_ / "site" / "station");
  EXPECT_EQ(s.rc, 0) << s.out;
  EXPECT_NE(s.out.find("DDS Security: identity CN=station"), std::string::npos) << s.out;
  const Outcome o = onboard(dir_ / "site" / "robot1");
  EXPECT_EQ(o.rc, 0) << o.out;
  EXPECT_NE(o.out.find("DDS Security: identity CN=robot1"), std::string::npos) << o.out;
}

TEST_F(DaemonCredentials, MissingExpiredOrAnothersCredentialsExitTwoWithTheReason) {
  Outcome r = station(dir_ / "nowhere");
  EXPECT_EQ(r.rc, 2) << r.out;
  EXPECT_NE(r.out.find("DDS Security credentials refused: " + (dir_ / "nowhere" / "ca_cert.pem").string() + ": missing"),
            std::string::npos)
      << r.out;

  r = station(dir_ / "site" / "robot1");  // a robot's bundle on the station
  EXPECT_EQ(r.rc, 2) << r.out;
  EXPECT_NE(r.out.find("the identity of robot1, not of station"), std::string::npos) << r.out;

  r = onboard(dir_ / "site" / "robot2");  // robot 2's bundle on robot 1
  EXPECT_EQ(r.rc, 2) << r.out;
  EXPECT_NE(r.out.find("the identity of robot2, not of robot1"), std::string::npos) << r.out;

  ASSERT_TRUE(teamscan::pki::issue_identity((dir_ / "site").string(), "robot1", now_s() - 10 * 86400, now_s() - 86400).ok());
  r = onboard(dir_ / "site" / "robot1");
  EXPECT_EQ(r.rc, 2) << r.out;
  EXPECT_NE(r.out.find("cert.pem: certificate has expired on"), std::string::npos) << r.out;

  fs::remove(dir_ / "site" / "station" / "key.pem");
  r = station(dir_ / "site" / "station");
  EXPECT_EQ(r.rc, 2) << r.out;
  EXPECT_NE(r.out.find("key.pem: missing"), std::string::npos) << r.out;
}

}  // namespace
