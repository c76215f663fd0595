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
// Model writes (fusion::ModelWriter, groundstation/fusion/model_writer.hpp): request_write() starts
// taking every core's model store with its decisions in the caller's loop, in slices of at most
// write_slice_ms per request_write()/poll_write() (the only part that holds the loop); the files are
// written on an idle-class writer thread. One write in flight, a request meanwhile is coalesced into
// one that follows. write_model() is the synchronous write (shutdown, tests).
#pragma once

#include <array>
#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <cstdio>
#include <deque>
#include <functional>
#include <future>
#include <memory>
#include <mutex>
#include <optional>
#include <set>
#include <string>
#include <system_error>
#include <thread>
#include <utility>
#include <vector>

#include "common/clock.hpp"
#include "common/dataset/dataset.hpp"
#include "common/result.hpp"
#include "common/thread_placement.hpp"
#include "common/time.hpp"
#include "groundstation/fusion/core.hpp"
#include "groundstation/fusion/core_rebuild.hpp"
#include "groundstation/fusion/core_set.hpp"
#include "groundstation/fusion/graph_backend.hpp"
#include "groundstation/fusion/model_move.hpp"
#include "groundstation/fusion/model_writer.hpp"
#include "groundstation/mapping/voxel_map.hpp"
#include "groundstation/station/latency_histogram.hpp"
#include "groundstation/station/live_map.hpp"
#include "groundstation/station/scan_record.hpp"
#include "groundstation/station/session_replay.hpp"
#include "groundstation/station/team_source.hpp"
#include "groundstation/trajectory/tum.hpp"

struct teamscan_msg_MapVoxel;

namespace teamscan::station {

// The stage's options, read from the daemon's [fusion], [team.kalman] and [registration] (config.hpp).
struct FusionOptions {
  // The daemon runs the stage (fusion.enabled), writes the model every write_interval (0: only on
  // shutdown) and publishes teamscan/map every map_interval (0: off).
  bool enabled = true;
  Duration write_interval = std::chrono::seconds(10);
  Duration map_interval = std::chrono::seconds(1);
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
  // The catch-up (catch_up()): due once this many scans were released late or poses came late
  // (fusion::CoreCounters scans_late + poses_late: a robot's back-fill after a radio shadow) since the last one and none for catch_up_quiet_s of the loop's
  // clock (the back-fill is over). 0 scans: never in the loop; flush() catches up whenever one is due.
  std::uint32_t catch_up_min_scans = 75;
  double catch_up_quiet_s = 2.0;
  // The catch-up in the loop is done in slices: the session folder is read and fed to the rebuilt cores
  // off the loop (a loader thread on writer_cpus, below the loop), then each loop turn feeds them at
  // most this many of the live scans queued meanwhile while the live cores go on taking, fusing and
  // showing the robots' scans; the rebuilt cores take over once they caught up with the live ones.
  // 0: the whole catch-up in the turn it is due, holding the loop (catch_up()), and the live map does
  // not follow the pose graph (only the final model does).
  std::uint32_t catch_up_slice_scans = 16;
  // The pose graph as the primary core's back end (fusion/graph_backend.hpp; [pose_graph]): fed every
  // scan the core releases, on its own thread; its trajectory is written at the end
  // (write_graph_trajectories). With its estimate_every_s (5 s; [pose_graph] follow_s, 0: only the final
  // model follows), the live map follows it: each new estimate moves the model onto the graph's poses, or
  // rebuilds the cores on them (follow_rigidly below; tick()). On by default ([pose_graph] enabled =
  // false: none, odometry alone or the registration's corrections).
  std::optional<fusion::GraphBackendOptions> pose_graph = [] {
    fusion::GraphBackendOptions o;
    o.estimate_every_s = 5.0;  // the live map follows it ([pose_graph] follow_s)
    return o;
  }();
  // How the live map follows the graph's estimates (pose_graph's estimate_every_s > 0). Rigidly (true,
  // unless an exact follow is due, below): every core's model store is moved scan by scan onto the
  // estimate's poses, write_slice_ms of a loop turn at a time, and the live map built again from the
  // primary's (fusion/model_move.hpp); the robots are handed their corrections from the estimate on; the
  // filters' evidence and the decisions at release stay as they were made; the cost is one pass over the
  // model, bounded by the mapped space. With the registration on, its corrections place the scans live,
  // and without a model store (core.max_points_per_voxel 0) there is no model to move: then only the final
  // model follows the graph. Exactly (false, every time): the whole session decided again on the
  // estimate's poses, as a catch-up, the registration off from then on (the cost growing with the time
  // mapped).
  bool follow_rigidly = true;
  // An estimate worth a rigid follow is followed exactly instead (the evidence, every decision and the
  // model on its poses) when that is expected to take at most exact_follow_max_s (the last exact follow's
  // time, scaled by the session's growth since; the first is tried, a restart's replay counts as one) and
  // the last one took at most exact_follow_share of the time from its start to now. Its cost grows with
  // the time mapped (the stop's final pass needs the same memory), so a growing session is followed
  // exactly less and less often, then only rigidly; while one runs no estimate is followed rigidly.
  // Either 0: rigid follows only.
  double exact_follow_share = 0.25;
  double exact_follow_max_s = 10.0;
  // A rigid follow moves the model only when some scan's returns would shift by more than this (its
  // position's shift plus its turn times the laser's 8 m reach): an estimate that moves nothing as far
  // is taken as it is (the model stays, the next one is compared with where the scans are).
  double follow_min_shift_m = 0.02;
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
// The scan's placed points (beams without a 3-D point are stored in scans.bin but are not part of the
// model) in metres with the data set's flags, arriving at the receipt's time, into `out` (its vectors
// reused); returns `out`. The robot id is the one the sample validation accepted (a replayed session's:
// replay_session_files).
const fusion::ScanInput& scan_input(const ScanPoints& scan, const Receipt& receipt, fusion::ScanInput& out);

struct FusionCounters {
  std::uint64_t scans = 0;            // scans fused (released by the core)
  std::uint64_t poses = 0;
  std::uint64_t points = 0;
  std::uint64_t live_removed = 0;     // points removed at release (the map so far)
  std::uint64_t duplicates = 0;       // scans received again (DDS history replay): stored, not fused twice
  std::uint64_t replayed_scans = 0;   // scans of the session folder replayed at start-up
  std::uint64_t catch_ups = 0;        // cores rebuilt in time order from the session folder after late inputs (catch_up)
  std::uint64_t caught_up_scans = 0;  // scans the last catch-up fed
  double last_catch_up_s = 0.0;       // the last catch-up, from due to done (CLOCK_MONOTONIC): in slices, the span
  std::uint64_t catch_up_turns = 0;   // the last catch-up's loop turns that fed the rebuilt cores (0: in one turn)
  double catch_up_slice_max_s = 0.0;  // ... its longest share of one loop turn (a slice, the start or the take-over)
  std::uint64_t caught_up_live_scans = 0;  // ... live scans fed to the rebuilt cores behind the session
  std::uint64_t catch_up_failures = 0;  // the session folder could not be read back (the cores as they were)
  std::uint64_t graph_follows = 0;    // the live cores taken over by cores rebuilt on a graph estimate (tick())
  std::uint64_t followed_nodes = 0;   // ... the last one's graph nodes and loop closures
  std::uint64_t followed_closures = 0;
  bool last_rebuild_followed_graph = false;  // the last rebuild (the catch-up counters) was a follow
  std::uint64_t rigid_follows = 0;    // of graph_follows: the model moved rigidly onto the estimate
  bool last_follow_rigid = false;     // the last follow moved the model (not a rebuild)
  std::uint64_t follow_moved_points = 0;  // ... the last one: the model points it moved
  std::uint64_t follow_scans = 0;     // ... the scans with a move of their own (those of the estimates)
  double last_follow_s = 0.0;         // ... from the estimate taken to the moved map in place
  std::uint64_t follow_turns = 0;     // ... the loop turns it moved the model in
  double follow_slice_max_s = 0.0;    // ... its longest share of one loop turn
  std::uint64_t follow_failures = 0;  // a rigid follow's moves could not be made (not retried on that estimate)
  std::uint64_t follows_skipped = 0;  // estimates that would have moved no scan by follow_min_shift_m
  double last_follow_shift_m = 0.0;   // the last follow's (or skipped estimate's) largest shift
  std::uint64_t graph_rebuilds = 0;   // the cores rebuilt on the pose graph's poses (rebuild_on_graph)
  double last_graph_rebuild_s = 0.0;  // ... the last one, the session read to the take-over
  std::uint64_t writes = 0;           // model writes done (every core's files written)
  std::uint64_t write_failures = 0;   // writes with a file not written (the first error: last_write())
  std::uint64_t writes_coalesced = 0; // request_write() while a write was in flight (served by one write after it)
  std::uint64_t last_write_kept = 0;  // points in the last fused PCD
  std::uint64_t last_write_removed = 0;
};

using ModelWriteReport = fusion::ModelWriteReport;

class FusionStage {
 public:
  // Fails if the core's options are bad (unknown method, ...).
  [[nodiscard]] static Result<std::unique_ptr<FusionStage>> create(const FusionOptions& options,
                                                                   std::string session_dir);

  // Hooks (Station::add_pose_hook / add_scan_hook). A scan whose (robot, seq) was fused recently is a
  // replay of the robots' DDS history: counted in `duplicates`, not fused again.
  void add_pose(const PoseObservation& pose);
  void add_scan(const ScanPoints& scan, const Receipt& receipt);
  // Rebuilds the core from the session folder's scans.bin and poses.csv (a restart): every sample in
  // arrival order through the same code, before the loop takes new ones. Returns the samples replayed.
  // `progressing` (optional) is called every few hundred samples (a long session takes a while).
  [[nodiscard]] Result<std::uint64_t> replay_session(const std::string& dir, const std::function<void()>& progressing = {});
  // The catch-up: every core reset and fed the session folder in the time order `teamscan eval SESSION`
  // feeds it (fusion/time_line.hpp), the newest scans left held, the live map rebuilt from the primary's
  // model; the live samples go on from there (the arrival clock resumes at `realtime_ns`). A back-fill
  // arrives after the core released its teammates' scans of that time, so its scans were released late,
  // out of stamp order, with the team state there was: after a catch-up every decision, the model store's
  // choice of points per voxel and the decisions at release are those of `teamscan eval` of the session
  // so far. Holds the loop for a replay of the whole session (counters().last_catch_up_s); a catch-up in
  // slices under way is dropped first. The loop's catch-up (tick()) is the same in slices.
  // `progress` (optional): the share of the session fed so far, about every 1 %.
  [[nodiscard]] Status catch_up(std::int64_t realtime_ns, const std::function<void(double)>& progress = {});
  // A catch-up in slices is under way (the session being read, or the rebuilt cores being fed).
  [[nodiscard]] bool catching_up() const { return run_ != nullptr; }
  // ... and its rebuilt cores are being fed: the loop should turn again without waiting for data.
  [[nodiscard]] bool catch_up_has_work() const;
  // The catch-up under way: scans of the session fed of those to feed, live inputs queued behind them.
  [[nodiscard]] fusion::RebuildProgress catch_up_progress() const;
  // Called after every catch-up and every follow of the graph with the counters (caught_up_scans,
  // last_catch_up_s, last_rebuild_followed_graph), on its thread.
  void set_catch_up_callback(std::function<void(const FusionCounters&)> f) { on_catch_up_ = std::move(f); }
  // Scans released late and poses taken late (CoreCounters::scans_late + poses_late) since the last
  // catch-up (the primary core's count).
  [[nodiscard]] std::uint64_t late_since_catch_up() const;
  // Releases every scan the cores hold (shutdown), after a catch-up if any scan was released late in
  // this run (since the start or its session replay): the final model is then the one of
  // `teamscan eval`'s time order on the session, byte for byte. Without: the arrival order's (equal to it
  // when no scan was released late). `progress` as catch_up()'s.
  void flush(const std::function<void(double)>& progress = {});
  // The loop's clock (CLOCK_REALTIME, the receive times' clock): held scans that waited long enough go;
  // a catch-up once one is due (FusionOptions::catch_up_min_scans, catch_up_quiet_s), in slices of
  // catch_up_slice_scans, one per call, until the rebuilt cores take over. With the pose graph, once it
  // published an estimate the cores do not follow yet, the same rebuild on the estimate's poses (every
  // core without the registration, each scan the estimate holds placed at its pose, a later one by its
  // robot's last correction; the graph keeps its state and is fed on): the live map, the decisions and
  // the team state follow the graph. A catch-up rebuilds on the newest estimate too.
  void tick(std::int64_t realtime_ns);

  // Writes every core's model from memory into the session folder (fused.pcd, and fused_all.pcd when
  // configured; the compared methods' files), on this thread, after any write in flight: NAME.tmp then
  // rename(2), so a reader never sees a half file. The shutdown write; last_write() has its report.
  [[nodiscard]] Status write_model();
  // The same write off the caller's loop: the snapshot here, the files on the writer thread. While a
  // write is in flight the request is counted (writes_coalesced) and one write follows it.
  void request_write() {
    if (!writer_->request()) ++counters_.writes_coalesced;
  }
  // From the loop: true when a write finished since the last call (its report: last_write(), and the
  // write callback); starts a coalesced write if the writer is free.
  bool poll_write() { return writer_->poll(); }
  [[nodiscard]] bool write_in_flight() const { return writer_->in_flight(); }
  // The writer thread's scheduling read back from the kernel (pthread_getschedparam, getpriority on its
  // thread id); `policy` -1 before the first request_write() started it.
  [[nodiscard]] ThreadScheduling writer_scheduling() const { return writer_->scheduling(); }
  // Finishes a snapshot in progress on this thread and waits for the writer; the report comes with
  // the next poll_write().
  void wait_for_write() { writer_->wait(); }
  [[nodiscard]] const ModelWriteReport& last_write() const { return writer_->last(); }
  // Called with every finished write's report, on the thread that calls write_model / request_write /
  // poll_write (the loop), never on the writer thread.
  void set_write_callback(std::function<void(const ModelWriteReport&)> f) { on_write_ = std::move(f); }
  // With options().pose_graph, after flush(): the graph's last search and optimisation over every scan
  // the core released (waits for the back end's thread), then `robot<N>.graph.tum` per robot in the
  // session folder (one line per scan, its stamp, the graph's pose; docs/slam.md "The back end").
  [[nodiscard]] Status write_graph_trajectories();
  // With options().pose_graph, after write_graph_trajectories(): every core reset and fed the session
  // folder in time order on the graph's poses (fusion/graph_map.hpp), so the model, its decisions and
  // the live map follow the graph: the model `teamscan eval SESSION --pose-graph` decides. The cores then
  // run without the registration (the graph placed the scans): the shutdown's last step before the final
  // write. An error (the session folder unreadable, or not this station's) leaves the cores as they were.
  // `progress` (optional): the share of the session fed so far, about every 1 %.
  [[nodiscard]] Status rebuild_on_graph(const std::function<void(double)>& progress = {});
  // The back end (nullptr without options().pose_graph); after a catch-up, the one fed its releases.
  [[nodiscard]] fusion::GraphBackend* graph() { return graph_.get(); }
  // The graph's estimate the cores were last rebuilt on (tick()), nullptr before the first.
  [[nodiscard]] const std::shared_ptr<const fusion::GraphEstimate>& followed_estimate() const { return followed_; }
  // Writes the latency histograms (options().latency_csv) into the session folder, atomically.
  [[nodiscard]] Status write_latency() const;
  // Scan stamp (end of sweep, CLOCK_REALTIME) -> the scan decided by the core and in the live map, and
  // scan stamp -> taken from DDS (the station stores it right then, before fusion), one sample per scan.
  [[nodiscard]] const LatencyHistogram& fused_latency() const { return fused_latency_; }
  [[nodiscard]] const LatencyHistogram& stored_latency() const { return stored_latency_; }

  // The occupied voxels of the live map (the primary core's model store binned at map_resolution_m,
  // corrected positions) as teamscan/map voxels (flags 1: every point in the voxel was removed at
  // release); `robots`, if given, the robot of each. map_release(): the core's instant they show.
  void map_voxels(std::vector<teamscan_msg_MapVoxel>& out, std::vector<std::uint8_t>* robots = nullptr) const {
    map_.voxels(out, robots);
  }
  // Only the voxels that changed (new points) since the last call or clear_map_changes(), with their
  // whole counts and flags (a viewer replaces its voxel), then forgets them.
  void map_voxels_changed(std::vector<teamscan_msg_MapVoxel>& out, std::vector<std::uint8_t>* robots = nullptr) {
    map_.changed_voxels(out, robots);
  }
  [[nodiscard]] std::uint64_t map_release() const { return map_.release(); }
  // True once after the live map was built again (a catch-up, a follow of the graph): voxels may have
  // gone, so the next publication is the whole map.
  [[nodiscard]] bool take_map_replaced() { return std::exchange(map_replaced_, false); }
  // A rigid follow of the graph under way (FusionOptions::follow_rigidly).
  [[nodiscard]] bool following() const { return follow_ != nullptr; }
  void clear_map_changes() { map_.forget_changes(); }
  [[nodiscard]] std::uint32_t map_total_voxels() const { return static_cast<std::uint32_t>(map_.occupied_voxels()); }
  [[nodiscard]] const LiveMap& live_map() const { return map_; }
  [[nodiscard]] std::uint32_t map_resolution_mm() const;

  [[nodiscard]] const fusion::FusionCore& core() const { return cores_->primary(); }
  [[nodiscard]] fusion::FusionCore& core() { return cores_->primary(); }
  // A compared method's core (compare_methods), or nullptr.
  [[nodiscard]] const fusion::FusionCore* compared_core(const std::string& method) const { return cores_->compared(method); }
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
  FusionStage(const FusionOptions& options, std::string session_dir, std::unique_ptr<fusion::CoreSet> cores);
  void on_release(const fusion::FusedScan& scan);
  void add_scan_to_cores(const fusion::ScanInput& in);
  void finish_write(const ModelWriteReport& report);
  struct CatchUpRun;
  // `follow`: a rebuild on the graph's newest estimate that keeps the graph (else a catch-up, which
  // starts a new graph fed the rebuilt primary's releases in time order).
  void start_catch_up(std::int64_t realtime_ns, bool follow = false);
  void continue_catch_up();
  void finish_catch_up();
  void drop_catch_up();
  struct RigidFollow;  // fusion_follow.cpp
  // The rigid follow of an estimate: its moves made off the loop, then the cores' corrections set and
  // their models moved a slice per turn (all of it with `to_the_end`), then the moved map in place.
  void start_rigid_follow(std::shared_ptr<const fusion::GraphEstimate> estimate);
  // `realtime_ns`: the loop's clock, for an exact follow started in its place (exact_follow_due).
  void continue_rigid_follow(bool to_the_end, std::int64_t realtime_ns = 0);
  void finish_rigid_follow();
  void on_released_while_following(const fusion::FusedScan& scan);
  // An estimate worth following is followed exactly now (FusionOptions::exact_follow_max_s, exact_follow_share).
  [[nodiscard]] bool exact_follow_due() const;
  // A finished catch-up's leftovers (the live cores' and live map's old states, the session read): freed
  // on a thread of their own on writer_cpus, so no loop turn waits for them to be given back.
  template <class Leftovers>
  void free_off_loop(std::unique_ptr<Leftovers> leftovers);
  // The session folder read back for a rebuild (a catch-up in slices under way dropped first), its rows
  // and where to read each scan's points as it is fed; an error if it cannot be read or holds fewer
  // scans than the cores took (not this station's folder).
  [[nodiscard]] Result<SessionIndex> read_own_session();
  void on_rebuilt_release(const fusion::FusedScan& scan);
  // Its part that only touches the catch-up's own state: the rebuilt map, its counters, its new graph
  // (the session's releases, on the loader thread: start_catch_up).
  static void add_rebuilt_release(CatchUpRun& run, const fusion::FusedScan& scan);
  void record_fused(std::uint8_t robot, std::uint32_t scan, std::int64_t stamp_ns, std::int64_t arrival_ns,
                    const Pose2& map_from_robot);

  FusionOptions options_;
  std::string session_dir_;
  std::unique_ptr<trajectory::TumAppender> trajectories_;  // robot<N>.tum in the session folder (docs/slam.md)
  std::unique_ptr<fusion::CoreSet> cores_;  // the primary core and the compared methods' (fusion/core_set.hpp)
  LiveMap map_;
  fusion::ScanInput scratch_;
  LatencyHistogram fused_latency_;
  LatencyHistogram stored_latency_;
  FusionCounters counters_;
  std::FILE* latency_log_ = nullptr;
  bool replaying_ = false;  // replay_session(): no latency samples (they are not this run's)
  bool resume_ = false;     // the first live sample after a replay resumes the core's arrival clock
  bool catching_up_ = false;  // catch_up(): released scans are counted as the cores' again, not as live
  std::uint64_t late_base_ = 0;  // the primary's scans_late + poses_late after the last catch-up
  std::uint64_t late_seen_ = 0;  // ... at the last tick, and when it last grew
  std::int64_t late_at_ns_ = 0;
  std::unique_ptr<CatchUpRun> run_;  // the catch-up in slices under way (catch_up_run.hpp)
  std::future<void> freeing_;        // the last catch-up's leftovers being freed (free_off_loop)
  // The primary core's back end: fed its releases (the session replay's too); a catch-up feeds a new
  // one the rebuilt primary's releases, which takes over with the cores.
  std::unique_ptr<fusion::GraphBackend> graph_;
  std::uint64_t followed_version_ = 0;  // graph_'s estimate the cores were rebuilt on (0: none)
  std::shared_ptr<const fusion::GraphEstimate> followed_;
  fusion::ScanPlacement placement_;        // where the live cores' released scans sit (rigid follows)
  std::unique_ptr<RigidFollow> follow_;   // the rigid follow under way
  // The last exact follow of an estimate (a rebuild on its poses): when it began, how long it took, and
  // the session's scans it decided again.
  struct ExactFollow {
    Time started;
    Duration took{};
    std::uint64_t scans = 0;
  };
  std::optional<ExactFollow> exact_follow_;
  bool map_replaced_ = false;
  // Scans the live cores released during the last catch-up that the rebuilt ones still held when they
  // took over: released again later, shown but not counted twice (latency, trajectory).
  std::set<std::pair<std::uint8_t, std::uint32_t>> released_before_;
  std::function<void(const ModelWriteReport&)> on_write_;
  std::function<void(const FusionCounters&)> on_catch_up_;
  std::unique_ptr<fusion::ModelWriter> writer_;  // after cores_: destroyed (its thread joined) first
};

// Frees a rebuild's or a follow's leftovers (old cores' states, old live maps, a session read) on a
// thread of its own on writer_cpus, so no loop turn waits for their memory to be given back.
template <class Leftovers>
void FusionStage::free_off_loop(std::unique_ptr<Leftovers> leftovers) {
  if (freeing_.valid()) freeing_.wait();  // the one before (catch-ups and follows are seconds apart: long done)
  try {
    freeing_ = std::async(std::launch::async, [leftovers = std::move(leftovers), cpus = options_.writer_cpus]() mutable {
      (void)set_current_thread_cpus(cpus);  // with the model writer, off the loop's CPUs (none: unchanged)
      set_current_thread_below_loop();
      leftovers.reset();
    });
  } catch (const std::system_error&) {
    // No thread: the leftovers, still in the callable std::async was given, are freed here.
  }
}

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
