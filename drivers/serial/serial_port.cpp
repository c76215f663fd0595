// POSIX serial port: termios raw 8N1, poll()-based timeouts, every system call through posix_call.
#include "drivers/serial/serial_port.hpp"

#include <fcntl.h>
#include <poll.h>
#include <sys/ioctl.h>
#include <termios.h>
#include <unistd.h>

#include <algorithm>
#include <utility>

#include "common/clock.hpp"
#include "drivers/serial/posix_call.hpp"

namespace teamscan::serial {
namespace {

struct BaudCode {
  std::uint32_t baud;
  speed_t speed;
};

// B500000 is a Linux extension of <termios.h> (glibc defines it); current kernels accept it on
// FTDI and most USB-RS422 adapters directly (PROTOCOLS.md §2.1), so no custom divisor is needed.
constexpr BaudCode kBaudCodes[] = {
    {1200, B1200},     {1800, B1800},     {2400, B2400},   {4800, B4800},   {9600, B9600},
    {19200, B19200},   {38400, B38400},   {57600, B57600}, {115200, B115200}, {230400, B230400},
    {500000, B500000},
};

// poll() timeout in whole milliseconds, rounded up so that a short wait never becomes a busy loop.
int poll_timeout_ms(Time deadline) {
  const Duration left = deadline - now_monotonic();
  if (left <= Duration::zero()) return 0;
  const auto ms = (left.count() + 999'999) / 1'000'000;
  return static_cast<int>(std::min<std::int64_t>(ms, 60'000));
}

}  // namespace

bool is_supported_baud(std::uint32_t baud) { return baud_to_speed(baud) != 0; }

unsigned baud_to_speed(std::uint32_t baud) {
  for (const auto& c : kBaudCodes)
    if (c.baud == baud) return c.speed;
  return 0;
}

std::uint32_t speed_to_baud(unsigned speed) {
  for (const auto& c : kBaudCodes)
    if (c.speed == speed) return c.baud;
  return 0;
}

SerialPort::SerialPort(SerialPort&& o) noexcept : fd_{std::exchange(o.fd_, -1)}, baud_{o.baud_} {}

SerialPort& SerialPort::operator=(SerialPort&& o) noexcept {
  if (this != &o) {
    close();
    fd_ = std::exchange(o.fd_, -1);
    baud_ = o.baud_;
  }
  return *this;
}

SerialPort::~SerialPort() { close(); }

void SerialPort::close() {
  if (fd_ >= 0) {
    // close() is not retried on EINTR: on Linux the fd is released either way.
    (void)::close(fd_);
    fd_ = -1;
  }
}

Result<SerialPort> SerialPort::open(const char* path, std::uint32_t baud) {
  if (!is_supported_baud(baud)) return Error{"unsupported baud rate", EINVAL, static_cast<long>(baud)};
  SerialPort port;
  const SysResult fd = posix_call([&] { return ::open(path, O_RDWR | O_NOCTTY | O_CLOEXEC | O_NONBLOCK); });
  if (!fd.ok()) return Error{"cannot open serial device", fd.err};
  port.fd_ = static_cast<int>(fd.value);

  termios tio{};
  SysResult r = posix_call([&] { return ::tcgetattr(port.fd_, &tio); });
  if (!r.ok()) return Error{"not a serial device (tcgetattr failed)", r.err};
  ::cfmakeraw(&tio);  // 8 data bits, no parity, no echo, no line editing
  tio.c_cflag &= ~static_cast<tcflag_t>(CSTOPB | CRTSCTS | PARENB);
  tio.c_cflag |= static_cast<tcflag_t>(CLOCAL | CREAD | CS8);
  tio.c_iflag &= ~static_cast<tcflag_t>(IXON | IXOFF | IXANY);
  tio.c_cc[VMIN] = 1;  // with O_NONBLOCK: read() returns EAGAIN when empty, 0 only on hang-up
  tio.c_cc[VTIME] = 0;
  r = posix_call([&] { return ::tcsetattr(port.fd_, TCSANOW, &tio); });
  if (!r.ok()) return Error{"cannot set raw mode (tcsetattr failed)", r.err};
  Status s = port.set_baud(baud);
  if (!s.ok()) return s.error();
  return port;
}

Status SerialPort::set_baud(std::uint32_t baud) {
  if (fd_ < 0) return Error{"serial port is closed", EBADF};
  const speed_t speed = baud_to_speed(baud);
  if (speed == 0) return Error{"unsupported baud rate", EINVAL, static_cast<long>(baud)};
  termios tio{};
  SysResult r = posix_call([&] { return ::tcgetattr(fd_, &tio); });
  if (!r.ok()) return Error{"tcgetattr failed", r.err};
  if (::cfsetispeed(&tio, speed) != 0 || ::cfsetospeed(&tio, speed) != 0)
    return Error{"baud rate rejected by cfsetspeed", errno, static_cast<long>(baud)};
  r = posix_call([&] { return ::tcsetattr(fd_, TCSANOW, &tio); });
  if (!r.ok()) return Error{"tcsetattr failed (baud rate)", r.err, static_cast<long>(baud)};
  // tcsetattr succeeds if any change was applied: read back to catch a rate the driver refused.
  r = posix_call([&] { return ::tcgetattr(fd_, &tio); });
  if (!r.ok()) return Error{"tcgetattr failed", r.err};
  if (::cfgetospeed(&tio) != speed) return Error{"baud rate not accepted by the device", EINVAL, static_cast<long>(baud)};
  baud_ = baud;
  return ok_status();
}

Result<std::size_t> SerialPort::read(std::span<std::uint8_t> buf, Duration timeout) {
  if (fd_ < 0) return Error{"serial port is closed", EBADF};
  if (buf.empty()) return std::size_t{0};
  const Time deadline = now_monotonic() + timeout;
  for (;;) {
    pollfd pfd{fd_, POLLIN, 0};
    const SysResult p = posix_call([&] { return ::poll(&pfd, 1, poll_timeout_ms(deadline)); });
    if (!p.ok()) return Error{"poll failed on serial port", p.err};
    if (p.value == 0) return std::size_t{0};
    if ((pfd.revents & POLLNVAL) != 0) return Error{"serial port fd is invalid", EBADF};
    // Read even when POLLHUP is set: bytes that arrived before the hang-up are still delivered.
    const SysResult n = posix_call([&] { return ::read(fd_, buf.data(), buf.size()); });
    if (n.ok()) {
      if (n.value == 0) return Error{"serial device hung up (end of file)", EIO};
      return static_cast<std::size_t>(n.value);
    }
    if (n.err == EAGAIN || n.err == EWOULDBLOCK) {
      if ((pfd.revents & (POLLHUP | POLLERR)) != 0) return Error{"serial device lost (hang-up)", EIO};
      if (now_monotonic() >= deadline) return std::size_t{0};
      continue;  // spurious wake-up
    }
    return Error{"serial device lost (read failed)", n.err};
  }
}

Status SerialPort::write_all(std::span<const std::uint8_t> bytes, Duration timeout) {
  if (fd_ < 0) return Error{"serial port is closed", EBADF};
  const Time deadline = now_monotonic() + timeout;
  std::size_t done = 0;
  while (done < bytes.size()) {
    const SysResult n = posix_call([&] { return ::write(fd_, bytes.data() + done, bytes.size() - done); });
    if (n.ok()) {
      done += static_cast<std::size_t>(n.value);
      continue;
    }
    if (n.err != EAGAIN && n.err != EWOULDBLOCK) return Error{"serial device lost (write failed)", n.err};
    if (now_monotonic() >= deadline) return Error{"serial write timed out", ETIMEDOUT, static_cast<long>(done)};
    pollfd pfd{fd_, POLLOUT, 0};
    const SysResult p = posix_call([&] { return ::poll(&pfd, 1, poll_timeout_ms(deadline)); });
    if (!p.ok()) return Error{"poll failed on serial port", p.err};
    if ((pfd.revents & (POLLHUP | POLLERR | POLLNVAL)) != 0) return Error{"serial device lost (hang-up)", EIO};
  }
  return ok_status();
}

Status SerialPort::flush_input() {
  if (fd_ < 0) return Error{"serial port is closed", EBADF};
  const SysResult r = posix_call([&] { return ::tcflush(fd_, TCIFLUSH); });
  if (!r.ok()) return Error{"tcflush failed", r.err};
  return ok_status();
}

Status SerialPort::drain(Duration timeout) {
  if (fd_ < 0) return Error{"serial port is closed", EBADF};
  // tcdrain() has no timeout, so wait for the driver's queue to empty first; what is left then is at
  // most the UART FIFO, which leaves within a few character times without flow control.
  const Time deadline = now_monotonic() + timeout;
  for (;;) {
    int queued = 0;
    const SysResult q = posix_call([&] { return ::ioctl(fd_, TIOCOUTQ, &queued); });
    if (!q.ok()) return Error{"TIOCOUTQ failed", q.err};
    if (queued <= 0) break;
    if (now_monotonic() >= deadline) return Error{"serial drain timed out", ETIMEDOUT, queued};
    ::usleep(1000);
  }
  const SysResult r = posix_call([&] { return ::tcdrain(fd_); });
  if (!r.ok()) return Error{"tcdrain failed", r.err};
  return ok_status();
}

}  // namespace teamscan::serial
