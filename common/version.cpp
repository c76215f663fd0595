// version.hpp: the values come from build/<preset>/generated/teamscan_version.h (cmake/GitVersion.cmake).
#include "common/version.hpp"

#include <cstdio>

#include "teamscan_version.h"

namespace teamscan {

const char* version() { return TEAMSCAN_VERSION; }
const char* git_commit() { return TEAMSCAN_GIT_COMMIT; }

void print_version(const char* program) { std::printf("%s %s (git %s)\n", program, version(), git_commit()); }

}  // namespace teamscan
