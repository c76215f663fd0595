// Unit tests of tools/pki (the site PKI) and dds/security (the credential check and Cyclone's security
// properties): what `teamscan pki init` writes, that private keys are 0600, that the check finds what
// is missing, expired, revoked, tampered or mismatched, and that Cyclone's own plugins accept the
// bundles and enforce the permissions locally (writers outside the grant return NOT_ALLOWED_BY_SECURITY;
// expired, foreign-CA and tampered credentials make participant creation fail).
#include <sys/stat.h>

#include <ctime>
#include <filesystem>
#include <fstream>
#include <string>

#include <dds/dds.h>
#include <gtest/gtest.h>

#include "dds/security/credentials.hpp"
#include "teamscan.h"
#include "tests/support/test_domain.hpp"
#include "tools/pki/site_pki.hpp"

namespace fs = std::filesystem;
using namespace teamscan;

namespace {

std::int64_t now_s() { return static_cast<std::int64_t>(std::time(nullptr)); }

class PkiTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("teamscan_pki_test_" + std::to_string(::getpid()) + "_" +
                                        ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    pki::SiteOptions o;
    o.robots = 2;
    o.domain_min = o.domain_max = test::test_domain_id();
    o.now_s = now_s();
    ASSERT_TRUE(pki::create_site(dir_.string(), o).ok());
  }
  void TearDown() override { fs::remove_all(dir_); }
  std::string bundle(const char* name) const { return (dir_ / name).string(); }
  static bool has(const std::vector<std::string>& v, const std::string& needle) {
    for (const auto& s : v)
      if (s.find(needle) != std::string::npos) return true;
    return false;
  }
  static std::string read(const fs::path& p) {
    std::ifstream in(p);
    return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  }
  // A participant with the bundle's identity, or a negative return code.
  dds_entity_t participant(const std::string& b) const {
    dds_qos_t* q = dds_create_qos();
    dds::security::add_security_properties(q, b);
    const dds_entity_t p = dds_create_participant(test::test_domain_id(), q, nullptr);
    dds_delete_qos(q);
    return p;
  }
  fs::path dir_;
};

mode_t mode_of(const fs::path& p) {
  struct stat st{};
  EXPECT_EQ(::stat(p.c_str(), &st), 0) << p;
  return st.st_mode & 0777;
}

TEST_F(PkiTest, InitWritesEveryBundleWithPrivateKeysOnlyForTheOwner) {
  EXPECT_EQ(mode_of(dir_ / "ca" / "ca_key.pem"), 0600u);
  for (const char* name : {"station", "robot1", "robot2"}) {
    for (const char* f : {dds::security::kCaCertFile, dds::security::kCertFile, dds::security::kKeyFile, dds::security::kGovernanceFile,
                          dds::security::kPermissionsFile, dds::security::kCrlFile})
      EXPECT_TRUE(fs::exists(dir_ / name / f)) << name << "/" << f;
    EXPECT_EQ(mode_of(dir_ / name / dds::security::kKeyFile), 0600u) << name;
    const dds::security::CredentialCheck c = dds::security::check_credentials(bundle(name), now_s());
    EXPECT_TRUE(c.ok()) << name << ": " << c.summary();
    EXPECT_EQ(c.identity, name);
  }
  EXPECT_FALSE(fs::exists(dir_ / "robot3"));
  const pki::SiteReport r = pki::check_site(dir_.string(), now_s());
  EXPECT_EQ(r.problems, 0u);
  EXPECT_EQ(r.lines.size(), 4u);  // ca, robot1, robot2, station
}

TEST_F(PkiTest, APrivateKeyRewrittenOverAReadableFileBecomes0600) {
  const fs::path key = dir_ / "robot1" / dds::security::kKeyFile;
  fs::permissions(key, fs::perms::owner_read | fs::perms::owner_write | fs::perms::group_read | fs::perms::others_read);
  EXPECT_TRUE(has(dds::security::check_credentials(bundle("robot1"), now_s()).problems, "lets group or others read"));
  EXPECT_TRUE(pki::issue_identity(dir_.string(), "robot1", now_s() - 60, now_s() + 86400).ok());
  EXPECT_EQ(mode_of(key), 0600u);
}

TEST_F(PkiTest, CheckSaysWhatIsMissingExpiredOrDoesNotMatch) {
  fs::remove_all(dir_ / "robot2");
  pki::SiteReport r = pki::check_site(dir_.string(), now_s());
  EXPECT_EQ(r.problems, 1u);
  EXPECT_TRUE(has(r.lines, "robot2: missing"));

  // An identity that expired yesterday.
  ASSERT_TRUE(pki::issue_identity(dir_.string(), "robot2", now_s() - 10 * 86400, now_s() - 86400).ok());
  dds::security::CredentialCheck c = dds::security::check_credentials(bundle("robot2"), now_s());
  EXPECT_TRUE(has(c.problems, "certificate has expired")) << c.summary();
  EXPECT_TRUE(has(c.problems, "the grant for CN=robot2,O=TeamScan has expired")) << c.summary();

  // robot1's permissions in robot2's bundle: no grant for robot2's subject.
  ASSERT_TRUE(pki::issue_identity(dir_.string(), "robot2", now_s() - 60, now_s() + 86400).ok());
  fs::copy_file(dir_ / "robot1" / dds::security::kPermissionsFile, dir_ / "robot2" / dds::security::kPermissionsFile,
                fs::copy_options::overwrite_existing);
  c = dds::security::check_credentials(bundle("robot2"), now_s());
  EXPECT_TRUE(has(c.problems, "no grant for CN=robot2,O=TeamScan")) << c.summary();

  // robot1's key in robot2's bundle.
  ASSERT_TRUE(pki::issue_identity(dir_.string(), "robot2", now_s() - 60, now_s() + 86400).ok());
  fs::copy_file(dir_ / "robot1" / dds::security::kKeyFile, dir_ / "robot2" / dds::security::kKeyFile, fs::copy_options::overwrite_existing);
  c = dds::security::check_credentials(bundle("robot2"), now_s());
  EXPECT_TRUE(has(c.problems, "does not match")) << c.summary();

  r = pki::check_site(dir_.string(), now_s());
  EXPECT_EQ(r.problems, 1u);
  EXPECT_TRUE(has(r.lines, "robot2:"));
}

TEST_F(PkiTest, TamperedPermissionsAndAnotherCasIdentityAreFound) {
  // One character of the signed grant changed: robot1 would publish in robot2's partition.
  const fs::path perm = dir_ / "robot1" / dds::security::kPermissionsFile;
  std::string text = read(perm);
  const std::size_t at = text.find("<partition>robot1</partition>");
  ASSERT_NE(at, std::string::npos);
  text[at + 16] = '2';
  std::ofstream(perm, std::ios::trunc) << text;
  dds::security::CredentialCheck c = dds::security::check_credentials(bundle("robot1"), now_s());
  EXPECT_TRUE(has(c.problems, "signature does not verify")) << c.summary();

  // An identity with the same name, from another CA.
  pki::CertAuthority rogue = pki::make_ca("TeamScan", now_s() - 60, now_s() + 86400);
  dds::security::EvpKeyPtr key = pki::make_key();
  dds::security::X509Ptr cert = pki::issue_cert(rogue, key.get(), "robot2", "TeamScan", now_s() - 60, now_s() + 86400);
  ASSERT_TRUE(pki::write_text((dir_ / "robot2" / dds::security::kCertFile).string(), pki::cert_pem(cert.get())).ok());
  ASSERT_TRUE(pki::write_private_key((dir_ / "robot2" / dds::security::kKeyFile).string(), key.get()).ok());
  c = dds::security::check_credentials(bundle("robot2"), now_s());
  EXPECT_TRUE(has(c.problems, "not issued by this site's CA")) << c.summary();
}

TEST_F(PkiTest, RevocationPutsTheCertificateOnTheSiteCrlAndRemovesItsBundle) {
  const std::string old_cert = read(dir_ / "robot2" / dds::security::kCertFile);
  const fs::path old_bundle = dir_.parent_path() / (dir_.filename().string() + "_old_robot2");
  fs::remove_all(old_bundle);
  fs::copy(dir_ / "robot2", old_bundle);
  ASSERT_TRUE(pki::revoke_identity(dir_.string(), "robot2", now_s()).ok());
  EXPECT_FALSE(fs::exists(dir_ / "robot2"));
  EXPECT_EQ(read(dir_ / "revoked" / "robot2" / dds::security::kCertFile), old_cert);
  EXPECT_EQ(read(dir_ / "robot1" / dds::security::kCrlFile), read(dir_ / "ca" / dds::security::kCrlFile));
  // The old bundle with the new CRL: revoked.
  fs::copy_file(dir_ / "ca" / dds::security::kCrlFile, old_bundle / dds::security::kCrlFile, fs::copy_options::overwrite_existing);
  const dds::security::CredentialCheck c = dds::security::check_credentials(old_bundle.string(), now_s());
  EXPECT_TRUE(has(c.problems, "certificate revoked")) << c.summary();
  // Cyclone's authentication plugin honours the CRL: the revoked identity cannot even create a participant.
  EXPECT_LT(participant(old_bundle.string()), 0);
  fs::remove_all(old_bundle);
  const pki::SiteReport r = pki::check_site(dir_.string(), now_s());
  EXPECT_EQ(r.problems, 0u);
  EXPECT_TRUE(has(r.lines, "robot2: revoked"));
}

// Cyclone's plugins with these bundles: the grants as designed, enforced at entity creation.
TEST_F(PkiTest, CyclonesPluginsAcceptTheBundlesAndEnforceTheGrants) {
  const dds_entity_t robot = participant(bundle("robot2"));
  ASSERT_GT(robot, 0) << dds_strretcode(robot);
  const dds_entity_t scan = dds_create_topic(robot, &teamscan_msg_ScanPoints_desc, "teamscan/scan", nullptr, nullptr);
  const dds_entity_t team = dds_create_topic(robot, &teamscan_msg_TeamState_desc, "teamscan/team", nullptr, nullptr);
  ASSERT_GT(scan, 0) << dds_strretcode(scan);
  ASSERT_GT(team, 0) << dds_strretcode(team);
  auto writer_in = [&](dds_entity_t pp, dds_entity_t tp, const char* partition) {
    dds_qos_t* q = dds_create_qos();
    if (partition != nullptr) dds_qset_partition1(q, partition);
    const dds_entity_t pub = dds_create_publisher(pp, q, nullptr);
    dds_delete_qos(q);
    return pub < 0 ? pub : dds_create_writer(pub, tp, nullptr, nullptr);
  };
  EXPECT_GT(writer_in(robot, scan, "robot2"), 0);
  EXPECT_EQ(writer_in(robot, scan, "robot1"), DDS_RETCODE_NOT_ALLOWED_BY_SECURITY);
  EXPECT_EQ(writer_in(robot, scan, nullptr), DDS_RETCODE_NOT_ALLOWED_BY_SECURITY);
  EXPECT_EQ(writer_in(robot, scan, "robot*"), DDS_RETCODE_NOT_ALLOWED_BY_SECURITY);
  EXPECT_EQ(writer_in(robot, team, nullptr), DDS_RETCODE_NOT_ALLOWED_BY_SECURITY);  // only the station
  EXPECT_GT(dds_create_reader(robot, team, nullptr, nullptr), 0);
  EXPECT_EQ(dds_create_reader(robot, scan, nullptr, nullptr), DDS_RETCODE_NOT_ALLOWED_BY_SECURITY);
  dds_delete(robot);

  const dds_entity_t station = participant(bundle("station"));
  ASSERT_GT(station, 0) << dds_strretcode(station);
  const dds_entity_t s_scan = dds_create_topic(station, &teamscan_msg_ScanPoints_desc, "teamscan/scan", nullptr, nullptr);
  const dds_entity_t s_team = dds_create_topic(station, &teamscan_msg_TeamState_desc, "teamscan/team", nullptr, nullptr);
  EXPECT_GT(writer_in(station, s_team, nullptr), 0);
  EXPECT_EQ(writer_in(station, s_scan, "robot1"), DDS_RETCODE_NOT_ALLOWED_BY_SECURITY);
  dds_qos_t* q = dds_create_qos();
  dds_qset_partition1(q, "robot*");
  const dds_entity_t sub = dds_create_subscriber(station, q, nullptr);
  dds_delete_qos(q);
  EXPECT_GT(dds_create_reader(sub, s_scan, nullptr, nullptr), 0);
  dds_delete(station);
}

TEST_F(PkiTest, CyclonesPluginsRefuseExpiredForeignAndTamperedCredentials) {
  ASSERT_TRUE(pki::issue_identity(dir_.string(), "robot1", now_s() - 10 * 86400, now_s() - 86400).ok());
  EXPECT_LT(participant(bundle("robot1")), 0);  // expired certificate (and grant)

  pki::CertAuthority rogue = pki::make_ca("TeamScan", now_s() - 60, now_s() + 86400);
  dds::security::EvpKeyPtr key = pki::make_key();
  dds::security::X509Ptr cert = pki::issue_cert(rogue, key.get(), "robot2", "TeamScan", now_s() - 60, now_s() + 86400);
  ASSERT_TRUE(pki::write_text((dir_ / "robot2" / dds::security::kCertFile).string(), pki::cert_pem(cert.get())).ok());
  ASSERT_TRUE(pki::write_private_key((dir_ / "robot2" / dds::security::kKeyFile).string(), key.get()).ok());
  EXPECT_LT(participant(bundle("robot2")), 0);  // not signed by the identity CA

  const fs::path perm = dir_ / "station" / dds::security::kPermissionsFile;
  std::string text = read(perm);
  const std::size_t at = text.find("robot*");
  ASSERT_NE(at, std::string::npos);
  text.replace(at, 6, "*-----");
  std::ofstream(perm, std::ios::trunc) << text;
  EXPECT_LT(participant(bundle("station")), 0);  // signature failure
}

}  // namespace
