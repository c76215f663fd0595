// read_clock_sync (clock_sync.hpp).
#include "onboard/daemon/clock_sync.hpp"

#include <sys/timex.h>
#include <unistd.h>

namespace teamscan::onboard {

ClockSync read_clock_sync() noexcept {
  struct timex tx{};
  tx.modes = 0;  // read only
  const int state = ::adjtimex(&tx);
  if (state >= 0) {
    return (state == TIME_ERROR || (tx.status & STA_UNSYNC) != 0) ? ClockSync::kNotSynchronised : ClockSync::kSynchronised;
  }
  // EPERM under ProtectClock=yes: timesyncd's flag file (created on its first synchronisation).
  if (::access("/run/systemd/timesync/synchronized", F_OK) == 0) return ClockSync::kSynchronised;
  return ClockSync::kUnknown;
}

const char* to_string(ClockSync s) noexcept {
  switch (s) {
    case ClockSync::kSynchronised: return "synchronised";
    case ClockSync::kNotSynchronised: return "NOT synchronised";
    case ClockSync::kUnknown: break;
  }
  return "unknown";
}

}  // namespace teamscan::onboard
