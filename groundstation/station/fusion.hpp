// The ground station's fusion stage: the received samples converted into the fusion core's inputs
// (groundstation/fusion/core.hpp, the same core `teamscan eval` runs), the teamscan/map voxel maps fed
// from the core's released scans, the latency histograms, and the fused model written from the core's
// memory. It runs from Station hooks, after the sample is stored: a failure here never loses a
// received sample. After a restart it first replays its session folder through the core
// (session_replay.hpp), so it decides as it did before.
//
// Compared methods (FusionOptions::compare_methods): one more core per method, fed the same samples in
// the same order (live and in the replay), each with its own model store and model file
// (method_file_name); only the primary core feeds teamscan/map, the latency and the counters.
//
// Model writes: request_write() starts taking every core's model store with its decisions in the
// caller's loop, in slices of at most write_slice_ms per request_write()/poll_write() (the only part
// that holds the loop); each slice's rows go through a bounded queue to a writer thread that streams
// them into the files (fusion::ModelFileWriter). One write in flight, a request meanwhile is coalesced
// into one that follows. write_model() is the synchronous write (shutdown, tests).
//
// The writer thread yields to the receive loop: it runs SCHED_IDLE (and nice 19, should the kernel
// refuse SCHED_IDLE), so on a CPU it shares with the loop (the station may be pinned to one) it only
// takes time the loop leaves idle, and a waking loop preempts it at once (a CPU that is never idle
// finishes no periodic write until it is: requests coalesce, the queue stays bounded, the shutdown
// write still completes). It is not pinned away from the loop's CPU: idle time there is its to use,
// while another CPU may be busy with other processes.
// The loop never waits for the writer in its per-turn calls (poll_write, request_write): they only
// try its mutex and come back next turn when the writer holds it (its critical sections are a queue
// operation each, but an idle-class thread can be preempted inside one).
#pragma once

#include <array>
#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <cstdio>
#include <deque>
#include <functional>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "common/clock.hpp"
#include "common/result.hpp"
#include "common/thread_placement.hpp"
#include "groundstation/fusion/core.hpp"
#include "groundstation/mapping/voxel_map.hpp"
#include "groundstation/station/latency_histogram.hpp"
#include "groundstation/station/live_map.hpp"
#include "groundstation/station/scan_record.hpp"
#include "groundstation/station/team_source.hpp"

struct teamscan_msg_MapVoxel;

namespace teamscan::station {

struct FusionOptions {
  // The core: method (mapping::known_methods() / extended_methods()), its options, the tracker, the
  // hold time and the model store's cap (fusion/core.hpp CoreOptions).
  fusion::CoreOptions core;
  // Voxel edge of the teamscan/map updates (metres).
  double map_resolution_m = 0.1;
  // File names inside the session folder. `all_points_pcd` empty: not written.
  std::string kept_pcd = "fused.pcd";
  std::string all_points_pcd;
  // Per-scan latency histograms (scan stamp -> taken from DDS, scan stamp -> decided and in the fused
  // map), written by write_latency(); empty: not written.
  std::string latency_csv = "latency.csv";
  // Per fused scan a line `robot,seq,stamp_ns,received_ns,fused_ns` (CLOCK_REALTIME), through one stdio
  // buffer (no allocation per scan); empty: none. For measuring a time window (the demo's run).
  std::string latency_log_csv;
  // Methods decided side by side with core.method (same options otherwise), each by its own core with
  // its own model store, written as method_file_name(kept_pcd / all_points_pcd, method). Not the
  // primary method, no repeats (create() refuses them).
  std::vector<std::string> compare_methods;
  // A periodic write's snapshot takes at most this much of one loop turn (request_write, poll_write);
  // the rest waits for the next turns. 0: one step (64 model voxels per core) per turn.
  double write_slice_ms = 2.0;
  // The CPUs the model writer thread may run on (empty: the process's affinity). A station whose loop
  // is pinned to one core keeps the writer's file work (page-cache copies, kernel sections that the
  // loop cannot preempt) off that core with this; the snapshot itself stays in the loop.
  std::vector<int> writer_cpus;
};

// A compared method's model file: "fused_all.pcd" + "position" -> "fused_all.position.pcd" (the
// method before the extension; no extension: appended).
[[nodiscard]] std::string method_file_name(const std::string& name, const std::string& method);
// The options a compared method's core runs with, and its files: `o` with core.method = method, the
// model files named by method_file_name and no compared methods of its own (what model_check and the
// demo read its model with). `method` == o.core.method: `o` without compare_methods.
[[nodiscard]] FusionOptions compared_options(const FusionOptions& o, const std::string& method);

// A received pose / scan as the core's input (one conversion, used live and by the session replay).
[[nodiscard]] fusion::PoseInput pose_input(const PoseObservation& pose);
// Fills `points`/`flags`/`beams` with the scan's placed points (beams without a 3-D point are stored in
// scans.bin but are not part of the model) and returns the input viewing them.
struct ScanBuffers {
  std::vector<mapping::MapPoint> points;
  std::vector<std::uint16_t> flags, beams;
};
[[nodiscard]] fusion::ScanInput scan_input(const StoredScan& scan, ScanBuffers& buffers);

struct FusionCounters {
  std::uint64_t scans = 0;            // scans fused (released by the core)
  std::uint64_t poses = 0;
  std::uint64_t points = 0;
  std::uint64_t live_removed = 0;     // points removed at release (the map so far)
  std::uint64_t duplicates = 0;       // scans received again (DDS history replay): stored, not fused twice
  std::uint64_t replayed_scans = 0;   // scans of the session folder replayed at start-up
  std::uint64_t writes = 0;           // model writes done (every core's files written)
  std::uint64_t write_failures = 0;   // writes with a file not written (the first error: last_write())
  std::uint64_t writes_coalesced = 0; // request_write() while a write was in flight (served by one write after it)
  std::uint64_t last_write_kept = 0;  // points in the last fused PCD
  std::uint64_t last_write_removed = 0;
};

// One model write (every core's files), as it finished.
struct ModelWriteReport {
  bool ok = true;
  Error error{};              // the first file that failed
  bool on_writer_thread = false;
  double snapshot_s = 0;      // the stores copied with their decisions, in the caller's loop (all slices)
  double snapshot_slice_max_s = 0;  // the longest slice: the loop's longest stall for this write
  std::uint32_t snapshot_slices = 0;
  double snapshot_span_s = 0; // first slice to the hand-over to the writer thread
  double write_s = 0;         // formatted and written (the writer thread, or the caller's for write_model())
  std::uint64_t points = 0;   // every core's snapshot
  std::uint64_t kept = 0, removed = 0;  // the primary model's
};

struct FusionConfig;
struct KalmanConfig;
struct RegistrationConfig;
// The daemon's [fusion], [team.kalman] and [registration] config as FusionOptions (the tracker is the
// team source's; without `registration`: its defaults).
[[nodiscard]] FusionOptions fusion_options_from_config(const FusionConfig& fusion, const KalmanConfig& kalman);
[[nodiscard]] FusionOptions fusion_options_from_config(const FusionConfig& fusion, const KalmanConfig& kalman,
                                                       const RegistrationConfig& registration);

class FusionStage {
 public:
  // Fails if the core's options are bad (unknown method, ...).
  [[nodiscard]] static Result<std::unique_ptr<FusionStage>> create(const FusionOptions& options,
                                                                   std::string session_dir);

  // Hooks (Station::add_pose_hook / add_scan_hook). A scan whose (robot, seq) was fused recently is a
  // replay of the robots' DDS history: counted in `duplicates`, not fused again.
  void add_pose(const PoseObservation& pose);
  void add_scan(const StoredScan& scan);
  // Rebuilds the core from the session folder's scans.bin and poses.csv (a restart): every sample in
  // arrival order through the same code, before the loop takes new ones. Returns the samples replayed.
  [[nodiscard]] Result<std::uint64_t> replay_session(const std::string& dir);
  // Releases every scan the cores hold (shutdown).
  void flush();
  // The loop's clock (CLOCK_REALTIME, the receive times' clock): held scans that waited long enough go.
  void tick(std::int64_t realtime_ns);

  // Writes every core's model from memory into the session folder (fused.pcd, and fused_all.pcd when
  // configured; the compared methods' files), on this thread, after any write in flight: NAME.tmp then
  // rename(2), so a reader never sees a half file. The shutdown write; last_write() has its report.
  [[nodiscard]] Status write_model();
  // The same write off the caller's loop: the snapshot here, the files on the writer thread. While a
  // write is in flight the request is counted (writes_coalesced) and one write follows it.
  void request_write();
  // From the loop: true when a write finished since the last call (its report: last_write(), and the
  // write callback); starts a coalesced write if the writer is free.
  bool poll_write();
  [[nodiscard]] bool write_in_flight() const;
  // The writer thread's scheduling read back from the kernel (pthread_getschedparam, getpriority on its
  // thread id); `policy` -1 before the first request_write() started it.
  [[nodiscard]] ThreadScheduling writer_scheduling() const;
  // Finishes a snapshot in progress on this thread and waits for the writer; the report comes with
  // the next poll_write().
  void wait_for_write();
  [[nodiscard]] const ModelWriteReport& last_write() const { return last_write_; }
  // Called with every finished write's report, on the thread that calls write_model / request_write /
  // poll_write (the loop), never on the writer thread.
  void set_write_callback(std::function<void(const ModelWriteReport&)> f) { on_write_ = std::move(f); }
  // Writes the latency histograms (options().latency_csv) into the session folder, atomically.
  [[nodiscard]] Status write_latency() const;
  // Scan stamp (end of sweep, CLOCK_REALTIME) -> the scan decided by the core and in the live map, and
  // scan stamp -> taken from DDS (the station stores it right then, before fusion), one sample per scan.
  [[nodiscard]] const LatencyHistogram& fused_latency() const { return fused_latency_; }
  [[nodiscard]] const LatencyHistogram& stored_latency() const { return stored_latency_; }

  // The occupied voxels of the live map as teamscan/map voxels (flags 1: every point in the voxel
  // was removed at release).
  void map_voxels(std::vector<teamscan_msg_MapVoxel>& out) const { map_.voxels(out); }
  // Only the voxels that changed (new points) since the last call or clear_map_changes(), with their
  // whole counts and flags (a viewer replaces its voxel), then forgets them.
  void map_voxels_changed(std::vector<teamscan_msg_MapVoxel>& out) { map_.changed_voxels(out); }
  void clear_map_changes() { map_.forget_changes(); }
  [[nodiscard]] std::uint32_t map_total_voxels() const { return static_cast<std::uint32_t>(map_.occupied_voxels()); }
  [[nodiscard]] const LiveMap& live_map() const { return map_; }
  [[nodiscard]] std::uint32_t map_resolution_mm() const;

  [[nodiscard]] const fusion::FusionCore& core() const { return *models_.front()->core; }
  [[nodiscard]] fusion::FusionCore& core() { return *models_.front()->core; }
  // A compared method's core (compare_methods), or nullptr.
  [[nodiscard]] const fusion::FusionCore* compared_core(const std::string& method) const;
  // Every core's model store (the primary's and the compared methods'), bytes.
  [[nodiscard]] std::size_t model_memory_bytes() const;
  // Every core's filter map state (voxel counts, free-space grids), bytes.
  [[nodiscard]] std::size_t filter_memory_bytes() const;
  [[nodiscard]] const FusionCounters& counters() const { return counters_; }
  [[nodiscard]] const FusionOptions& options() const { return options_; }

  ~FusionStage();
  FusionStage(const FusionStage&) = delete;
  FusionStage& operator=(const FusionStage&) = delete;

 private:
  // A core and its model files; models_[0] is the primary method's.
  struct Model {
    std::unique_ptr<fusion::FusionCore> core;
    std::string kept_path, all_path;
    std::size_t snapshot_next = 0, snapshot_end = 0;  // a periodic write: the model voxels still to take
  };
  // A part of a periodic write for the writer thread: one model's rows; `last`: the write ends here
  // (`abandon`: without files: a synchronous write replaces it).
  struct WriterPart {
    std::size_t model = 0;
    fusion::ModelSnapshot rows;
    bool last = false;
    bool abandon = false;
  };
  FusionStage(const FusionOptions& options, std::string session_dir, std::vector<std::unique_ptr<Model>> models);
  void on_release(const fusion::FusedScan& scan);
  void add_scan_to_cores(const fusion::ScanInput& in);
  void begin_snapshot();
  bool advance_snapshot(bool all);
  void writer_main();
  void wait_writer_idle();
  // `wait`: block on the writer's mutex (the synchronous write); else only try it (the loop's turn).
  bool collect_finished(bool wait);
  void finish_write();

  FusionOptions options_;
  std::string session_dir_;
  std::vector<std::unique_ptr<Model>> models_;
  LiveMap map_;
  ScanBuffers scratch_;
  LatencyHistogram fused_latency_;
  LatencyHistogram stored_latency_;
  FusionCounters counters_;
  std::FILE* latency_log_ = nullptr;
  bool replaying_ = false;  // replay_session(): no latency samples (they are not this run's)
  bool resume_ = false;     // the first live sample after a replay resumes the core's arrival clock
  // The writer thread (started by the first request_write()). Guarded by writer_mutex_: the queue, the
  // spare parts (their capacity reused), the flags and writer_report_. snapshot_report_ is the loop's
  // until it queues the write's last part (under the mutex); the writer reads it only after taking it.
  ModelWriteReport last_write_;
  std::function<void(const ModelWriteReport&)> on_write_;
  bool write_pending_ = false;  // a request coalesced while one was in flight (loop thread only)
  bool snapshotting_ = false;   // a periodic write's snapshot in progress (loop thread only)
  std::size_t snapshot_model_ = 0;  // the model being taken
  Time snapshot_started_{};
  ModelWriteReport snapshot_report_;
  std::thread writer_;
  std::thread::native_handle_type writer_handle_{};  // writer_'s, for writer_scheduling()
  std::atomic<int> writer_tid_{0};  // the writer's kernel thread id, set by it at start
  std::atomic<int> writer_affinity_error_{0};  // pthread_setaffinity_np of options_.writer_cpus
  mutable std::mutex writer_mutex_;
  std::condition_variable writer_cv_;
  std::deque<WriterPart> writer_queue_;
  std::vector<fusion::ModelSnapshot> writer_spare_;
  bool writer_begin_ = false, writer_busy_ = false, writer_done_ = false, writer_stop_ = false;
  ModelWriteReport writer_report_;
};

// Hands each robot's correction, as the fusion core applies it at a time (PoseHistory::correction_at:
// the newest its registration set at or before that time, an accepted match's or the drift rates'
// extrapolation between matches, with its σ), to the team source whenever it changed, so teamscan/team
// carries the corrected poses and the correction itself (docs/registration.md "Back on the robots").
// A change that follows an accepted match registers the team source's track (`measurement`); the
// extrapolation is a change of frame. Call with the time before every team publication (the loop: also
// after held scans were released by the clock), after every sample the core took, and after a session
// replay.
class CorrectionShare {
 public:
  void share(const fusion::FusionCore& core, TeamSource& team, Time at);

 private:
  struct Shared {
    std::int64_t from_stamp_ns = 0;
    Pose2 map_from_odom;
    std::uint64_t accepted = 0;  // the registration's accepted matches when it was handed over
    bool any = false;
  };
  std::array<Shared, kMaxRobots + 1> shared_{};  // per robot id: the correction last handed over
};

}  // namespace teamscan::station
