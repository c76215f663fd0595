// deploy/: the systemd units pass `systemd-analyze verify` without a single message and score an
// exposure <= 2.0 in `systemd-analyze security --offline=yes`; the site Cyclone config is accepted by
// Cyclone (run with its network parts replaced by loopback, so the test never leaves 127.0.0.1).
#include <gtest/gtest.h>

#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <regex>
#include <set>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include <dds/dds.h>

#include "tests/support/test_domain.hpp"

namespace {

namespace fs = std::filesystem;

std::string source_dir() {
  const char* s = std::getenv("TEAMSCAN_SOURCE_DIR");
  return s != nullptr ? s : TEAMSCAN_SOURCE_DIR_FALLBACK;
}

std::string slurp(const fs::path& p) {
  std::ifstream in(p);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

struct CommandResult {
  int rc = -1;
  std::string out;
};

// Runs a shell command with a time bound; captures stdout+stderr or stderr only.
CommandResult run(const std::string& cmd) {
  CommandResult r;
  FILE* p = ::popen(("timeout 60 " + cmd).c_str(), "r");
  if (p == nullptr) return r;
  char buf[4096];
  while (std::fgets(buf, sizeof buf, p) != nullptr) r.out += buf;
  const int st = ::pclose(p);
  r.rc = WIFEXITED(st) ? WEXITSTATUS(st) : -1;
  return r;
}

bool have_systemd_analyze() {
  const char* path = std::getenv("PATH");
  std::stringstream dirs(path != nullptr ? path : "/usr/bin:/bin");
  for (std::string d; std::getline(dirs, d, ':');) {
    if (::access((d + "/systemd-analyze").c_str(), X_OK) == 0) return true;
  }
  return false;
}

// A copy of a unit with ExecStart pointing at a binary that exists (verify insists on it).
fs::path staged_unit(const std::string& name, const std::string& instance_name, const std::string& text_override = "") {
  static const fs::path dir = [] {
    char tmpl[] = "/tmp/teamscan-units-XXXXXX";
    return fs::path(::mkdtemp(tmpl));
  }();
  std::string text = text_override.empty() ? slurp(fs::path(source_dir()) / "deploy" / name) : text_override;
  text = std::regex_replace(text, std::regex("/usr/bin/teamscan-[a-z]+"), TEAMSCAN_EXISTING_BINARY);
  const fs::path p = dir / instance_name;
  std::ofstream(p) << text;
  return p;
}

struct UnitCase {
  const char* file;
  const char* instance;
};
const UnitCase kUnits[] = {{"teamscan-onboard@.service", "teamscan-onboard@robot1.service"},
                           {"teamscan-groundstation.service", "teamscan-groundstation.service"}};

TEST(SystemdUnits, VerifyPrintsNothing) {
  if (!have_systemd_analyze()) GTEST_SKIP() << "systemd-analyze not installed";
  for (const UnitCase& u : kUnits) {
    const fs::path p = staged_unit(u.file, u.instance);
    // rc is 0 even for unknown keys and bad values (DDS_SYSTEMD.md 5.4): any stderr output fails.
    const CommandResult r = run("systemd-analyze verify " + p.string() + " 2>&1 >/dev/null");
    EXPECT_EQ(r.rc, 0) << u.file;
    EXPECT_EQ(r.out, "") << u.file;
  }
}

TEST(SystemdUnits, VerifyCheckCatchesAnInlineComment) {
  if (!have_systemd_analyze()) GTEST_SKIP() << "systemd-analyze not installed";
  // The failure this test guards against: an inline comment silently drops a hardening directive.
  std::string text = slurp(fs::path(source_dir()) / "deploy" / "teamscan-groundstation.service");
  text = std::regex_replace(text, std::regex("PrivateTmp=yes"), "PrivateTmp=yes # private /tmp");
  const fs::path p = staged_unit("", "teamscan-broken.service", text);
  const CommandResult r = run("systemd-analyze verify " + p.string() + " 2>&1 >/dev/null");
  EXPECT_NE(r.out, "");
}

TEST(SystemdUnits, SecurityExposureAtMostTwo) {
  if (!have_systemd_analyze()) GTEST_SKIP() << "systemd-analyze not installed";
  for (const UnitCase& u : kUnits) {
    const fs::path p = staged_unit(u.file, u.instance);
    // --threshold is on the 0..100 scale: 20 = exposure 2.0.
    const CommandResult r = run("systemd-analyze security --offline=yes --threshold=20 " + p.string() + " 2>&1");
    EXPECT_EQ(r.rc, 0) << r.out;
    std::smatch m;
    ASSERT_TRUE(std::regex_search(r.out, m, std::regex("Overall exposure level for [^:]+: ([0-9.]+)"))) << r.out;
    const double exposure = std::stod(m[1].str());
    std::printf("%s: exposure %.1f\n", u.file, exposure);
    EXPECT_LE(exposure, 2.0) << u.file;
  }
}

TEST(SystemdUnits, WatchdogNotifyAndRestartArePresent) {
  for (const UnitCase& u : kUnits) {
    const std::string t = slurp(fs::path(source_dir()) / "deploy" / u.file);
    for (const char* key : {"\nType=notify\n", "\nWatchdogSec=", "\nRestart=on-failure\n", "\nNoNewPrivileges=yes\n",
                            "\nProtectSystem=strict\n", "\nUser=teamscan\n"}) {
      EXPECT_NE(t.find(key), std::string::npos) << u.file << " lacks " << key;
    }
  }
  const std::string onboard = slurp(fs::path(source_dir()) / "deploy" / "teamscan-onboard@.service");
  EXPECT_NE(onboard.find("\nSupplementaryGroups=dialout\n"), std::string::npos);
}

// The site config with its network parts swapped for loopback: Cyclone must accept every element.
std::string site_config_on_loopback(const std::string& extra = "") {
  std::string x = slurp(fs::path(source_dir()) / "deploy" / "cyclonedds-site.xml");
  x = std::regex_replace(x, std::regex("<NetworkInterface [^/]*/>"), "<NetworkInterface address=\"127.0.0.1\" multicast=\"false\"/>");
  x = std::regex_replace(x, std::regex("<AllowMulticast>[a-z]+</AllowMulticast>"), "<AllowMulticast>false</AllowMulticast>");
  x = std::regex_replace(x, std::regex("<Peer address=\"[0-9.]+\"/>"), "<Peer address=\"127.0.0.1\"/>");
  x = std::regex_replace(x, std::regex("<\\?xml[^>]*>"), "");
  if (!extra.empty()) x = std::regex_replace(x, std::regex("</Discovery>"), "</Discovery>" + extra);
  EXPECT_EQ(x.find("192.168."), std::string::npos);
  EXPECT_EQ(x.find("wlan0"), std::string::npos);
  return x;
}

// Each check in a child process: a Cyclone domain with a broken config must not linger in this one.
int child_creates_domain(const std::string& xml, dds_domainid_t id) {
  const pid_t pid = ::fork();
  if (pid == 0) {
    const dds_entity_t dom = dds_create_domain(id, xml.c_str());
    if (dom < 0) ::_exit(1);
    const dds_entity_t pp = dds_create_participant(id, nullptr, nullptr);
    ::_exit(pp < 0 ? 2 : 0);
  }
  int st = 0;
  ::waitpid(pid, &st, 0);
  return WIFEXITED(st) ? WEXITSTATUS(st) : -1;
}

TEST(CycloneSiteConfig, AcceptedByCyclone) {
  EXPECT_EQ(child_creates_domain(site_config_on_loopback(), 41), 0);
}

TEST(CycloneSiteConfig, CheckRejectsAnUnknownElement) {
  EXPECT_NE(child_creates_domain(site_config_on_loopback("<Bogus>1</Bogus>"), 42), 0);
}

// A secured site's discovery (docs/security.md, Deployment step 6): the robots name the station as their
// only peer, so that they authenticate the station alone, not each other. On one host as the security
// benchmark runs it: the station on participant index 0 (a known port), each robot without an index of
// its own and with one peer, the station's discovery port. Each process counts the participants it
// discovers over a few seconds: the station both robots, each robot the station and nothing else.
std::string loopback_config() {
  return std::regex_replace(slurp(fs::path(source_dir()) / "deploy" / "cyclonedds-lo.xml"), std::regex("<\\?xml[^>]*>"), "");
}

std::string star_station_config() {
  return std::regex_replace(loopback_config(), std::regex("<ParticipantIndex>auto</ParticipantIndex>"),
                            "<ParticipantIndex>0</ParticipantIndex>");
}

std::string star_robot_config(dds_domainid_t id) {
  std::string x = std::regex_replace(loopback_config(), std::regex("<ParticipantIndex>auto</ParticipantIndex>"),
                                     "<ParticipantIndex>none</ParticipantIndex>");
  const std::string station_port = std::to_string(7400 + 250 * id + 10);  // DDSI's default port mapping, index 0
  return std::regex_replace(x, std::regex("<Peer address=\"127.0.0.1\"/>"), "<Peer address=\"127.0.0.1:" + station_port + "\"/>");
}

// In a child: joins domain `id` with `xml`, and exits with the number of other participants it has
// discovered after `seconds` (100 + a code on failure).
pid_t child_counts_participants(const std::string& xml, dds_domainid_t id, double seconds) {
  const pid_t pid = ::fork();
  if (pid != 0) return pid;
  if (dds_create_domain(id, xml.c_str()) < 0) ::_exit(101);
  const dds_entity_t pp = dds_create_participant(id, nullptr, nullptr);
  if (pp < 0) ::_exit(102);
  dds_guid_t self{};
  if (dds_get_guid(pp, &self) != DDS_RETCODE_OK) ::_exit(103);
  const dds_entity_t rd = dds_create_reader(pp, DDS_BUILTIN_TOPIC_DCPSPARTICIPANT, nullptr, nullptr);
  if (rd < 0) ::_exit(104);
  std::set<std::string> others;
  const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(seconds);
  while (std::chrono::steady_clock::now() < end) {
    std::array<void*, 16> samples{};
    std::array<dds_sample_info_t, 16> infos{};
    const int n = dds_read(rd, samples.data(), infos.data(), samples.size(), static_cast<std::uint32_t>(samples.size()));
    for (int i = 0; i < n; ++i) {
      const auto* p = static_cast<const dds_builtintopic_participant_t*>(samples[static_cast<std::size_t>(i)]);
      if (std::memcmp(p->key.v, self.v, sizeof self.v) != 0)
        others.insert(std::string(reinterpret_cast<const char*>(p->key.v), sizeof p->key.v));
    }
    if (n > 0) (void)dds_return_loan(rd, samples.data(), n);
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  ::_exit(static_cast<int>(std::min<std::size_t>(others.size(), 99)));
}

int exit_code(pid_t pid) {
  int st = 0;
  ::waitpid(pid, &st, 0);
  return WIFEXITED(st) ? WEXITSTATUS(st) : -1;
}

TEST(CycloneSiteConfig, RobotsPeeringWithTheStationOnlyDiscoverTheStationAndNotEachOther) {
  const dds_domainid_t id = teamscan::test::test_domain_id();
  const pid_t station = child_counts_participants(star_station_config(), id, 6.0);
  std::this_thread::sleep_for(std::chrono::milliseconds(300));  // the station holds index 0 first
  const pid_t robot1 = child_counts_participants(star_robot_config(id), id, 5.0);
  const pid_t robot2 = child_counts_participants(star_robot_config(id), id, 5.0);
  EXPECT_EQ(exit_code(robot1), 1);  // the station only
  EXPECT_EQ(exit_code(robot2), 1);
  EXPECT_EQ(exit_code(station), 2);  // both robots
  // The same three on the plain loopback config (every participant probes every index) find each other:
  // the check above can fail.
  const pid_t m0 = child_counts_participants(loopback_config(), id, 5.0);
  const pid_t m1 = child_counts_participants(loopback_config(), id, 5.0);
  const pid_t m2 = child_counts_participants(loopback_config(), id, 5.0);
  EXPECT_EQ(exit_code(m1), 2);
  EXPECT_EQ(exit_code(m2), 2);
  EXPECT_EQ(exit_code(m0), 2);
}

}  // namespace
