// A pseudo-terminal pair for tests and emulated devices (DDS_SYSTEMD.md §6): the host program opens
// the slave (/dev/pts/N, or a symlink to it) as its "serial port"; the device side talks on the master.
#pragma once

#include <cstdint>
#include <string>

#include "common/result.hpp"

namespace teamscan::serial {

// Move-only. The master fd is non-blocking (use poll). One slave fd stays open for the pair's life so
// that the master never reads EIO while the host program closes and reopens its port (§6 "Hangup").
class PtyPair {
 public:
  PtyPair() = default;
  PtyPair(const PtyPair&) = delete;
  PtyPair& operator=(const PtyPair&) = delete;
  PtyPair(PtyPair&& o) noexcept;
  PtyPair& operator=(PtyPair&& o) noexcept;
  ~PtyPair();

  // A new pair with the slave in raw mode (cfmakeraw: no echo, no CR/LF mapping) at 9600 baud.
  [[nodiscard]] static Result<PtyPair> create();

  [[nodiscard]] int master_fd() const { return master_fd_; }
  [[nodiscard]] const char* slave_path() const { return slave_path_; }
  [[nodiscard]] bool is_open() const { return master_fd_ >= 0; }
  // Points `symlink_path` at the slave, atomically replacing an old link; removed on close/destruction.
  [[nodiscard]] Status link(const std::string& symlink_path);
  [[nodiscard]] const std::string& link_path() const { return link_path_; }
  // The rate the host program set on the slave. termios ioctls on a master act on the slave, so this
  // is tcgetattr(master) (§6 "Baud rate"); the kernel stores the rate but does not enforce it.
  // 0 when closed or when the rate is not one of ours (is_supported_baud).
  [[nodiscard]] std::uint32_t slave_baud() const;
  // Bytes written on the master that the host has not read yet (FIONREAD on the pair's own slave fd):
  // a server waits for 0 before closing, or the host would lose them in the hang-up.
  [[nodiscard]] Result<std::size_t> host_unread_bytes() const;
  // Sets the slave's rate from the master side (what a host would see before it sets its own).
  [[nodiscard]] Status set_slave_baud(std::uint32_t baud);
  // "Unplug": closes master and slave fds and removes the symlink; the host sees EIO/hang-up.
  void close();

 private:
  int master_fd_ = -1;
  int slave_fd_ = -1;
  char slave_path_[64] = {};
  std::string link_path_;
};

}  // namespace teamscan::serial
