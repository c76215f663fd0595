// What the hil tests that run teamscan-onboard (and teamscan-groundstation) as processes share: a
// temporary folder, the binaries' paths in the build tree (ctest's TEAMSCAN_BINARY_DIR), spawning one with
// its output into a log file, and reading a log back.
#pragma once

#include <fcntl.h>
#include <stdlib.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

namespace teamscan::test {

struct TempDir {
  std::filesystem::path path;
  explicit TempDir(const char* prefix = "teamscan-onboard") {
    std::string tmpl = (std::filesystem::temp_directory_path() / (std::string(prefix) + "-XXXXXX")).string();
    path = ::mkdtemp(tmpl.data());
  }
  ~TempDir() {
    std::error_code ec;
    std::filesystem::remove_all(path, ec);
  }
};

inline std::string binary_dir() {
  const char* b = std::getenv("TEAMSCAN_BINARY_DIR");
  return b != nullptr ? b : ".";
}
inline std::string daemon_path() { return binary_dir() + "/onboard/daemon/teamscan-onboard"; }
inline std::string station_path() { return binary_dir() + "/groundstation/station/teamscan-groundstation"; }
inline std::string source_dir() {
  const char* d = std::getenv("TEAMSCAN_SOURCE_DIR");
  return d != nullptr ? d : ".";
}

// Forks and executes args[0] with `env_add` ("NAME=value") added, stdout and stderr into `log_file`
// (appended to with `append`, else truncated). The child's pid (the caller waits for it).
inline pid_t spawn(const std::vector<std::string>& args, const std::vector<std::string>& env_add,
                   const std::filesystem::path& log_file, bool append = false) {
  const pid_t pid = ::fork();
  if (pid != 0) return pid;
  const int fd = ::open(log_file.c_str(), O_WRONLY | O_CREAT | (append ? O_APPEND : O_TRUNC), 0644);
  if (fd >= 0) {
    ::dup2(fd, 1);
    ::dup2(fd, 2);
  }
  for (const auto& e : env_add) ::putenv(const_cast<char*>(e.c_str()));
  std::vector<char*> argv;
  for (const auto& a : args) argv.push_back(const_cast<char*>(a.c_str()));
  argv.push_back(nullptr);
  ::execv(argv[0], argv.data());
  ::_exit(127);
}

inline std::string file_text(const std::filesystem::path& p) {
  std::ifstream in(p);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

}  // namespace teamscan::test
