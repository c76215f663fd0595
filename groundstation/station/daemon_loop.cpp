// teamscan-groundstation's run loop and orderly stop (daemon_loop.hpp).
#include "groundstation/station/daemon_loop.hpp"

#include <algorithm>
#include <chrono>
#include <csignal>
#include <cstdint>
#include <cstdio>
#include <functional>
#include <string>

#include "common/clock.hpp"
#include "dds/notify.hpp"
#include "groundstation/station/daemon_log.hpp"
#include "groundstation/station/timeout_progress.hpp"

namespace teamscan::station::daemon {

namespace {

// The last map every output gets: the loop's last publication, or (`again`, once the station stopped
// hearing the robots) the live map as it stands now, the whole of it: the final model on the pose graph's
// poses (the same release, the same scans, placed by the graph), on teamscan/map, ROS 2 map_cloud and the
// view alike. Logged, then flushed to each output's readers before they stop.
void publish_final_map(Daemon& d, bool again) {
  if (!d.fusion) return;
  FusionStage& fusion = *d.fusion;
  if (again) {
    fusion.map_voxels(d.map_voxels, &d.map_robots);
    fusion.clear_map_changes();
    const std::uint32_t total = fusion.map_total_voxels();
    if (!d.map_voxels.empty() && !d.station->publish_map(d.map_voxels, fusion.map_resolution_mm(), total).ok())
      log(kWarning, "fusion: teamscan/map write failed");
    if (d.ros2 && !d.map_voxels.empty()) d.ros2->offer_map(d.map_voxels, total);
    if (d.view_feeder) d.view_feeder->offer_map(d.map_voxels, d.map_robots, true, total, fusion.map_release());
  }
  d.store->log_event(now_realtime(), "live map: last published at release " + std::to_string(fusion.map_release()) + " (" +
                                         std::to_string(fusion.map_total_voxels()) + " voxels); the core released " +
                                         std::to_string(fusion.core().counters().scans_released) + " scans" +
                                         (!again ? "" : fusion.counters().graph_rebuilds > 0 ? " (the final model on the pose graph's poses)"
                                                                                              : " (the live map at the stop)"));
  constexpr Duration kFlushTimeout = std::chrono::seconds(2);
  if (!d.station->map_acknowledged_within(kFlushTimeout)) log(kWarning, "teamscan/map: the last map was not acknowledged by every reader in 2 s");
  if (d.ros2 && !d.ros2->flush(kFlushTimeout)) log(kWarning, "ros2: the last map cloud was not acknowledged by every reader in 2 s");
  if (d.view_server && !d.view_server->flush(kFlushTimeout)) log(kWarning, "view: the last map did not reach every page in 2 s");
}

volatile std::sig_atomic_t g_stop = 0;
void on_stop_signal(int) { g_stop = 1; }

// The loop's clocks and counters. Loop-time counters (STYLE.md 8): the longest handling of one poll's
// samples, and the teamscan/map publications, which run in this loop too and hold the next take back
// (docs/demo.md "Scale").
class RunLoop {
 public:
  RunLoop(const GroundStationConfig& cfg, Daemon& d, Duration ping_period)
      : cfg_{cfg}, d_{d}, st_{*d.station}, ping_period_{ping_period} {}

  // The turn after a stop signal is the last: every held scan released and the map published once
  // more, so the final map reaches teamscan/map and the view at the release the model is written at.
  void run() {
    while (!last_turn_) {
      last_turn_ = g_stop != 0;
      tick();
    }
  }
  void log_figures() const;

 private:
  void tick();
  void write_model_if_due();
  void publish_map_if_due();
  void report_status_if_due();

  const GroundStationConfig& cfg_;
  Daemon& d_;
  Station& st_;
  const Duration ping_period_;
  Time now_ = now_monotonic();
  Time next_ping_ = now_;
  Time next_status_ = now_ + cfg_.status_interval;
  Time next_write_ = now_ + cfg_.fusion.write_interval;
  Time next_map_ = now_ + cfg_.fusion.map_interval;
  std::uint64_t scans_at_write_ = 0;
  std::uint32_t lost_before_ = 0;
  std::uint64_t rejected_before_ = 0;
  Time next_reject_log_ = now_;
  Duration handle_max_{0}, map_max_{0}, map_total_{0};
  std::uint64_t map_count_ = 0;
  bool last_turn_ = false;
};

// One loop, one tick: wait for data at most until the next team publication is due.
void RunLoop::tick() {
  const Time before_poll = now_monotonic();
  // A catch-up in slices turns again at once (after the samples that are there); else wait for data.
  const bool busy = d_.fusion && d_.fusion->catch_up_has_work();
  const std::size_t handled =
      st_.poll(busy ? Duration{0} : std::min<Duration>(cfg_.station.team_period, std::chrono::milliseconds(50)));
  now_ = now_monotonic();
  if (handled > 0) handle_max_ = std::max(handle_max_, now_ - before_poll);
  if (d_.fusion) {
    // Held scans that waited long enough go now (the clock, not a sample, releases them: a burst, a
    // feed that stopped); their matches may move a correction, so the correction the core applies now
    // goes to the team source before the team is published, not only after the next sample.
    const Time rt = now_realtime();
    if (last_turn_) d_.fusion->flush();
    d_.fusion->tick(rt.ns());
    d_.corrections.share(d_.fusion->core(), *d_.team_source, rt);
  }
  st_.publish_team_if_due(now_);
  if (d_.ros2) d_.ros2->tick(now_, *d_.team_source);
  if (d_.view_feeder) d_.view_feeder->tick(now_);
  if (ping_period_.count() > 0 && now_ >= next_ping_) {
    dds::notify_watchdog();
    next_ping_ = now_ + ping_period_;
  }
  if (d_.fusion) (void)d_.fusion->poll_write();  // a finished write logged; a coalesced one started
  write_model_if_due();
  publish_map_if_due();
  report_status_if_due();
}

// The periodic model write: the snapshot in this loop, the files on the writer thread (events.log).
void RunLoop::write_model_if_due() {
  if (!d_.fusion || cfg_.fusion.write_interval.count() <= 0 || now_ < next_write_) return;
  if (d_.fusion->counters().scans != scans_at_write_) {
    scans_at_write_ = d_.fusion->counters().scans;
    d_.fusion->request_write();
    now_ = now_monotonic();
  }
  next_write_ = now_ + cfg_.fusion.write_interval;
}

void RunLoop::publish_map_if_due() {
  if (!d_.fusion || cfg_.fusion.map_interval.count() <= 0 || (now_ < next_map_ && !last_turn_)) return;
  // Only the voxels changed since the last publication, and the whole map every kFullMapEvery-th
  // (teamscan/map is keep-last 1, volatile: a late or lagging viewer catches up from a full one;
  // total_voxels == the update's length marks a full map). The whole map every time would cost this
  // loop time in proportion to the mapped space (docs/demo.md "Scale").
  constexpr std::uint64_t kFullMapEvery = 10;
  FusionStage& fusion = *d_.fusion;
  const bool replaced = fusion.take_map_replaced();  // built again: voxels may have gone
  const bool whole = replaced || map_count_ % kFullMapEvery == 0 || (d_.view_feeder && d_.view_feeder->wants_whole_map());
  if (whole) {
    fusion.map_voxels(d_.map_voxels, &d_.map_robots);
    fusion.clear_map_changes();
  } else {
    fusion.map_voxels_changed(d_.map_voxels, &d_.map_robots);
  }
  const std::uint32_t total = fusion.map_total_voxels();
  if (!d_.map_voxels.empty() && !st_.publish_map(d_.map_voxels, fusion.map_resolution_mm(), total).ok()) {
    log(kWarning, "fusion: teamscan/map write failed");
  }
  if (d_.ros2 && !d_.map_voxels.empty()) d_.ros2->offer_map(d_.map_voxels, total);
  if (d_.view_feeder) d_.view_feeder->offer_map(d_.map_voxels, d_.map_robots, whole, total, fusion.map_release());
  const Duration took = now_monotonic() - now_;
  map_max_ = std::max(map_max_, took);
  map_total_ += took;
  ++map_count_;
  now_ = now_monotonic();
  next_map_ = now_ + cfg_.fusion.map_interval;
}

void RunLoop::report_status_if_due() {
  if (now_ < next_status_) return;
  const std::string line = st_.status_line();
  dds::notify_status(line.c_str());
  if (st_.robots_lost() != lost_before_) {
    log(kWarning, line);
    lost_before_ = st_.robots_lost();
  }
  // Refused samples and clock reports (docs/validation.md): in the journal at most every 10 s.
  if (st_.counters().rejected != rejected_before_ && now_ >= next_reject_log_) {
    log(kWarning, line);
    rejected_before_ = st_.counters().rejected;
    next_reject_log_ = now_ + std::chrono::seconds(10);
  }
  if (!st_.write_validation()) log(kWarning, "cannot write validation.csv in the session folder");
  next_status_ = now_ + cfg_.status_interval;
}

void RunLoop::log_figures() const {
  char line[200];
  std::snprintf(line, sizeof line, "loop: longest poll (wait + handling) that took samples %.1f ms; teamscan/map %llu publications, longest %.1f ms, mean %.1f ms",
                to_seconds(handle_max_) * 1e3, static_cast<unsigned long long>(map_count_), to_seconds(map_max_) * 1e3,
                map_count_ ? to_seconds(map_total_) * 1e3 / static_cast<double>(map_count_) : 0.0);
  d_.store->log_event(now_realtime(), line);
}

void log_ros2_figures(Daemon& d) {
  const Ros2Counters c = d.ros2->counters();
  char line[400];
  std::snprintf(line, sizeof line, "ros2: %llu map updates, %llu clouds (last %llu points, longest %.1f ms, mean %.1f ms on "
                "its thread), %llu tf, %llu odometry, %llu scans (%llu dropped), %llu write errors; loop's longest "
                "hand-over %.3f ms, %llu deferred",
                static_cast<unsigned long long>(c.map_updates), static_cast<unsigned long long>(c.clouds),
                static_cast<unsigned long long>(c.last_cloud_points), to_seconds(c.cloud_max) * 1e3,
                c.clouds ? to_seconds(c.cloud_total) * 1e3 / static_cast<double>(c.clouds) : 0.0,
                static_cast<unsigned long long>(c.tf_messages), static_cast<unsigned long long>(c.odometry),
                static_cast<unsigned long long>(c.scans), static_cast<unsigned long long>(c.scans_dropped),
                static_cast<unsigned long long>(c.write_errors), to_seconds(c.offer_max) * 1e3,
                static_cast<unsigned long long>(c.handovers_deferred));
  d.store->log_event(now_realtime(), line);
}

void log_disk_sync_figures(Daemon& d) {
  const DiskSyncFigures f = d.disk_sync->figures();
  char text[160];
  std::snprintf(text, sizeof text, "disk sync: %llu rounds off the loop, %llu failed fdatasync, slowest %.1f ms",
                static_cast<unsigned long long>(f.syncs), static_cast<unsigned long long>(f.failures),
                static_cast<double>(f.longest_ns) * 1e-6);
  d.store->log_event(now_realtime(), text);
  if (f.failures > 0) log(kErr, text);
}

}  // namespace

void install_stop_signals() {
  struct sigaction sa{};
  sa.sa_handler = on_stop_signal;
  sigemptyset(&sa.sa_mask);
  sigaction(SIGTERM, &sa, nullptr);
  sigaction(SIGINT, &sa, nullptr);
}

std::optional<int> run_until_stopped(const GroundStationConfig& cfg, Daemon& d) {
  const Duration wd = dds::watchdog_interval();
  const Duration ping_period = wd.count() > 0 ? wd / 2 : Duration{0};
  dds::notify_ready();
  dds::notify_status(("receiving; session " + d.store->dir()).c_str());
  log(kInfo, "ready" + std::string(wd.count() > 0 ? ", watchdog on" : ""));

  // The session files reach the disk every sync_interval from a thread of their own (disk_sync.hpp):
  // a slow fdatasync never holds the receive loop.
  auto disk_sync = DiskSync::start(d.store->file_descriptors(), cfg.sync_interval);
  if (!disk_sync) {
    log(kErr, disk_sync.error().what);
    return 1;
  }
  d.disk_sync = std::move(disk_sync.value());

  RunLoop loop{cfg, d, ping_period};
  loop.run();
  dds::notify_stopping();
  if (d.view_feeder) d.view_feeder->offer_snapshot();  // the state with the final map's release (the robots' records still here)
  // Without the pose graph the loop's last turn published the final map; with it, the outputs stay up
  // until the final model on the graph's poses is published to them (stop_daemon).
  if (!(d.fusion && d.fusion->graph())) publish_final_map(d, false);
  loop.log_figures();
  return std::nullopt;
}

namespace {

// The fusion stage's end: every held scan decided, the model written; with the pose graph, its last
// optimisation, robot<N>.graph.tum, the final model decided again on its poses and written.
void finish_fusion(Daemon& d) {
  TimeoutProgress stop;  // TimeoutStopSec is sized for a station with little left to do
  stop.step("stopping: deciding the held scans");
  d.fusion->flush(stop.progress());  // every held scan decided with what arrived
  stop.step("stopping: writing the model");
  (void)d.fusion->write_model();  // after any write in flight, synchronous: the models are complete at exit
  fusion::GraphBackend* g = d.fusion->graph();
  if (g == nullptr) return;
  const std::size_t behind = g->queued();  // nodes the graph had not taken when the station stopped
  {
    const FusionCounters& c = d.fusion->counters();
    char follows[240];
    std::snprintf(follows, sizeof follows,
                  "fusion: the live map followed the pose graph %llu times (%llu moved rigidly); %llu estimates shifted no scan by "
                  "%.3f m and were not followed; %llu follows failed",
                  static_cast<unsigned long long>(c.graph_follows), static_cast<unsigned long long>(c.rigid_follows),
                  static_cast<unsigned long long>(c.follows_skipped), d.fusion->options().follow_min_shift_m,
                  static_cast<unsigned long long>(c.follow_failures));
    d.store->log_event(now_realtime(), follows);
  }
  stop.step("stopping: the pose graph's last optimisation");
  while (!g->finished_within(std::chrono::seconds(1))) stop.progress()(0.0);
  const Status graph = d.fusion->write_graph_trajectories();  // robot<N>.graph.tum
  const fusion::GraphBackendCounters c = g->counters();
  const posegraph::SlamStats st = g->graph_stats();
  char line[320];
  std::snprintf(line, sizeof line,
                "pose graph: %llu scans, %llu nodes (%zu behind at the stop, at most %zu), %zu submaps (%zu retired), %zu closures, "
                "%.0f MB of submaps and kept returns, %.1f s from the first scan to the last optimisation",
                static_cast<unsigned long long>(c.scans), static_cast<unsigned long long>(c.nodes), behind, c.queue_max, st.submaps,
                st.retired, st.closures, static_cast<double>(st.memory_bytes) / 1e6, g->seconds());
  d.store->log_event(now_realtime(), line);
  log(graph ? kInfo : kErr, graph ? std::string{line} + "; wrote robot<N>.graph.tum"
                                  : std::string{line} + "; robot<N>.graph.tum not written: " + graph.error().what);
  // The final model on the graph's poses (the one written above stays if this fails).
  stop.step("stopping: the model on the pose graph's poses");
  if (const Status rebuilt = d.fusion->rebuild_on_graph(stop.progress()); !rebuilt.ok()) {
    log(kErr, std::string{"fusion: the final model stays on the front end's poses: "} + rebuilt.error().what);
    return;
  }
  stop.step("stopping: writing the model on the pose graph's poses");
  if (const Status written = d.fusion->write_model(); !written.ok()) {
    log(kErr, std::string{"fusion: the final model on the pose graph's poses not written: "} + written.error().what);
    return;
  }
  std::snprintf(line, sizeof line, "fusion: the final model decided again on the pose graph's poses in %.1f s",
                d.fusion->counters().last_graph_rebuild_s);
  d.store->log_event(now_realtime(), line);
  log(kInfo, line);
}

}  // namespace

void stop_daemon(Daemon& d) {
  log(kInfo, "stopping: " + d.station->status_line());
  (void)d.station->write_validation();
  d.store->log_event(now_realtime(), "station stopping: " + d.station->status_line());
  // Nothing more is taken from the robots (what they send now stays in their stores); the map's
  // publishers stay in DDS until the final model is out.
  d.station->close_inputs();
  d.disk_sync->stop();
  log_disk_sync_figures(d);
  d.store->sync();  // the session is complete on disk before the final model write
  if (d.fusion) finish_fusion(d);
  // With the pose graph, what every output shows last is the final model on its poses (or, if that could
  // not be made, the live map as it stood): one output path to the end.
  if (d.fusion && d.fusion->graph()) publish_final_map(d, true);
  if (d.ros2) {
    log_ros2_figures(d);
    d.ros2.reset();
  }
  d.station.reset();  // leaves DDS
  if (d.view_server) {
    d.store->log_event(now_realtime(), d.view_server->counters().line());
    d.view_server.reset();  // its thread stops before the station's state goes
  }
}

}  // namespace teamscan::station::daemon
