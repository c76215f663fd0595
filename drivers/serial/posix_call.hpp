// The one seam for system calls in drivers/serial (STYLE.md 4, after iceoryx posix_call.hpp): retries
// EINTR and turns -1/errno into an error value, so no caller forgets either.
#pragma once

#include <cerrno>
#include <type_traits>

namespace teamscan::serial {

// The outcome of one system call: its return value, or the errno it failed with (EINTR never).
struct SysResult {
  long value = -1;
  int err = 0;
  [[nodiscard]] bool ok() const { return err == 0; }
};

// Calls `call()` until it returns anything but -1 with errno EINTR. `call` is re-evaluated on every
// retry, so a call with a timeout recomputes the time left from its own deadline (see SerialPort).
template <class Call>
[[nodiscard]] SysResult posix_call(Call&& call) {
  for (;;) {
    errno = 0;
    const auto rc = call();
    static_assert(std::is_integral_v<decltype(rc)>, "posix_call wraps calls that return an integer");
    if (rc == -1) {
      const int e = errno;
      if (e == EINTR) continue;
      return SysResult{-1, e == 0 ? EIO : e};
    }
    return SysResult{static_cast<long>(rc), 0};
  }
}

}  // namespace teamscan::serial
