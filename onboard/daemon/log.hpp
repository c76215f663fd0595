// Journal-friendly logging for the daemon: one line per message on stderr, with the sd-daemon
// priority prefix (<3> error ... <7> debug) when stderr goes to the journal (JOURNAL_STREAM set),
// so `journalctl -p err` works; plain lines otherwise. No allocation.
#pragma once

#include <cstdarg>
#include <cstdio>
#include <cstdlib>

namespace teamscan::onboard {

enum class LogLevel : int { crit = 2, err = 3, warning = 4, notice = 5, info = 6, debug = 7 };

__attribute__((format(printf, 2, 3))) inline void log_message(LogLevel level, const char* fmt, ...) {
  static const bool journal = std::getenv("JOURNAL_STREAM") != nullptr;
  char line[512];
  va_list ap;
  va_start(ap, fmt);
  std::vsnprintf(line, sizeof line, fmt, ap);
  va_end(ap);
  if (journal) std::fprintf(stderr, "<%d>%s\n", static_cast<int>(level), line);
  else std::fprintf(stderr, "teamscan-onboard: %s\n", line);
}

}  // namespace teamscan::onboard
