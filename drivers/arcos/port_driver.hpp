// The I/O side of the ARCOS link: ArcosPortDriver runs an ArcosClient on a real serial port
// (serial::SerialPort), reopening the device after a loss; run_pioneer_on_pty() serves an emulated
// Pioneer on a pseudo-terminal (serial::PtyRunner) for HIL tests and `teamscan emulate`.
#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <string>

#include "common/result.hpp"
#include "common/time.hpp"
#include "drivers/arcos/client.hpp"
#include "drivers/arcos/emulator.hpp"
#include "drivers/serial/pty_runner.hpp"
#include "drivers/serial/serial_port.hpp"

namespace teamscan::arcos {

struct ArcosPortDriverStatistics {
  std::uint64_t opens = 0;        // successful opens of the device
  std::uint64_t open_failures = 0;
  std::uint64_t losses = 0;       // read/write/baud errors that closed the port
  std::uint64_t bytes_read = 0, bytes_written = 0;
};

class ArcosPortDriver {
 public:
  // `path` is copied (start-up); the client must outlive the driver.
  ArcosPortDriver(ArcosClient& client, const char* path, Duration reopen_period = 1s);

  // One turn of the loop (STYLE.md 8): open or reopen when due, tick the client, apply its rate,
  // write what it queued, then wait for bytes up to its next deadline (at most `max_wait`).
  void step(Duration max_wait = 20ms);
  // Steps until `stop_at` (monotonic clock).
  void run_until(Time stop_at, Duration max_wait = 20ms);

  [[nodiscard]] bool port_open() const { return port_.is_open(); }
  [[nodiscard]] const ArcosPortDriverStatistics& statistics() const { return stats_; }
  [[nodiscard]] const Error& last_error() const { return last_error_; }

 private:
  void lose(Time now, const Error& e);

  ArcosClient& client_;
  std::array<char, 256> path_{};
  Duration reopen_period_;
  serial::SerialPort port_;
  bool lost_ = false;
  Time next_open_{};
  ArcosPortDriverStatistics stats_{};
  Error last_error_{};
  std::array<std::uint8_t, kSerialRxChunk> buf_{};
};

// Puts `robot` on a pseudo-terminal (symlink `link_path`, "" for none) and starts the runner's
// thread. The robot must outlive the runner; drive it through runner->with_device()/locked().
[[nodiscard]] Result<std::unique_ptr<serial::PtyRunner>> run_pioneer_on_pty(PioneerEmulator& robot,
                                                                            const std::string& link_path);

}  // namespace teamscan::arcos
