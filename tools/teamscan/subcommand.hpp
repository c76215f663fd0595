// Subcommand registry of the `teamscan` tool: every cmd_<name>.cpp defines one static
// SubcommandRegistration that adds its options to the CLI11 app and returns the exit code when run.
#pragma once

#include <functional>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

namespace teamscan::tool {

struct Subcommand {
  std::string name;
  std::string description;
  // Adds options to `app` (the subcommand's own CLI::App) and returns the function that runs it.
  std::function<std::function<int()>(CLI::App& app)> setup;
};

std::vector<Subcommand>& subcommand_registry();

struct SubcommandRegistration {
  explicit SubcommandRegistration(Subcommand s) { subcommand_registry().push_back(std::move(s)); }
};

}  // namespace teamscan::tool
