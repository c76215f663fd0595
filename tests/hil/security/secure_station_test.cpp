// DDS Security end to end on loopback: the Station library in this process, secured with the site's
// station bundle, against teamscan_secure_peer processes with and without credentials:
//  - a participant without credentials discovers no teamscan endpoint, receives 0 samples and gets 0
//    samples accepted by the station;
//  - robot 2's identity cannot create a writer in robot 1's partition nor a team writer, and what it
//    publishes as robot 1 in its own partition is refused by the station (counted, logged);
//  - identities from another CA, expired or revoked (CRL) ones and tampered permissions never reach the
//    station.
#include <fcntl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "common/clock.hpp"
#include "dds/security/credentials.hpp"
#include "groundstation/station/session_store.hpp"
#include "groundstation/station/station.hpp"
#include "tests/support/test_domain.hpp"
#include "tools/pki/site_pki.hpp"

namespace fs = std::filesystem;
using namespace std::chrono_literals;

namespace teamscan::station {
namespace {

std::int64_t now_s() { return static_cast<std::int64_t>(std::time(nullptr)); }

std::string slurp(const fs::path& p) {
  std::ifstream in(p);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

// A peer process whose stdout goes to a file, read once it has exited.
class Peer {
 public:
  Peer(const std::vector<std::string>& args, const fs::path& out) : out_{out} {
    pid_ = ::fork();
    if (pid_ == 0) {
      const int fd = ::open(out.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
      ::dup2(fd, 1);
      std::vector<std::string> all{TEAMSCAN_SECURE_PEER};
      all.insert(all.end(), args.begin(), args.end());
      std::vector<char*> argv;
      for (std::string& a : all) argv.push_back(a.data());
      argv.push_back(nullptr);
      ::execv(argv[0], argv.data());
      ::_exit(127);
    }
  }
  ~Peer() {
    if (!done_ && pid_ > 0) {
      ::kill(pid_, SIGKILL);
      ::waitpid(pid_, nullptr, 0);
    }
  }
  bool finished() {
    if (done_) return true;
    int st = 0;
    if (::waitpid(pid_, &st, WNOHANG) == pid_) done_ = true;
    return done_;
  }
  std::string output() const { return slurp(out_); }
  // The integer after `key ` in the output, or nullopt.
  std::optional<long> value(const std::string& key) const {
    const std::string o = output();
    const std::size_t at = o.find(key + " ");
    if (at == std::string::npos) return std::nullopt;
    return std::stol(o.substr(at + key.size() + 1));
  }

 private:
  fs::path out_;
  pid_t pid_ = -1;
  bool done_ = false;
};

class SecureStation : public ::testing::Test {
 protected:
  void SetUp() override {
    char tmpl[] = "/tmp/teamscan-secure-XXXXXX";
    root_ = ::mkdtemp(tmpl);
    pki::SiteOptions o;
    o.robots = 3;
    o.domain_min = o.domain_max = test::test_domain_id();
    o.now_s = now_s();
    ASSERT_TRUE(pki::create_site(site("").string(), o).ok());
    // robot3 is revoked; its old bundle (with the CRL of before) is kept to try it.
    fs::copy(site("robot3"), root_ / "robot3-revoked");
    ASSERT_TRUE(pki::revoke_identity(site("").string(), "robot3", now_s()).ok());
    auto s = SessionStore::open((root_ / "session").string());
    ASSERT_TRUE(s.ok()) << s.error().what;
    store_.emplace(std::move(s.value()));
    StationOptions so;
    so.domain_id = test::test_domain_id();
    so.silence_timeout = 0s;
    so.pki_dir = site("station").string();
    auto st = Station::create(so, *store_, team_);
    ASSERT_TRUE(st.ok()) << st.error().what;
    station_ = std::move(st.value());
  }
  void TearDown() override {
    station_.reset();
    fs::remove_all(root_);
  }
  fs::path site(const std::string& name) const { return root_ / "site" / name; }
  std::vector<std::string> args(std::vector<std::string> a, const std::optional<fs::path>& pki) const {
    a.insert(a.end(), {"--domain", test::test_domain_arg()});
    if (pki) a.insert(a.end(), {"--pki", pki->string()});
    return a;
  }
  // Runs the station until every peer has exited (bounded).
  void run_until_done(std::vector<Peer*> peers, Duration timeout = 30s) {
    const Time deadline = now_monotonic() + timeout;
    while (now_monotonic() < deadline) {
      station_->poll(20ms);
      station_->publish_team_if_due(now_monotonic());
      bool all = true;
      for (Peer* p : peers) all = p->finished() && all;
      if (all) break;
    }
    for (int i = 0; i < 10; ++i) station_->poll(20ms);  // whatever is still in flight
  }
  std::string events() const {
    for (const auto& e : fs::recursive_directory_iterator(root_ / "session"))
      if (e.path().filename() == "events.log") return slurp(e.path());
    return {};
  }

  fs::path root_;
  std::optional<SessionStore> store_;
  LastPoseTeamSource team_;
  std::unique_ptr<Station> station_;
};

TEST_F(SecureStation, NoCredentialsDiscoversNothingReceivesNothingInjectsNothing) {
  // A legitimate robot 1 publishes all along, so there is something to see. The listener and the intruder
  // take turns (two participants without credentials would find each other).
  Peer robot1(args({"publish", "--robot", "1", "--partition", "robot1", "--seconds", "8"}, site("robot1")), root_ / "robot1.out");
  Peer listener(args({"listen", "--seconds", "3.5"}, std::nullopt), root_ / "listen.out");
  run_until_done({&listener});
  Peer intruder(args({"publish", "--robot", "2", "--partition", "robot2", "--seconds", "3"}, std::nullopt), root_ / "intruder.out");
  run_until_done({&robot1, &intruder});
  EXPECT_EQ(listener.value("participant"), 0) << listener.output();
  EXPECT_EQ(listener.value("discovered"), 0) << listener.output();
  EXPECT_EQ(listener.value("matched"), 0) << listener.output();
  EXPECT_EQ(listener.value("samples"), 0) << listener.output();
  EXPECT_EQ(intruder.value("scan_writer"), 0) << intruder.output();   // it may write, but no one listens
  EXPECT_EQ(intruder.value("matched"), 0) << intruder.output();
  EXPECT_GT(intruder.value("written").value_or(0), 0) << intruder.output();
  EXPECT_EQ(station_->robot(2).scans + station_->robot(2).poses, 0u);
  // The secured robot got through all along.
  EXPECT_GT(station_->robot(1).scans, 20u);
  EXPECT_EQ(robot1.value("matched"), 1) << robot1.output();
}

TEST_F(SecureStation, Robot2CannotPublishAsRobot1NorTheTeamState) {
  // In robot 1's partition: refused by its own access control (and by the station's, were it bypassed).
  Peer in_robot1(args({"publish", "--robot", "1", "--partition", "robot1", "--team", "--seconds", "1"}, site("robot2")),
                 root_ / "in_robot1.out");
  // In its own partition but claiming robot 1: delivered, refused by the station's identity check.
  Peer as_robot1(args({"publish", "--robot", "1", "--partition", "robot2", "--seconds", "4"}, site("robot2")),
                 root_ / "as_robot1.out");
  run_until_done({&in_robot1, &as_robot1});
  EXPECT_EQ(in_robot1.value("participant"), 0) << in_robot1.output();
  EXPECT_EQ(in_robot1.value("scan_writer"), DDS_RETCODE_NOT_ALLOWED_BY_SECURITY) << in_robot1.output();
  EXPECT_EQ(in_robot1.value("team_writer"), DDS_RETCODE_NOT_ALLOWED_BY_SECURITY) << in_robot1.output();
  EXPECT_EQ(as_robot1.value("scan_writer"), 0) << as_robot1.output();
  EXPECT_EQ(as_robot1.value("matched"), 1) << as_robot1.output();
  EXPECT_EQ(station_->robot(1).scans + station_->robot(1).poses, 0u);
  EXPECT_EQ(station_->robot(2).scans + station_->robot(2).poses, 0u);
  EXPECT_GT(station_->counters().identity_mismatches, 20u);
  EXPECT_NE(events().find("robot 2 published as robot 1"), std::string::npos) << events();
}

TEST_F(SecureStation, ForeignExpiredRevokedAndTamperedCredentialsNeverReachTheStation) {
  // A complete bundle for "robot1" from another CA (its own governance and permissions).
  pki::SiteOptions o;
  o.robots = 1;
  o.domain_min = o.domain_max = test::test_domain_id();
  o.now_s = now_s();
  ASSERT_TRUE(pki::create_site((root_ / "rogue").string(), o).ok());
  // robot2 expired yesterday; robot1's permissions with one byte changed.
  ASSERT_TRUE(pki::issue_identity(site("").string(), "robot2", now_s() - 10 * 86400, now_s() - 86400).ok());
  const fs::path tampered = root_ / "robot1-tampered";
  fs::copy(site("robot1"), tampered);
  std::string perm = slurp(tampered / dds::security::kPermissionsFile);
  perm[perm.find("<partition>robot1") + 16] = '*';
  std::ofstream(tampered / dds::security::kPermissionsFile, std::ios::trunc) << perm;

  Peer foreign(args({"publish", "--robot", "1", "--partition", "robot1", "--seconds", "4"}, root_ / "rogue" / "robot1"),
               root_ / "foreign.out");
  Peer revoked(args({"publish", "--robot", "3", "--partition", "robot3", "--seconds", "4"}, root_ / "robot3-revoked"),
               root_ / "revoked.out");
  Peer expired(args({"publish", "--robot", "2", "--partition", "robot2", "--seconds", "1"}, site("robot2")), root_ / "expired.out");
  Peer bad_perm(args({"publish", "--robot", "1", "--partition", "robot1", "--seconds", "1"}, tampered), root_ / "tampered.out");
  run_until_done({&foreign, &revoked, &expired, &bad_perm});
  EXPECT_EQ(foreign.value("participant"), 0) << foreign.output();  // valid in its own eyes
  EXPECT_EQ(foreign.value("matched"), 0) << foreign.output();
  EXPECT_EQ(revoked.value("participant"), 0) << revoked.output();  // its old CRL does not list itself
  EXPECT_EQ(revoked.value("matched"), 0) << revoked.output();
  EXPECT_LT(expired.value("participant").value_or(0), 0) << expired.output();
  EXPECT_LT(bad_perm.value("participant").value_or(0), 0) << bad_perm.output();
  for (std::uint32_t id : {1u, 2u, 3u}) EXPECT_EQ(station_->robot(id).scans + station_->robot(id).poses, 0u) << id;
  EXPECT_EQ(station_->counters().identity_mismatches, 0u);
}

}  // namespace
}  // namespace teamscan::station
