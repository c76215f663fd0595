// `teamscan version`: prints the tool's version.
#include <cstdio>

#include "tools/teamscan/subcommand.hpp"

namespace teamscan::tool {
namespace {
const SubcommandRegistration kVersion{{"version", "Print the teamscan version", [](CLI::App&) {
                                         return [] {
                                           std::printf("teamscan 0.1.0\n");
                                           return 0;
                                         };
                                       }}};
}  // namespace
}  // namespace teamscan::tool
