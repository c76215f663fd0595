// teamscan: the user's tool. Thin: parses arguments and calls the libraries (DESIGN.md).
#include <algorithm>
#include <cstdio>
#include <map>

#include "common/version.hpp"
#include "tools/teamscan/subcommand.hpp"

namespace teamscan::tool {
std::vector<Subcommand>& subcommand_registry() {
  static std::vector<Subcommand> registry;
  return registry;
}
}  // namespace teamscan::tool

int main(int argc, char** argv) {
  using teamscan::tool::subcommand_registry;
  CLI::App app{"teamscan: simulate, emulate, record, replay, decode, evaluate and render multi-robot laser surveys"};
  app.require_subcommand(1);
  app.add_flag_callback(
      "--version",
      [] {
        teamscan::print_version("teamscan");
        throw CLI::Success();
      },
      "Print the version and the git commit, and exit");
  auto& registry = subcommand_registry();
  std::sort(registry.begin(), registry.end(), [](const auto& a, const auto& b) { return a.name < b.name; });
  std::map<CLI::App*, std::function<int()>> runners;
  for (auto& sub : registry) {
    CLI::App* sub_app = app.add_subcommand(sub.name, sub.description);
    runners[sub_app] = sub.setup(*sub_app);
  }
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    // --help and --version exit 0; every usage error exits 2 (the project's convention; CLI11's own
    // codes are 105-109).
    return app.exit(e) == 0 ? 0 : 2;
  }
  for (auto& [sub_app, run] : runners)
    if (sub_app->parsed()) return run();
  return 2;
}
