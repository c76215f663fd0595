// Flushes the session files to the disk on a thread of its own, every interval, so that the receive loop
// never waits for the disk: fdatasync(2) behind other writers' I/O was seen to block the station's loop
// for hundreds of milliseconds (scan -> taken from DDS p50 0.2 s with 8 robots while builds ran).
// It syncs duplicates of the session files' descriptors (dup(2): the same open files), so it never
// depends on the SessionStore's lifetime; stop() (or the destructor) ends the thread after its current
// sync. The loop's own final sync at shutdown stays synchronous (SessionStore::sync()).
#pragma once

#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <mutex>
#include <thread>
#include <vector>

#include "common/result.hpp"

namespace teamscan::station {

struct DiskSyncFigures {
  std::uint64_t syncs = 0;          // rounds over every file
  std::uint64_t failures = 0;       // fdatasync(2) calls that failed (EIO, ENOSPC...)
  std::int64_t longest_ns = 0;      // the slowest round
};

class DiskSync {
 public:
  // Starts the thread; fails if a descriptor cannot be duplicated.
  [[nodiscard]] static Result<std::unique_ptr<DiskSync>> start(const std::vector<int>& fds,
                                                               std::chrono::nanoseconds interval);
  ~DiskSync();
  DiskSync(const DiskSync&) = delete;
  DiskSync& operator=(const DiskSync&) = delete;

  void stop();
  [[nodiscard]] DiskSyncFigures figures() const;

 private:
  DiskSync(std::vector<int> fds, std::chrono::nanoseconds interval);
  void run();

  std::vector<int> fds_;
  std::chrono::nanoseconds interval_;
  mutable std::mutex mutex_;
  std::condition_variable wake_;
  bool stopping_ = false;
  DiskSyncFigures figures_;
  std::thread thread_;
};

}  // namespace teamscan::station
