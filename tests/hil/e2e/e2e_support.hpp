// Shared by the e2e tests: run `teamscan demo` with arguments into a fresh folder, read its summary.json.
#pragma once

#include <unistd.h>
#include <sys/wait.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

namespace teamscan::e2e {

inline std::string teamscan_binary() {
  const char* b = std::getenv("TEAMSCAN_BINARY_DIR");
  return std::string{b ? b : "."} + "/tools/teamscan/teamscan";
}

// Runs the demo (its stdout, the summary, goes to DIR/demo.out; its stderr, progress and events, to
// DIR/demo.err); returns its exit status.
inline int run_demo(const std::string& dir, const std::string& args) {
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  const std::string cmd = teamscan_binary() + " demo --quiet --out " + dir + " " + args + " > " + dir + "/demo.out 2> " + dir + "/demo.err";
  const int rc = std::system(cmd.c_str());
  return WIFEXITED(rc) ? WEXITSTATUS(rc) : -1;
}

inline std::string read_file(const std::string& path) {
  std::ifstream in(path);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

// The demo's output for a failure message: its summary, then its progress and events.
inline std::string demo_log(const std::string& dir) {
  return read_file(dir + "/demo.out") + "\n--- stderr ---\n" + read_file(dir + "/demo.err");
}

// The text of `"key": value` (number, true/false, or [..]) after position `from` in a JSON text.
inline std::string json_value(const std::string& json, const std::string& key, std::size_t from = 0) {
  const std::size_t k = json.find("\"" + key + "\":", from);
  if (k == std::string::npos) return {};
  std::size_t v = k + key.size() + 3;
  while (v < json.size() && json[v] == ' ') ++v;
  std::size_t e = v;
  if (json[v] == '[') {
    e = json.find(']', v) + 1;
  } else {
    while (e < json.size() && json[e] != ',' && json[e] != '}' && json[e] != '\n') ++e;
  }
  return json.substr(v, e - v);
}

inline double json_number(const std::string& json, const std::string& key, std::size_t from = 0) {
  const std::string v = json_value(json, key, from);
  return v.empty() ? -1e300 : std::stod(v);
}

// Position of robot `id`'s object in the "robots" array.
inline std::size_t robot_entry(const std::string& json, int id) {
  return json.find("{\"id\": " + std::to_string(id) + ",", json.find("\"robots\""));
}

}  // namespace teamscan::e2e
