// teamscan-groundstation's messages on stderr (daemon_log.hpp).
#include "groundstation/station/daemon_log.hpp"

#include <cstdio>
#include <cstdlib>

namespace teamscan::station::daemon {

void log(int priority, const std::string& text) {
  static const bool journal = std::getenv("JOURNAL_STREAM") != nullptr;
  if (journal) {
    std::fprintf(stderr, "<%d>%s\n", priority, text.c_str());
  } else {
    std::fprintf(stderr, "teamscan-groundstation: %s\n", text.c_str());
  }
}

}  // namespace teamscan::station::daemon
