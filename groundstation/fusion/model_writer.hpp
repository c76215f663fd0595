// The fused model's writer: a core's model store with its decisions, taken in parts (ModelSnapshot),
// streamed into the model's binary PCD files (ModelFileWriter), and ModelWriter, which writes a set of
// cores' models off the caller's loop: the snapshot in the loop in slices of at most write_slice_ms, the
// files on a writer thread, one write in flight, a request meanwhile coalesced into one that follows.
//
// The writer thread yields to the receive loop: it runs SCHED_IDLE (and nice 19, should the kernel
// refuse SCHED_IDLE), so on a CPU it shares with the loop it only takes time the loop leaves idle, and a
// waking loop preempts it at once (a CPU that is never idle finishes no periodic write until it is:
// requests coalesce, the queue stays bounded, the synchronous write still completes). It is not pinned
// away from the loop's CPU unless writer_cpus says so. The loop never waits for the writer in its
// per-turn calls (poll, request): they only try its mutex and come back next turn when the writer holds
// it (its critical sections are a queue operation each, but an idle-class thread can be preempted
// inside one).
#pragma once

#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <functional>
#include <memory>
#include <mutex>
#include <span>
#include <string>
#include <thread>
#include <vector>

#include "common/result.hpp"
#include "common/thread_placement.hpp"
#include "common/time.hpp"
#include "groundstation/fusion/model_store.hpp"

namespace teamscan::fusion {

class FusionCore;

// Model rows with their decisions (FusionCore::snapshot_model_part): a copy, so it can be written on
// another thread while the core goes on.
struct ModelSnapshot {
  std::vector<ModelPoint> points;
  std::vector<std::uint8_t> removed;  // one per point: the decision when it was taken
  std::uint64_t kept = 0;
};

struct ModelFigures {
  std::uint64_t kept = 0, removed = 0;
};

// The model files streamed from rows with their decisions, in any number of parts, on any one thread:
// `kept_path` (binary PCD of the kept points: x y z robot scan beam) and, if not empty, `all_path`
// (every row, plus keep and live_keep). The rows go through a 64 KiB buffer into NAME.rows.tmp;
// finish() writes NAME.tmp (the header, whose point count is known only then, and the rows) and renames
// it into place, so a reader never sees a half file and the model is never held twice in memory.
class ModelFileWriter {
 public:
  ModelFileWriter(std::string kept_path, std::string all_path);
  ~ModelFileWriter();  // an unfinished write leaves no file behind
  ModelFileWriter(const ModelFileWriter&) = delete;
  ModelFileWriter& operator=(const ModelFileWriter&) = delete;

  void add(std::span<const ModelPoint> points, std::span<const std::uint8_t> removed);
  void add(const ModelSnapshot& part) { add(part.points, part.removed); }
  [[nodiscard]] Result<ModelFigures> finish();

 private:
  struct File;
  std::unique_ptr<File> kept_, all_;
  ModelFigures figures_;
};

// The whole model of `core` in parts through a ModelFileWriter, on the caller's thread (one instant).
[[nodiscard]] Result<ModelFigures> write_model_files(const FusionCore& core, const std::string& kept_path,
                                                     const std::string& all_path);

// One model write (every core's files), as it finished.
struct ModelWriteReport {
  bool ok = true;
  Error error{};              // the first file that failed
  bool on_writer_thread = false;
  double snapshot_s = 0;      // the stores copied with their decisions, in the caller's loop (all slices)
  double snapshot_slice_max_s = 0;  // the longest slice: the loop's longest stall for this write
  std::uint32_t snapshot_slices = 0;
  double snapshot_span_s = 0; // first slice to the hand-over to the writer thread
  double write_s = 0;         // formatted and written (the writer thread, or the caller's for write_now())
  std::uint64_t points = 0;   // every core's snapshot
  std::uint64_t kept = 0, removed = 0;  // the first core's model
};

struct ModelWriterOptions {
  // A periodic write's snapshot takes at most this much of one loop turn (request, poll); the rest
  // waits for the next turns. 0: one step (64 model voxels per core) per turn.
  double write_slice_ms = 2.0;
  // The CPUs the writer thread may run on (empty: the process's affinity).
  std::vector<int> writer_cpus;
};

// A core whose model is written, and its files (`all_path` empty: no all-points file).
struct ModelTarget {
  const FusionCore* core = nullptr;
  std::string kept_path, all_path;
};

class ModelWriter {
 public:
  // `on_finished`: every finished write's report, on the thread that calls write_now / request / poll
  // (the loop), never on the writer thread. The cores must outlive the writer.
  ModelWriter(std::vector<ModelTarget> targets, ModelWriterOptions options,
              std::function<void(const ModelWriteReport&)> on_finished);
  ~ModelWriter();  // a write in flight finishes first
  ModelWriter(const ModelWriter&) = delete;
  ModelWriter& operator=(const ModelWriter&) = delete;

  // Every core's model on this thread, after any write in flight (a snapshot in progress is replaced).
  const ModelWriteReport& write_now();
  // Starts a write off the caller's loop; false: one is in flight, this request is coalesced into one
  // that follows it.
  bool request();
  // From the loop: true when a write finished since the last call; starts a coalesced write if free.
  bool poll();
  [[nodiscard]] bool in_flight() const;
  // A periodic write's snapshot is being taken in the loop's turns (it reads the cores).
  [[nodiscard]] bool snapshotting() const { return snapshotting_; }
  // Finishes a snapshot in progress on this thread and waits for the writer thread.
  void wait();
  // The writer thread's scheduling read back from the kernel; `policy` -1 before the first request().
  [[nodiscard]] ThreadScheduling scheduling() const;
  [[nodiscard]] const ModelWriteReport& last() const { return last_; }

 private:
  struct Target : ModelTarget {
    std::size_t snapshot_next = 0, snapshot_end = 0;  // a periodic write: the model voxels still to take
  };
  // A part of a periodic write for the writer thread: one model's rows; `last`: the write ends here
  // (`abandon`: without files: a synchronous write replaces it).
  struct WriterPart {
    std::size_t model = 0;
    ModelSnapshot rows;
    bool last = false;
    bool abandon = false;
  };
  void begin_snapshot();
  bool advance_snapshot(bool all);
  void writer_main();
  void wait_writer_idle();
  // `wait`: block on the writer's mutex (the synchronous write); else only try it (the loop's turn).
  bool collect_finished(bool wait);
  void finish_write();

  std::vector<Target> targets_;
  ModelWriterOptions options_;
  std::function<void(const ModelWriteReport&)> on_finished_;
  ModelWriteReport last_;
  // Guarded by writer_mutex_: the queue, the spare parts (their capacity reused), the flags and
  // writer_report_. snapshot_report_ is the loop's until it queues the write's last part (under the
  // mutex); the writer reads it only after taking it.
  bool write_pending_ = false;  // a request coalesced while one was in flight (loop thread only)
  bool snapshotting_ = false;   // a periodic write's snapshot in progress (loop thread only)
  std::size_t snapshot_model_ = 0;  // the model being taken
  Time snapshot_started_{};
  ModelWriteReport snapshot_report_;
  std::thread writer_;
  std::thread::native_handle_type writer_handle_{};  // writer_'s, for scheduling()
  std::atomic<int> writer_tid_{0};  // the writer's kernel thread id, set by it at start
  std::atomic<int> writer_affinity_error_{0};  // pthread_setaffinity_np of options_.writer_cpus
  mutable std::mutex writer_mutex_;
  std::condition_variable writer_cv_;
  std::deque<WriterPart> writer_queue_;
  std::vector<ModelSnapshot> writer_spare_;
  bool writer_begin_ = false, writer_busy_ = false, writer_done_ = false, writer_stop_ = false;
  ModelWriteReport writer_report_;
};

}  // namespace teamscan::fusion
