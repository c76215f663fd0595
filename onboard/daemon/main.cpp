// teamscan-onboard: the robot daemon (DESIGN.md). Parses the command line, loads the config, builds the
// DDS publisher and runs the event loop. Exit codes: 0 stopped by SIGTERM/SIGINT (or --check-config
// passed), 1 resource error (DDS, epoll, ...), 2 configuration error (systemd: RestartPreventExitStatus=2).
#include <cstdio>
#include <cstring>
#include <ctime>
#include <string>

#include "common/version.hpp"
#include "dds/security/credentials.hpp"
#include "dds/security/openssl_util.hpp"
#include "onboard/core/config.hpp"
#include "onboard/daemon/daemon.hpp"
#include "onboard/daemon/log.hpp"
#include "onboard/daemon/publisher.hpp"

namespace {

constexpr const char* kUsage =
    "usage: teamscan-onboard --config FILE.toml [--pki-dir DIR] [--check-config] [--help] [--version]\n"
    "\n"
    "The teamscan robot daemon: runs the Pioneer 3-AT (ARCOS) and the SICK LMS-200 on their serial\n"
    "ports, turns every scan into 3-D points in the map frame, flags teammates with the direction\n"
    "filter (paper eq. 7) and publishes pose, scans and status over DDS (teamscan/pose, /scan,\n"
    "/status; subscribes to teamscan/team). Runs under systemd (Type=notify, WatchdogSec) or alone.\n"
    "\n"
    "  --config FILE    the robot's TOML config (examples: onboard-down-laser.toml and\n"
    "                   onboard-up-laser.toml in /usr/share/teamscan/examples or deploy/)\n"
    "  --pki-dir DIR    DDS Security: this robot's credential bundle (teamscan pki; the unit passes\n"
    "                   $CREDENTIALS_DIRECTORY); checked before DDS starts, a bad one exits 2\n"
    "  --check-config   parse and check FILE (and --pki-dir's credentials), print the settings, exit 0\n"
    "                   if valid and 2 if not\n"
    "  --help           this text\n"
    "  --version        the version and the git commit\n"
    "\n"
    "Signals: SIGTERM/SIGINT stop the laser stream, close the Pioneer and exit 0; SIGUSR1 logs and\n"
    "publishes a status at once. DDS uses CYCLONEDDS_URI (tests and development: the loopback config\n"
    "deploy/cyclonedds-lo.xml).\n";

}  // namespace

int main(int argc, char** argv) {
  using namespace teamscan::onboard;
  std::string config_path;
  std::string pki_dir;
  bool check_only = false;
  for (int i = 1; i < argc; ++i) {
    const char* a = argv[i];
    if (std::strcmp(a, "--help") == 0 || std::strcmp(a, "-h") == 0) {
      std::fputs(kUsage, stdout);
      return 0;
    }
    if (std::strcmp(a, "--version") == 0) {
      teamscan::print_version("teamscan-onboard");
      return 0;
    }
    if (std::strcmp(a, "--check-config") == 0) {
      check_only = true;
    } else if (std::strcmp(a, "--config") == 0 && i + 1 < argc) {
      config_path = argv[++i];
    } else if (std::strncmp(a, "--config=", 9) == 0) {
      config_path = a + 9;
    } else if (std::strcmp(a, "--pki-dir") == 0 && i + 1 < argc) {
      pki_dir = argv[++i];
    } else {
      std::fprintf(stderr, "teamscan-onboard: unknown or incomplete argument '%s'\n\n%s", a, kUsage);
      return 2;
    }
  }
  if (config_path.empty()) {
    std::fprintf(stderr, "teamscan-onboard: --config FILE is required\n\n%s", kUsage);
    return 2;
  }
  std::string message;
  auto config = load_onboard_config(config_path, message);
  if (!config.ok()) {
    log_message(LogLevel::err, "refusing the config: %s", message.c_str());
    return 2;
  }
  if (!pki_dir.empty()) {
    const std::string identity = teamscan::dds::security::robot_identity(config.value().robot_id);
    const teamscan::dds::security::CredentialCheck c =
        teamscan::dds::security::check_credentials_for(pki_dir, identity, static_cast<std::int64_t>(std::time(nullptr)));
    if (!c.ok()) {
      log_message(LogLevel::err, "DDS Security credentials refused: %s", c.summary().c_str());
      return 2;
    }
    log_message(LogLevel::info, "DDS Security: identity %s, certificate valid until %s", c.subject.c_str(),
                teamscan::dds::security::unix_to_utc(c.not_after_s).c_str());
  }
  if (check_only) {
    std::printf("%s: valid\n%s\n", config_path.c_str(), describe(config.value()).c_str());
    return 0;
  }
  log_message(LogLevel::info, "config %s: %s", config_path.c_str(), describe(config.value()).c_str());

  auto publisher = make_publisher(config.value(), pki_dir.empty() ? nullptr : pki_dir.c_str());
  if (!publisher.ok()) {
    log_message(LogLevel::err, "cannot start the DDS bridge: %s (errno %d)", publisher.error().what,
                publisher.error().sys_errno);
    return 1;
  }
  auto daemon = OnboardDaemon::create(config.value(), *publisher.value());
  if (!daemon.ok()) {
    log_message(LogLevel::err, "cannot set up the event loop: %s (%s)", daemon.error().what,
                std::strerror(daemon.error().sys_errno));
    return 1;
  }
  return daemon.value()->run();
}
