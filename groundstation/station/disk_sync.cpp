// Session files flushed to the disk off the receive loop (disk_sync.hpp).
#include "groundstation/station/disk_sync.hpp"

#include <fcntl.h>
#include <unistd.h>

#include <cerrno>
#include <memory>
#include <string>

namespace teamscan::station {

Result<std::unique_ptr<DiskSync>> DiskSync::start(const std::vector<int>& fds, std::chrono::nanoseconds interval) {
  std::vector<int> own;
  for (int fd : fds) {
    if (fd < 0) continue;
    const int d = ::fcntl(fd, F_DUPFD_CLOEXEC, 0);
    if (d < 0) {
      const int e = errno;
      for (int o : own) ::close(o);
      return Error{"station: cannot duplicate a session file descriptor for the disk sync", e};
    }
    own.push_back(d);
  }
  if (interval.count() <= 0) interval = std::chrono::seconds(1);
  return std::unique_ptr<DiskSync>(new DiskSync(std::move(own), interval));
}

DiskSync::DiskSync(std::vector<int> fds, std::chrono::nanoseconds interval)
    : fds_{std::move(fds)}, interval_{interval}, thread_{[this] { run(); }} {}

DiskSync::~DiskSync() {
  stop();
  for (int fd : fds_) ::close(fd);
}

void DiskSync::stop() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stopping_ = true;
  }
  wake_.notify_all();
  if (thread_.joinable()) thread_.join();
}

DiskSyncFigures DiskSync::figures() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return figures_;
}

void DiskSync::run() {
  std::unique_lock<std::mutex> lock(mutex_);
  while (!stopping_) {
    if (wake_.wait_for(lock, interval_, [this] { return stopping_; })) break;
    lock.unlock();
    const auto t0 = std::chrono::steady_clock::now();
    std::uint64_t failed = 0;
    for (int fd : fds_) {
      if (::fdatasync(fd) != 0) ++failed;
    }
    const std::int64_t took = std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::steady_clock::now() - t0).count();
    lock.lock();
    ++figures_.syncs;
    figures_.failures += failed;
    if (took > figures_.longest_ns) figures_.longest_ns = took;
  }
}

}  // namespace teamscan::station
