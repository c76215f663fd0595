// teamscan-groundstation's parts started and wired (daemon_wiring.hpp).
#include "groundstation/station/daemon_wiring.hpp"

#include <cstdio>
#include <cstdlib>
#include <cstring>

#include "common/capacities.hpp"
#include "common/clock.hpp"
#include "common/units.hpp"
#include "groundstation/station/daemon_log.hpp"
#include "groundstation/station/pose_history_team_source.hpp"
#include "groundstation/station/timeout_progress.hpp"

namespace teamscan::station::daemon {

namespace {

std::optional<int> open_session(const std::string& root, const std::string& session_dir, HeapPages heap,
                                const std::string& heap_why, Daemon& d) {
  auto store = session_dir.empty() ? SessionStore::create(root) : SessionStore::open(session_dir);
  if (!store) {
    log(kErr, std::string(store.error().what) + " (" + std::strerror(store.error().sys_errno) + ")");
    return 1;
  }
  d.store.emplace(std::move(store.value()));
  log(kInfo, "session folder " + d.store->dir());
  if (heap == HeapPages::Huge) log(kInfo, "heap on transparent huge pages (glibc.malloc.hugetlb=1)");
  else if (heap == HeapPages::OperatorSet) log(kInfo, std::string("heap pages as GLIBC_TUNABLES says: ") + std::getenv("GLIBC_TUNABLES"));
  else log(kWarning, "heap on 4 KiB pages (the re-execution with glibc.malloc.hugetlb=1 failed: " + heap_why + ")");
  return std::nullopt;
}

// The fusion stage first: with it on, teamscan/team is published from its core's pose history, the
// station's one tracker (the same tracks the filters use). Its session replay comes after the station
// has subscribed (start_live_fusion).
std::optional<int> start_fusion_and_team_source(const GroundStationConfig& cfg, Daemon& d) {
  if (cfg.fusion.enabled) {
    auto created = FusionStage::create(cfg.fusion, d.store->dir());
    if (!created) {
      log(kErr, created.error().what);
      return 1;
    }
    d.fusion = std::move(created.value());
  }
  if (cfg.team_source == TeamSourceKind::kLastPose) {
    d.team_source = std::make_unique<LastPoseTeamSource>(cfg.last_pose);
  } else if (d.fusion) {
    d.team_source = std::make_unique<PoseHistoryTeamSource>(d.fusion->core().poses(), cfg.last_pose.default_body);
  } else {
    fusion::PoseHistoryOptions history;
    history.tracker = cfg.fusion.core.tracker;
    history.tracker.team_lag_s = 0.0;  // no decisions without the fusion: no decision lag
    d.team_source = std::make_unique<PoseHistoryTeamSource>(history, cfg.last_pose.default_body);
  }
  log(kInfo, std::string("team source: ") +
                 (cfg.team_source == TeamSourceKind::kLastPose ? "last pose"
                  : d.fusion ? "Kalman tracks of the fusion core's pose history"
                             : "Kalman tracks of a pose history (fusion off)"));
  return std::nullopt;
}

// ROS 2 wire names (docs/ros2.md): fed from the loop by copies, published on its own thread.
std::optional<int> start_ros2(const GroundStationConfig& cfg, Daemon& d) {
  if (!cfg.ros2.enabled) return std::nullopt;
  auto created = Ros2Publisher::create(cfg.ros2, d.station->participant());
  if (!created) {
    log(kErr, created.error().what);
    return 1;
  }
  d.ros2 = std::move(created.value());
  d.station->add_pose_hook([&d](const PoseObservation& p) { d.ros2->add_pose(p); });
  // rt/robotN/scan in robotN/base_link at the scan's stamp where the fusion core's pose history places
  // the robot then, else in robotN/odom.
  d.station->add_scan_hook([&d](const ScanPoints& s, const Receipt& receipt) {
    if (d.fusion && receipt.rejected == 0 && s.robot_id >= 1 && s.robot_id <= kMaxRobots) {
      const fusion::PoseHistory::ScanPose at =
          d.fusion->core().poses().scan_pose(static_cast<std::uint8_t>(s.robot_id), s.stamp.ns());
      if (at.found) return d.ros2->add_scan(s, receipt, &at.odom);
    }
    d.ros2->add_scan(s, receipt);
  });
  log(kInfo, "ros2: rt/teamscan/map_cloud, rt/tf, rt/robotN/odom, rt/robotN/scan");
  if (!cfg.fusion.enabled || cfg.fusion.map_interval.count() == 0) {
    log(kWarning, "ros2: no map cloud: it follows teamscan/map (fusion.enabled, fusion.map_interval_s > 0)");
  }
  return std::nullopt;
}

// The live fusion stage runs from the hooks, after each sample is stored (storage first: a failing
// fusion stage never costs a received sample; the station counts the failure and goes on).
void start_live_fusion(const GroundStationConfig& cfg, Daemon& d) {
  if (!d.fusion) return;
  SessionStore& store = *d.store;
  // A restart on the same session folder: the core is rebuilt from everything stored so far (the same
  // code, arrival order), so it decides as before; the robots' DDS history then fills the outage.
  store.sync();
  TimeoutProgress start;  // TimeoutStartSec is sized for a fresh start, not a long session read back
  start.step("starting: reading the session folder back into the fusion core");
  auto replayed = d.fusion->replay_session(store.dir(), [&start] { start.progressing(); });
  if (!replayed) {
    log(kErr, std::string("fusion: cannot replay the session folder: ") + replayed.error().what);
    store.log_event(now_realtime(), std::string("fusion: session replay failed: ") + replayed.error().what);
  } else if (replayed.value() > 0) {
    char text[160];
    std::snprintf(text, sizeof text, "fusion: rebuilt from the session folder: %llu samples, %llu scans fused",
                  static_cast<unsigned long long>(replayed.value()),
                  static_cast<unsigned long long>(d.fusion->counters().replayed_scans));
    log(kInfo, text);
    store.log_event(now_realtime(), text);
  }
  // With the registration on, the core's pose history corrects the poses teamscan/team is published
  // from; each robot's correction in force (a match, or the drift rates' extrapolation since one) goes
  // to the team source in wire form when it changes, so the members carry it too (docs/registration.md).
  TeamSource* const team = d.team_source.get();
  d.corrections.share(d.fusion->core(), *team, now_realtime());  // after the session replay
  d.station->add_pose_hook([&d, team](const PoseObservation& p) {
    d.fusion->add_pose(p);
    d.corrections.share(d.fusion->core(), *team, now_realtime());
  });
  // A back-filled pose enters the pose history (stamped in a shadow: the catch-up after it decides again).
  d.station->add_backfill_pose_hook([&d](const PoseObservation& p) { d.fusion->add_pose(p); });
  d.station->add_scan_hook([&d, team](const ScanPoints& s, const Receipt& receipt) {
    d.fusion->add_scan(s, receipt);
    d.corrections.share(d.fusion->core(), *team, now_realtime());
  });
  log(kInfo, "fusion: method " + cfg.fusion.core.method + ", model " + store.dir() + "/fused.pcd");
  for (const std::string& m : cfg.fusion.compare_methods)
    log(kInfo, "fusion: compared method " + m + ", model " + store.dir() + "/" + method_file_name("fused.pcd", m));
}

// Where the model writer thread runs (fusion.writer_cpus), as the kernel reports it: once.
void log_writer_placement(Daemon& d) {
  if (d.writer_told) return;
  d.writer_told = true;
  const ThreadScheduling ws = d.fusion->writer_scheduling();
  std::string line = "model writer thread: " + describe(ws);
  if (ws.affinity_error != 0) line += std::string(" (fusion.writer_cpus refused: ") + std::strerror(ws.affinity_error) + ")";
  d.store->log_event(now_realtime(), line);
  if (ws.affinity_error != 0) log(kWarning, line);
}

// Where the registration's matches run (registration.cpus), and how often the loop waited for one.
void log_match_placement(Daemon& d) {
  const registration::Registration* reg = d.fusion->core().registration();
  if (reg == nullptr || reg->worker() == nullptr) return;
  const ThreadScheduling ms = reg->worker()->scheduling();
  std::string line = "registration match thread: " + describe(ms) + "; the loop waited for " +
                     std::to_string(reg->worker()->waits_blocked()) + " matches";
  if (ms.affinity_error != 0) line += std::string(" (registration.cpus refused: ") + std::strerror(ms.affinity_error) + ")";
  d.store->log_event(now_realtime(), line);
  if (ms.affinity_error != 0 && !d.match_told) log(kWarning, line);
  d.match_told = true;
}

// A finished model write in events.log: its figures, or its failure; then the latency so far.
void log_model_write(const GroundStationConfig& cfg, Daemon& d, const ModelWriteReport& w) {
  FusionStage& fusion = *d.fusion;
  if (!w.ok) {
    log(kErr, std::string("fusion: ") + w.error.what + " (" + std::strerror(w.error.sys_errno) + ")");
    d.store->log_event(now_realtime(), std::string("fused model write failed: ") + w.error.what);
  } else {
    const fusion::CoreCounters& c = fusion.core().counters();
    const FusionCounters& fc = fusion.counters();
    char text[768];
    std::snprintf(text, sizeof text,
                  "fused model written (%s): %llu kept, %llu removed, %llu scans; snapshot %.3f s in the loop (%u slices, longest "
                  "%.1f ms, over %.2f s), write %.2f s %s "
                  "(%zu models, %llu points; %llu requests coalesced); model store %llu points in %zu voxels (%llu beyond the "
                  "per-voxel cap), %.1f MiB (all models %.1f MiB); filter maps %.1f MiB, live map %.1f MiB; %llu scans released by hold_s, %llu out of stamp order",
                  w.on_writer_thread ? "periodic" : "shutdown", static_cast<unsigned long long>(w.kept), static_cast<unsigned long long>(w.removed),
                  static_cast<unsigned long long>(fc.scans), w.snapshot_s, w.snapshot_slices,
                  w.snapshot_slice_max_s * 1e3, w.snapshot_span_s, w.write_s,
                  w.on_writer_thread ? "on the writer thread" : "in the loop", 1 + cfg.fusion.compare_methods.size(),
                  static_cast<unsigned long long>(w.points), static_cast<unsigned long long>(fc.writes_coalesced),
                  static_cast<unsigned long long>(c.stored_points), fusion.core().model_voxels(),
                  static_cast<unsigned long long>(c.capped_points),
                  static_cast<double>(fusion.core().model_memory_bytes()) / (1024.0 * 1024.0),
                  static_cast<double>(fusion.model_memory_bytes()) / (1024.0 * 1024.0),
                  static_cast<double>(fusion.filter_memory_bytes()) / (1024.0 * 1024.0),
                  static_cast<double>(fusion.live_map().memory_bytes()) / (1024.0 * 1024.0),
                  static_cast<unsigned long long>(c.scans_forced), static_cast<unsigned long long>(c.scans_out_of_stamp_order));
    d.store->log_event(now_realtime(), text);
    if (w.on_writer_thread) log_writer_placement(d);
    log_match_placement(d);
  }
  // Scan -> fused-map latency so far (latency.csv; docs/demo.md "Scale").
  const LatencyHistogram& lat = fusion.fused_latency();
  char line[160];
  std::snprintf(line, sizeof line, "scan -> fused map latency: %llu scans, p50 %.1f ms, p99 %.1f ms, max %.1f ms",
                static_cast<unsigned long long>(lat.count()), static_cast<double>(lat.quantile_ns(0.5)) * 1e-6,
                static_cast<double>(lat.quantile_ns(0.99)) * 1e-6, static_cast<double>(lat.max_ns()) * 1e-6);
  d.store->log_event(now_realtime(), line);
  if (const Status l = fusion.write_latency(); !l.ok()) log(kWarning, std::string("fusion: ") + l.error().what);
}

// The browser view (docs/view.md): its own thread serves HTTP/WebSocket; the loop only offers copies
// to its bounded feed (ViewFeeder). A view that cannot listen is logged and left off: the station runs on.
void start_view(const GroundStationConfig& cfg, Daemon& d) {
  if (cfg.view.listen.empty()) return;
  view::ServerOptions vo;
  std::string why;
  (void)view::parse_listen(cfg.view.listen, vo.listen, why);  // validated with the config
  vo.web_root = cfg.view.web_root.empty() ? default_view_web_root() : cfg.view.web_root;
  vo.hub.map_resolution_mm = static_cast<std::uint32_t>(to_mm(cfg.fusion.map_resolution_m));
  vo.cpus = cfg.view.cpus;
  vo.foxglove.static_transforms = laser_transforms(cfg.ros2, now_realtime().ns());  // the laser mounts
  d.view_feed = std::make_unique<view::ViewFeed>();
  auto server = view::ViewServer::start(vo, *d.view_feed);
  if (!server) {
    log(kErr, std::string(server.error().what) + " " + cfg.view.listen + " (" + std::strerror(server.error().sys_errno) +
                  "); the view is off");
    d.view_feed.reset();
    return;
  }
  d.view_server = std::move(server.value());
  d.view_feeder = std::make_unique<ViewFeeder>(
      *d.view_feed, [&d](std::uint32_t id) -> const RobotRecord& { return d.station->robot(id); }, *d.team_source,
      from_seconds(cfg.view.period_s), vo.hub.map_resolution_mm,
      d.fusion ? GhostCount([&d](std::uint32_t id) { return d.fusion->core().robot_counters(id).removed_at_release; })
               : GhostCount{});
  d.station->add_pose_hook([&d](const PoseObservation& p) { d.view_feeder->on_pose(p); });
  d.station->add_scan_hook([&d](const ScanPoints& s, const Receipt& receipt) { d.view_feeder->on_scan(s, receipt); });
  log(kInfo, "view: " + d.view_server->url() +
                 (d.view_server->files() > 0 ? "" : " (no page found: give [view] web_root; API and /ws only)"));
  d.store->log_event(now_realtime(), "view: serving " + d.view_server->url() + " from " + (vo.web_root.empty() ? "-" : vo.web_root));
  const ThreadScheduling vs = d.view_server->scheduling();
  std::string placed = "view server thread: " + describe(vs);
  if (vs.affinity_error != 0) placed += std::string(" (view.cpus refused: ") + std::strerror(vs.affinity_error) + ")";
  d.store->log_event(now_realtime(), placed);
  if (vs.affinity_error != 0) log(kWarning, placed);
}

}  // namespace

std::optional<int> start_daemon(const GroundStationConfig& cfg, const std::string& session_dir, HeapPages heap,
                                const std::string& heap_why, Daemon& d) {
  if (auto exit = open_session(cfg.session_root, session_dir, heap, heap_why, d)) return exit;
  if (auto exit = start_fusion_and_team_source(cfg, d)) return exit;
  auto station = Station::create(cfg.station, *d.store, *d.team_source);
  if (!station) {
    log(kErr, station.error().what);
    return 1;
  }
  d.station = std::move(station.value());
  if (auto exit = start_ros2(cfg, d)) return exit;
  start_live_fusion(cfg, d);
  // The fused models written from the cores' memory (no read-back of the session): periodic writes
  // take a snapshot in the loop and are written on the fusion stage's writer thread; the shutdown
  // write is synchronous. Every finished write is logged in the loop, with the latency so far.
  if (d.fusion) d.fusion->set_write_callback([&cfg, &d](const ModelWriteReport& w) { log_model_write(cfg, d, w); });
  if (d.fusion) {
    d.fusion->set_catch_up_callback([&d](const FusionCounters& c) {  // after a back-fill (fusion.hpp catch_up)
      char text[400];
      char what[160];
      if (c.last_follow_rigid) {
        std::snprintf(text, sizeof text,
                      "fusion: the map follows the pose graph's estimate (%llu nodes, %llu loop closures): %llu model points "
                      "moved rigidly (%llu scans' moves) in %.2f s (%llu loop turns, at most %.1f ms of one)",
                      static_cast<unsigned long long>(c.followed_nodes), static_cast<unsigned long long>(c.followed_closures),
                      static_cast<unsigned long long>(c.follow_moved_points), static_cast<unsigned long long>(c.follow_scans),
                      c.last_follow_s, static_cast<unsigned long long>(c.follow_turns), c.follow_slice_max_s * 1e3);
        d.store->log_event(now_realtime(), text);
        return;
      }
      if (c.last_rebuild_followed_graph)
        std::snprintf(what, sizeof what, "the map follows the pose graph's estimate (%llu nodes, %llu loop closures)",
                      static_cast<unsigned long long>(c.followed_nodes), static_cast<unsigned long long>(c.followed_closures));
      else
        std::snprintf(what, sizeof what, "caught up in time order");
      std::snprintf(text, sizeof text,
                    "fusion: %s: %llu scans of the session decided again in %.2f s "
                    "(%llu loop turns, at most %.1f ms of one; %llu live scans fed behind them)",
                    what, static_cast<unsigned long long>(c.caught_up_scans), c.last_catch_up_s,
                    static_cast<unsigned long long>(c.catch_up_turns), c.catch_up_slice_max_s * 1e3,
                    static_cast<unsigned long long>(c.caught_up_live_scans));
      d.store->log_event(now_realtime(), text);
    });
  }
  start_view(cfg, d);
  return std::nullopt;
}

}  // namespace teamscan::station::daemon
