// The version of every teamscan program: the project version and the git commit it was built from
// (baked in at build time; "unknown" when built from a tree without git, e.g. a release tarball).
#pragma once

namespace teamscan {

[[nodiscard]] const char* version();     // "0.1.0"
[[nodiscard]] const char* git_commit();  // "e5bae38c1f2a", "e5bae38c1f2a-dirty" or "unknown"

// Every program's --version line on stdout: "<program> 0.1.0 (git e5bae38c1f2a)".
void print_version(const char* program);

}  // namespace teamscan
