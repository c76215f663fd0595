// find_data_file (data_paths.hpp): the install prefix, the source tree, the configured share dir.
#include "common/data_paths.hpp"

#include <filesystem>
#include <system_error>

namespace teamscan {

std::string executable_dir() {
  std::error_code ec;
  const std::filesystem::path exe = std::filesystem::read_symlink("/proc/self/exe", ec);
  return ec ? std::string{"."} : exe.parent_path().string();
}

DataFile find_data_file(std::string_view installed, std::string_view in_source) {
  namespace fs = std::filesystem;
  const fs::path candidates[] = {fs::path(executable_dir()) / ".." / "share" / "teamscan" / installed,
                                 fs::path(TEAMSCAN_SOURCE_TREE) / in_source,
                                 fs::path(TEAMSCAN_INSTALL_DATADIR) / installed};
  DataFile found;
  for (const fs::path& c : candidates) {
    const std::string p = c.lexically_normal().string();
    std::error_code ec;
    if (fs::is_regular_file(c, ec)) {
      found.path = fs::absolute(c, ec).lexically_normal().string();
      return found;
    }
    found.searched += (found.searched.empty() ? "" : ", ") + p;
  }
  return found;
}

}  // namespace teamscan
