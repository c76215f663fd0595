// deploy/'s units hand each daemon its DDS Security bundle: one LoadCredential= per file the daemon
// reads (dds/security/credentials.hpp names them), --pki-dir ${CREDENTIALS_DIRECTORY} on the command line,
// and no restart loop when a credential is refused (exit 2) or cannot be loaded by systemd (243).
// (Exposure and `systemd-analyze verify`: dds_deploy_test.)
#include <filesystem>
#include <fstream>
#include <string>

#include <gtest/gtest.h>

#include "dds/security/credentials.hpp"

namespace fs = std::filesystem;

namespace {

std::string slurp(const fs::path& p) {
  std::ifstream in(p);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

fs::path deploy_dir() {
  const char* s = std::getenv("TEAMSCAN_SOURCE_DIR");
  return fs::path(s != nullptr ? s : ".") / "deploy";
}

TEST(SecureUnits, EveryCredentialFileIsLoadedAndPassedToTheDaemon) {
  const struct {
    const char* unit;
    const char* dir;
  } units[] = {{"teamscan-onboard@.service", "/etc/teamscan/pki/%i/"},
               {"teamscan-groundstation.service", "/etc/teamscan/pki/station/"}};
  for (const auto& u : units) {
    const std::string t = slurp(deploy_dir() / u.unit);
    ASSERT_FALSE(t.empty()) << u.unit;
    for (const char* f : {teamscan::dds::security::kCaCertFile, teamscan::dds::security::kCertFile, teamscan::dds::security::kKeyFile,
                          teamscan::dds::security::kGovernanceFile, teamscan::dds::security::kPermissionsFile,
                          teamscan::dds::security::kCrlFile}) {
      const std::string line = std::string("\nLoadCredential=") + f + ":" + u.dir + f + "\n";
      EXPECT_NE(t.find(line), std::string::npos) << u.unit << " lacks" << line;
    }
    EXPECT_NE(t.find(" --pki-dir ${CREDENTIALS_DIRECTORY}\n"), std::string::npos) << u.unit;
    EXPECT_NE(t.find("\nRestartPreventExitStatus=2 243\n"), std::string::npos) << u.unit;
  }
}

}  // namespace
