// `teamscan version`: prints the tool's version and git commit (the same line as `teamscan --version`).
#include "common/version.hpp"
#include "tools/teamscan/subcommand.hpp"

namespace teamscan::tool {
namespace {
const SubcommandRegistration kVersion{{"version", "Print the teamscan version and git commit", [](CLI::App&) {
                                         return [] {
                                           print_version("teamscan");
                                           return 0;
                                         };
                                       }}};
}  // namespace
}  // namespace teamscan::tool
