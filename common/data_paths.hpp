// Where a program finds the data files teamscan installs (DDS configs, scenarios, examples, web
// pages): the install prefix first, the source tree as the developer's fallback. Every program and
// library that reads a shipped data file looks it up here, never with its own path guesses.
#pragma once

#include <string>
#include <string_view>

namespace teamscan {

struct DataFile {
  std::string path;      // absolute; empty if the file was found nowhere
  std::string searched;  // every place looked in, for the error message ("a, b, c")
};

// `installed` is the path under share/teamscan ("cyclonedds-lo.xml", "scenarios/lap2.toml"),
// `in_source` the same file's path in the source tree ("deploy/cyclonedds-lo.xml"). Looked up, in
// order: <dir of this executable>/../share/teamscan/<installed> (any install prefix, also a
// relocated one), <source tree>/<in_source> (build trees; compiled in, used only while it exists),
// <configured prefix>/share/teamscan/<installed> (compiled in).
[[nodiscard]] DataFile find_data_file(std::string_view installed, std::string_view in_source);

// The folder of the running executable (/proc/self/exe), "." if unknown.
[[nodiscard]] std::string executable_dir();

}  // namespace teamscan
