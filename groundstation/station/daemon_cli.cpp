// teamscan-groundstation's command line, config and credentials (daemon_cli.hpp).
#include "groundstation/station/daemon_cli.hpp"

#include <cstdint>
#include <cstdio>
#include <ctime>
#include <vector>

#include <CLI/CLI.hpp>

#include "common/clock.hpp"
#include "common/units.hpp"
#include "common/version.hpp"
#include "dds/security/credentials.hpp"
#include "dds/security/openssl_util.hpp"
#include "groundstation/station/daemon_log.hpp"

namespace teamscan::station::daemon {

std::optional<int> parse_command_line(int argc, char** argv, CommandLine& out) {
  CLI::App app{"teamscan ground station: receives, stores and tracks the robots' DDS data"};
  app.add_option("--config", out.config_path, "ground-station config (TOML), e.g. deploy/groundstation.toml")
      ->check(CLI::ExistingFile);
  app.add_option("--session-dir", out.session_dir, "store into exactly this folder instead of a new session-<time>");
  app.add_option("--domain", out.domain, "DDS domain id (overrides dds.domain_id)")->check(CLI::Range(-1, 232));
  app.add_option("--pki-dir", out.pki_dir,
                 "DDS Security: the station's credential bundle (teamscan pki; the unit passes $CREDENTIALS_DIRECTORY); "
                 "checked before DDS starts, a bad one exits 2");
  app.add_flag("--check-config", out.check_only, "parse the config (and --pki-dir's credentials), print the effective values and exit");
  app.add_flag_callback(
      "--version",
      [] {
        print_version("teamscan-groundstation");
        throw CLI::Success();
      },
      "print the version and the git commit, and exit");
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e) == 0 ? 0 : 2;  // --help, --version: 0; a usage error: 2 (CLI11's codes are 105-109)
  }
  return std::nullopt;
}

std::optional<int> load_effective_config(const CommandLine& cli, GroundStationConfig& cfg) {
  if (!cli.config_path.empty()) {
    ConfigError err;
    if (!load_groundstation_config(cli.config_path, cfg, err)) {
      log(kErr, "config error: " + err.message);
      return 2;
    }
  }
  if (cli.domain >= 0) cfg.station.domain_id = static_cast<std::uint32_t>(cli.domain);
  if (!cli.pki_dir.empty()) {
    const dds::security::CredentialCheck c = dds::security::check_credentials_for(
        cli.pki_dir, dds::security::kStationIdentity, static_cast<std::int64_t>(std::time(nullptr)));
    if (!c.ok()) {
      log(kErr, "DDS Security credentials refused: " + c.summary());
      return 2;
    }
    log(kInfo, "DDS Security: identity " + c.subject + ", certificate valid until " +
                   dds::security::unix_to_utc(c.not_after_s));
    cfg.station.pki_dir = cli.pki_dir;
  }
  return std::nullopt;
}

namespace {

std::string cpu_list(const std::vector<int>& cpus) {
  std::string out = "[";
  for (std::size_t i = 0; i < cpus.size(); ++i) {
    if (i > 0) out += ", ";
    out += std::to_string(cpus[i]);
  }
  out += ']';
  return out;
}

}  // namespace

void print_effective_config(const GroundStationConfig& cfg) {
  std::printf("session_root = %s\nscan_history_depth = %u\nteam_rate_hz = %.3f\nsilence_timeout_s = %.3f\n",
              cfg.session_root.c_str(), cfg.station.scan_history_depth, 1.0 / to_seconds(cfg.station.team_period),
              to_seconds(cfg.station.silence_timeout));
  std::printf("fusion.enabled = %s\nfusion.method = %s\nfusion.resolution_m = %.3f\nfusion.half_angle_deg = %.3f\n"
              "fusion.write_interval_s = %.3f\nfusion.map_interval_s = %.3f\n",
              cfg.fusion.enabled ? "true" : "false", cfg.fusion.core.method.c_str(),
              cfg.fusion.core.methods.frequency.resolution_m, rad_to_deg(cfg.fusion.core.methods.direction.half_angle_rad),
              to_seconds(cfg.fusion.write_interval), to_seconds(cfg.fusion.map_interval));
  std::string compared;
  for (const std::string& m : cfg.fusion.compare_methods) compared += (compared.empty() ? "\"" : ", \"") + m + "\"";
  std::printf("fusion.compare_methods = [%s]\n", compared.c_str());
  std::printf("ros2.enabled = %s\nros2.map_interval_s = %.3f\nros2.pose_rate_hz = %.3f\nros2.heading_sigma_deg = %.3f\n",
              cfg.ros2.enabled ? "true" : "false", to_seconds(cfg.ros2.map_interval), cfg.ros2.pose_rate_hz,
              cfg.ros2.heading_sigma_deg);
  std::printf("view.listen = \"%s\"\n", cfg.view.listen.c_str());
  std::printf("view.cpus = %s\nfusion.writer_cpus = %s\nregistration.cpus = %s\n", cpu_list(cfg.view.cpus).c_str(),
              cpu_list(cfg.fusion.writer_cpus).c_str(), cpu_list(cfg.fusion.core.registration_options.cpus).c_str());
}

}  // namespace teamscan::station::daemon
