// POSIX serial port (PROTOCOLS.md §1.1, §2.1): raw 8N1, no flow control, standard rates and 500000 baud,
// reads and writes with timeouts, device loss reported as an Error value (never fatal).
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>

#include "common/result.hpp"
#include "common/time.hpp"

namespace teamscan::serial {

// 1200..230400 (the standard termios rates) and 500000 (the LMS 2xx fast rate, PROTOCOLS.md §2.1).
[[nodiscard]] bool is_supported_baud(std::uint32_t baud);

// The termios speed_t code of a supported rate (0 if unsupported), and back (0 if unknown).
[[nodiscard]] unsigned baud_to_speed(std::uint32_t baud);
[[nodiscard]] std::uint32_t speed_to_baud(unsigned speed);

// A serial device opened O_NOCTTY|O_CLOEXEC|O_NONBLOCK in raw 8N1 without flow control.
// Move-only; the fd closes on destruction. Every method reports a fault as a value.
class SerialPort {
 public:
  SerialPort() = default;
  SerialPort(const SerialPort&) = delete;
  SerialPort& operator=(const SerialPort&) = delete;
  SerialPort(SerialPort&& o) noexcept;
  SerialPort& operator=(SerialPort&& o) noexcept;
  ~SerialPort();

  [[nodiscard]] static Result<SerialPort> open(const char* path, std::uint32_t baud);
  // Sets both directions to `baud` (TCSANOW). 500000 uses B500000; unsupported rates are an Error.
  [[nodiscard]] Status set_baud(std::uint32_t baud);
  // Waits up to `timeout` for bytes; returns how many were read, 0 on timeout. Device loss (EIO,
  // ENXIO, POLLHUP/POLLERR without data, end of file on a hung-up tty) is an Error.
  [[nodiscard]] Result<std::size_t> read(std::span<std::uint8_t> buf, Duration timeout);
  // Writes every byte or fails: an Error on device loss or when `timeout` passes first.
  [[nodiscard]] Status write_all(std::span<const std::uint8_t> bytes, Duration timeout);
  // Discards bytes received but not read (tcflush TCIFLUSH).
  [[nodiscard]] Status flush_input();
  // Waits until the output queue is empty (TIOCOUTQ) and then tcdrain; an Error after `timeout`.
  [[nodiscard]] Status drain(Duration timeout);

  [[nodiscard]] int fd() const { return fd_; }
  [[nodiscard]] bool is_open() const { return fd_ >= 0; }
  [[nodiscard]] std::uint32_t baud() const { return baud_; }
  void close();

 private:
  int fd_ = -1;
  std::uint32_t baud_ = 0;
};

}  // namespace teamscan::serial
