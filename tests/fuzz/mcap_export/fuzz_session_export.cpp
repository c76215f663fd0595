// Fuzz target: export_session_mcap on a session folder whose one file is the input. The first byte
// picks the file (scans.bin, poses.csv, status.csv, fused.pcd), the rest is its content; the other files
// are absent. Any input must end in a written file or an error with a message, never a crash.
#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <string>

#include "tools/mcap_export/session_mcap.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size == 0) return 0;
  static const char* const kFiles[] = {"scans.bin", "poses.csv", "status.csv", "fused.pcd"};
  // One folder per process, in memory where there is a tmpfs (the generated inputs are many).
  static const std::string dir = [] {
    const std::filesystem::path base = std::filesystem::is_directory("/dev/shm")
                                           ? std::filesystem::path("/dev/shm")
                                           : std::filesystem::temp_directory_path();
    const std::string d = (base / ("fuzz_session_export_" + std::to_string(::getpid()))).string();
    std::filesystem::create_directories(d + "/session");
    return d;
  }();
  static const struct RemoveAtExit {
    ~RemoveAtExit() { std::filesystem::remove_all(dir); }
  } remove_at_exit;
  const unsigned pick = data[0] % 4u;
  for (unsigned i = 0; i < 4; ++i) {
    const std::string path = dir + "/session/" + kFiles[i];
    if (i != pick && i != 1) {
      std::remove(path.c_str());
      continue;
    }
    // The picked file gets the input; poses.csv, when not picked, stays empty so the folder is a session.
    if (std::FILE* f = std::fopen(path.c_str(), "wb")) {
      if (i == pick) std::fwrite(data + 1, 1, size - 1, f);
      std::fclose(f);
    }
  }
  std::string message;
  auto r = teamscan::mcap_export::export_session_mcap(dir + "/session", dir + "/out.mcap", {}, message);
  if (!r.ok() && message.empty()) __builtin_trap();  // an error always says what
  return 0;
}
