// ModelWriter: writes the fused model (fused.pcd / fused_all.pcd) off the receive loop (issue 6). A
// write reads the session files back from disk up to a snapshot the loop took after its fsync
// (scans.bin and poses.csv byte sizes), rebuilds the received data set with the live stage's own code
// (ReceivedBuilder), runs the offline pass and publishes the files by rename(2). No mutable state is
// shared with the loop: the snapshot is copied in, the report copied out. At most one write in flight.
#pragma once

#include <atomic>
#include <cstdint>
#include <functional>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "common/dataset/dataset.hpp"
#include "common/result.hpp"
#include "groundstation/station/fusion.hpp"

namespace teamscan::station {

// A consistent prefix of the session: every complete record of scans.bin and line of poses.csv within
// these byte counts (taken right after SessionStore::sync(), so the prefix is on disk).
struct SessionSnapshot {
  std::uint64_t scans_bytes = 0;
  std::uint64_t poses_bytes = 0;
  // The live decision per point in arrival order (fused_all.pcd's live_keep); copied, may be empty.
  std::vector<std::uint8_t> live_removed;
  std::string why = "periodic";
};

struct ModelWriteReport {
  bool ok = false;
  bool cancelled = false;  // stopped by cancel(): nothing published
  std::string error;
  int sys_errno = 0;
  std::string why;
  std::uint64_t scans = 0;       // scans in the model (replays not counted twice)
  std::uint64_t kept = 0;
  std::uint64_t removed = 0;
  std::uint64_t bad_records = 0; // scans.bin records skipped (CRC, length) or malformed poses.csv lines
  double seconds = 0.0;          // wall time of the whole write (read back + offline pass + files)
};

// Rebuilds the received data set from `dir`'s scans.bin and poses.csv up to `snapshot`'s sizes, in
// arrival order, through ReceivedBuilder (replays of a robot's history dropped as the live stage does),
// own poses refreshed from all poses. `bad` counts skipped records/lines.
[[nodiscard]] Status read_received(const std::string& dir, const SessionSnapshot& snapshot, std::uint32_t replay_window,
                                   Dataset& out, std::uint64_t& bad);

class ModelWriter {
 public:
  ModelWriter(FusionOptions options, std::string session_dir);
  ~ModelWriter();  // waits for a write in flight
  ModelWriter(const ModelWriter&) = delete;
  ModelWriter& operator=(const ModelWriter&) = delete;

  // Starts a write on a worker thread; false (nothing started) while one is in flight.
  bool start(SessionSnapshot snapshot);
  [[nodiscard]] bool busy() const { return in_flight_.load(std::memory_order_acquire); }
  // The report of a finished write, once (the loop logs it); empty while none finished since.
  std::optional<ModelWriteReport> take_report();
  // Waits for a write in flight (shutdown).
  void wait();
  // Asks a write in flight to stop at its next phase boundary (after the read-back, after the offline
  // pass): it then publishes nothing and reports "cancelled". Shutdown: cancel, wait, then run() the
  // final write, so a periodic write never delays the stop by a whole pass.
  void cancel() { cancel_.store(true, std::memory_order_release); }
  // The same write on the caller's thread (shutdown: the final model); with `dataset_dir` non-empty
  // also writes the received data set there from the same read-back.
  ModelWriteReport run(const SessionSnapshot& snapshot, const std::string& dataset_dir = {});

 private:
  ModelWriteReport write(const SessionSnapshot& snapshot, const std::string& dataset_dir, bool cancellable);

 public:

  // Tests: called on the worker thread at the start of each write started by start().
  void set_worker_hook(std::function<void()> hook) { worker_hook_ = std::move(hook); }
  [[nodiscard]] std::uint64_t started() const { return started_; }

 private:
  FusionOptions options_;
  std::string dir_;
  std::thread worker_;
  std::atomic<bool> in_flight_{false};
  std::atomic<bool> cancel_{false};
  std::mutex mutex_;  // guards report_
  std::optional<ModelWriteReport> report_;
  std::function<void()> worker_hook_;
  std::uint64_t started_ = 0;
};

}  // namespace teamscan::station
