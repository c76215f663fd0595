// teamscan-groundstation's command line: its options, the config and credentials they name (checked
// before DDS starts), and --check-config's print of the effective values.
#pragma once

#include <optional>
#include <string>

#include "groundstation/station/config.hpp"

namespace teamscan::station::daemon {

struct CommandLine {
  std::string config_path;  // --config; empty: the defaults
  std::string session_dir;  // --session-dir; empty: a new session-<time> under session_root
  std::string pki_dir;      // --pki-dir; empty: DDS Security off
  long domain = -2;         // --domain; negative: the config's
  bool check_only = false;  // --check-config
};

// The command line read into `out`. A value: exit now with it (--help and --version 0, a usage error 2).
[[nodiscard]] std::optional<int> parse_command_line(int argc, char** argv, CommandLine& out);

// The config the command line names, with --domain and --pki-dir applied (the credentials checked). A
// value: the error is logged, exit with it (2).
[[nodiscard]] std::optional<int> load_effective_config(const CommandLine& cli, GroundStationConfig& cfg);

// --check-config: the effective values on stdout, one `key = value` a line.
void print_effective_config(const GroundStationConfig& cfg);

}  // namespace teamscan::station::daemon
