// Pseudo-terminal pair: posix_openpt + raw slave, symlink management (DDS_SYSTEMD.md §6).
#include "drivers/serial/pty.hpp"

#include <fcntl.h>
#include <sys/ioctl.h>
#include <stdlib.h>
#include <termios.h>
#include <unistd.h>

#include <cstdio>
#include <cstring>
#include <utility>

#include "drivers/serial/posix_call.hpp"
#include "drivers/serial/serial_port.hpp"

namespace teamscan::serial {

PtyPair::PtyPair(PtyPair&& o) noexcept
    : master_fd_{std::exchange(o.master_fd_, -1)},
      slave_fd_{std::exchange(o.slave_fd_, -1)},
      link_path_{std::move(o.link_path_)} {
  std::memcpy(slave_path_, o.slave_path_, sizeof slave_path_);
  o.link_path_.clear();
}

PtyPair& PtyPair::operator=(PtyPair&& o) noexcept {
  if (this != &o) {
    close();
    master_fd_ = std::exchange(o.master_fd_, -1);
    slave_fd_ = std::exchange(o.slave_fd_, -1);
    std::memcpy(slave_path_, o.slave_path_, sizeof slave_path_);
    link_path_ = std::move(o.link_path_);
    o.link_path_.clear();
  }
  return *this;
}

PtyPair::~PtyPair() { close(); }

Result<PtyPair> PtyPair::create() {
  PtyPair pty;
  SysResult r = posix_call([] { return ::posix_openpt(O_RDWR | O_NOCTTY | O_CLOEXEC); });
  if (!r.ok()) return Error{"posix_openpt failed", r.err};
  pty.master_fd_ = static_cast<int>(r.value);
  r = posix_call([&] { return ::grantpt(pty.master_fd_); });
  if (!r.ok()) return Error{"grantpt failed", r.err};
  r = posix_call([&] { return ::unlockpt(pty.master_fd_); });
  if (!r.ok()) return Error{"unlockpt failed", r.err};
  const int name_rc = ::ptsname_r(pty.master_fd_, pty.slave_path_, sizeof pty.slave_path_);
  if (name_rc != 0) return Error{"ptsname_r failed", name_rc};
  r = posix_call([&] { return ::open(pty.slave_path_, O_RDWR | O_NOCTTY | O_CLOEXEC); });
  if (!r.ok()) return Error{"cannot open pty slave", r.err};
  pty.slave_fd_ = static_cast<int>(r.value);

  // The default slave mode is ICANON|ECHO|ONLCR: without raw mode '\n' becomes "\r\n" (§6).
  termios tio{};
  r = posix_call([&] { return ::tcgetattr(pty.slave_fd_, &tio); });
  if (!r.ok()) return Error{"tcgetattr on pty slave failed", r.err};
  ::cfmakeraw(&tio);
  tio.c_cflag |= static_cast<tcflag_t>(CLOCAL | CREAD);
  tio.c_cc[VMIN] = 1;
  tio.c_cc[VTIME] = 0;
  (void)::cfsetispeed(&tio, B9600);
  (void)::cfsetospeed(&tio, B9600);
  r = posix_call([&] { return ::tcsetattr(pty.slave_fd_, TCSANOW, &tio); });
  if (!r.ok()) return Error{"tcsetattr on pty slave failed", r.err};

  r = posix_call([&] { return ::fcntl(pty.master_fd_, F_GETFL); });
  if (!r.ok()) return Error{"fcntl F_GETFL failed", r.err};
  const int flags = static_cast<int>(r.value) | O_NONBLOCK;
  r = posix_call([&] { return ::fcntl(pty.master_fd_, F_SETFL, flags); });
  if (!r.ok()) return Error{"fcntl F_SETFL failed", r.err};
  return pty;
}

Status PtyPair::link(const std::string& symlink_path) {
  if (master_fd_ < 0) return Error{"pty is closed", EBADF};
  // symlink() then rename() replaces an existing link atomically: a host polling for the path never
  // sees it missing.
  const std::string tmp = symlink_path + ".tmp" + std::to_string(::getpid());
  (void)::unlink(tmp.c_str());
  SysResult r = posix_call([&] { return ::symlink(slave_path_, tmp.c_str()); });
  if (!r.ok()) return Error{"symlink failed", r.err};
  r = posix_call([&] { return ::rename(tmp.c_str(), symlink_path.c_str()); });
  if (!r.ok()) {
    (void)::unlink(tmp.c_str());
    return Error{"rename of symlink failed", r.err};
  }
  if (!link_path_.empty() && link_path_ != symlink_path) (void)::unlink(link_path_.c_str());
  link_path_ = symlink_path;
  return ok_status();
}

std::uint32_t PtyPair::slave_baud() const {
  if (master_fd_ < 0) return 0;
  termios tio{};
  const SysResult r = posix_call([&] { return ::tcgetattr(master_fd_, &tio); });
  if (!r.ok()) return 0;
  return speed_to_baud(::cfgetospeed(&tio));
}

Result<std::size_t> PtyPair::host_unread_bytes() const {
  if (slave_fd_ < 0) return Error{"pty is closed", EBADF};
  int queued = 0;
  const SysResult r = posix_call([&] { return ::ioctl(slave_fd_, FIONREAD, &queued); });
  if (!r.ok()) return Error{"FIONREAD on pty slave failed", r.err};
  return static_cast<std::size_t>(queued < 0 ? 0 : queued);
}

Status PtyPair::set_slave_baud(std::uint32_t baud) {
  if (master_fd_ < 0) return Error{"pty is closed", EBADF};
  const speed_t speed = baud_to_speed(baud);
  if (speed == 0) return Error{"unsupported baud rate", EINVAL, static_cast<long>(baud)};
  termios tio{};
  SysResult r = posix_call([&] { return ::tcgetattr(master_fd_, &tio); });
  if (!r.ok()) return Error{"tcgetattr on pty master failed", r.err};
  (void)::cfsetispeed(&tio, speed);
  (void)::cfsetospeed(&tio, speed);
  r = posix_call([&] { return ::tcsetattr(master_fd_, TCSANOW, &tio); });
  if (!r.ok()) return Error{"tcsetattr on pty master failed", r.err};
  return ok_status();
}

void PtyPair::close() {
  if (!link_path_.empty()) {
    // Remove the link only while it still points at our slave: a newer pair may have re-pointed it.
    char target[sizeof slave_path_] = {};
    const ssize_t n = ::readlink(link_path_.c_str(), target, sizeof target - 1);
    if (n > 0 && std::strcmp(target, slave_path_) == 0) (void)::unlink(link_path_.c_str());
    link_path_.clear();
  }
  if (slave_fd_ >= 0) (void)::close(std::exchange(slave_fd_, -1));
  if (master_fd_ >= 0) (void)::close(std::exchange(master_fd_, -1));
}

}  // namespace teamscan::serial
