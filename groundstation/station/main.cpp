// teamscan-groundstation: receives every robot's poses, scans and status over DDS, stores them in a
// session folder, marks robots that stop as lost, and publishes teamscan/team (issue 5). A systemd
// Type=notify service: READY=1 once subscribed, WATCHDOG=1 from the loop, STOPPING=1 on SIGTERM.
#include <algorithm>
#include <array>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <ctime>
#include <string>

#include <CLI/CLI.hpp>

#include "common/capacities.hpp"
#include "common/clock.hpp"
#include "common/version.hpp"
#include "dds/security/credentials.hpp"
#include "dds/security/openssl_util.hpp"
#include "groundstation/station/config.hpp"
#include "groundstation/station/disk_sync.hpp"
#include "groundstation/station/huge_page_heap.hpp"
#include "groundstation/station/ros2_publisher.hpp"
#include "groundstation/station/session_store.hpp"
#include "groundstation/station/station.hpp"
#include "dds/notify.hpp"
#include "groundstation/station/fusion.hpp"
#include "groundstation/station/pose_history_team_source.hpp"
#include "groundstation/station/team_source.hpp"
#include "groundstation/station/view_feeder.hpp"
#include "groundstation/view/server.hpp"
#include "teamscan.h"

namespace {

volatile std::sig_atomic_t g_stop = 0;
void on_stop_signal(int) { g_stop = 1; }

// Journal priorities (sd-daemon.h "<N>" prefixes) when stderr goes to the journal, plain text otherwise.
void log(int priority, const std::string& text) {
  static const bool journal = std::getenv("JOURNAL_STREAM") != nullptr;
  if (journal) {
    std::fprintf(stderr, "<%d>%s\n", priority, text.c_str());
  } else {
    std::fprintf(stderr, "teamscan-groundstation: %s\n", text.c_str());
  }
}
constexpr int kErr = 3;
constexpr int kWarning = 4;
constexpr int kInfo = 6;

}  // namespace

int main(int argc, char** argv) {
  using namespace teamscan;
  using namespace teamscan::station;
  std::string heap_why;
  const HeapPages heap = use_huge_page_heap(argv, &heap_why);  // may re-execute: first, before any thread
  CLI::App app{"teamscan ground station: receives, stores and tracks the robots' DDS data"};
  std::string config_path;
  std::string session_dir;
  bool check_only = false;
  long domain = -2;
  app.add_option("--config", config_path, "ground-station config (TOML), e.g. deploy/groundstation.toml")
      ->check(CLI::ExistingFile);
  app.add_option("--session-dir", session_dir, "store into exactly this folder instead of a new session-<time>");
  app.add_option("--domain", domain, "DDS domain id (overrides dds.domain_id)")->check(CLI::Range(-1, 232));
  std::string pki_dir;
  app.add_option("--pki-dir", pki_dir,
                 "DDS Security: the station's credential bundle (teamscan pki; the unit passes $CREDENTIALS_DIRECTORY); "
                 "checked before DDS starts, a bad one exits 2");
  app.add_flag("--check-config", check_only, "parse the config (and --pki-dir's credentials), print the effective values and exit");
  app.add_flag_callback(
      "--version",
      [] {
        print_version("teamscan-groundstation");
        throw CLI::Success();
      },
      "print the version and the git commit, and exit");
  CLI11_PARSE(app, argc, argv);

  GroundStationConfig cfg;
  if (!config_path.empty()) {
    ConfigError err;
    if (!load_groundstation_config(config_path, cfg, err)) {
      log(kErr, "config error: " + err.message);
      return 2;
    }
  }
  if (domain >= 0) cfg.station.domain_id = static_cast<std::uint32_t>(domain);
  if (!pki_dir.empty()) {
    const security::CredentialCheck c =
        security::check_credentials_for(pki_dir, security::kStationIdentity, static_cast<std::int64_t>(std::time(nullptr)));
    if (!c.ok()) {
      log(kErr, "DDS Security credentials refused: " + c.summary());
      return 2;
    }
    log(kInfo, "DDS Security: identity " + c.subject + ", certificate valid until " +
                   security::unix_to_utc(c.not_after_s));
    cfg.station.pki_dir = pki_dir;
  }
  if (check_only) {
    std::printf("session_root = %s\nscan_history_depth = %u\nteam_rate_hz = %.3f\nsilence_timeout_s = %.3f\n",
                cfg.session_root.c_str(), cfg.station.scan_history_depth, 1.0 / to_seconds(cfg.station.team_period),
                to_seconds(cfg.station.silence_timeout));
    std::printf("fusion.enabled = %s\nfusion.method = %s\nfusion.resolution_m = %.3f\nfusion.half_angle_deg = %.3f\n"
                "fusion.write_interval_s = %.3f\nfusion.map_interval_s = %.3f\n",
                cfg.fusion.enabled ? "true" : "false", cfg.fusion.method.c_str(), cfg.fusion.resolution_m,
                cfg.fusion.half_angle_deg, to_seconds(cfg.fusion.write_interval), to_seconds(cfg.fusion.map_interval));
    std::string compared;
    for (const std::string& m : cfg.fusion.compare_methods) compared += (compared.empty() ? "\"" : ", \"") + m + "\"";
    std::printf("fusion.compare_methods = [%s]\n", compared.c_str());
    std::printf("ros2.enabled = %s\nros2.map_interval_s = %.3f\nros2.pose_rate_hz = %.3f\nros2.heading_sigma_deg = %.3f\n",
                cfg.ros2.enabled ? "true" : "false", to_seconds(cfg.ros2.map_interval), cfg.ros2.pose_rate_hz,
                cfg.ros2.heading_sigma_deg);
    std::printf("view.listen = \"%s\"\n", cfg.view.listen.c_str());
    auto cpu_list = [](const std::vector<int>& cpus) {
      std::string out = "[";
      for (std::size_t i = 0; i < cpus.size(); ++i) {
        if (i > 0) out += ", ";
        out += std::to_string(cpus[i]);
      }
      out += ']';
      return out;
    };
    std::printf("view.cpus = %s\nfusion.writer_cpus = %s\nregistration.cpus = %s\n", cpu_list(cfg.view.cpus).c_str(),
                cpu_list(cfg.fusion.writer_cpus).c_str(), cpu_list(cfg.registration.cpus).c_str());
    return 0;
  }

  struct sigaction sa{};
  sa.sa_handler = on_stop_signal;
  sigemptyset(&sa.sa_mask);
  sigaction(SIGTERM, &sa, nullptr);
  sigaction(SIGINT, &sa, nullptr);

  auto store = session_dir.empty() ? SessionStore::create(cfg.session_root) : SessionStore::open(session_dir);
  if (!store) {
    log(kErr, std::string(store.error().what) + " (" + std::strerror(store.error().sys_errno) + ")");
    return 1;
  }
  log(kInfo, "session folder " + store->dir());
  if (heap == HeapPages::Huge) log(kInfo, "heap on transparent huge pages (glibc.malloc.hugetlb=1)");
  else if (heap == HeapPages::OperatorSet) log(kInfo, std::string("heap pages as GLIBC_TUNABLES says: ") + std::getenv("GLIBC_TUNABLES"));
  else log(kWarning, "heap on 4 KiB pages (the re-execution with glibc.malloc.hugetlb=1 failed: " + heap_why + ")");
  // The fusion stage first: with it on, teamscan/team is published from its core's pose history, the
  // station's one tracker (the same tracks the filters use). Its session replay comes after the station
  // has subscribed (below).
  std::unique_ptr<FusionStage> fusion;
  if (cfg.fusion.enabled) {
    auto created = FusionStage::create(fusion_options_from_config(cfg.fusion, cfg.kalman, cfg.registration), store->dir());
    if (!created) {
      log(kErr, created.error().what);
      return 1;
    }
    fusion = std::move(created.value());
  }
  std::unique_ptr<TeamSource> team_source;
  if (cfg.team_source == TeamSourceKind::kLastPose) {
    team_source = std::make_unique<LastPoseTeamSource>(cfg.last_pose);
  } else if (fusion) {
    team_source = std::make_unique<PoseHistoryTeamSource>(fusion->core().poses(), cfg.last_pose.default_body);
  } else {
    fusion::PoseHistoryOptions history;
    history.tracker = tracker_options(cfg.kalman);
    team_source = std::make_unique<PoseHistoryTeamSource>(history, cfg.last_pose.default_body);
  }
  TeamSource* const team = team_source.get();
  log(kInfo, std::string("team source: ") +
                 (cfg.team_source == TeamSourceKind::kLastPose ? "last pose"
                  : fusion ? "Kalman tracks of the fusion core's pose history"
                           : "Kalman tracks of a pose history (fusion off)"));
  auto station = Station::create(cfg.station, *store, *team);
  if (!station) {
    log(kErr, station.error().what);
    return 1;
  }
  Station& st = **station;
  // ROS 2 wire names (docs/ros2.md): fed from this loop by copies, published on its own thread.
  std::unique_ptr<Ros2Publisher> ros2;
  if (cfg.ros2.enabled) {
    auto created = Ros2Publisher::create(cfg.ros2, st.participant());
    if (!created) {
      log(kErr, created.error().what);
      return 1;
    }
    ros2 = std::move(created.value());
    st.add_pose_hook([&](const PoseObservation& p) { ros2->add_pose(p); });
    log(kInfo, "ros2: rt/teamscan/map_cloud, rt/tf, rt/robotN/odom");
    if (!cfg.fusion.enabled || cfg.fusion.map_interval.count() == 0) {
      log(kWarning, "ros2: no map cloud: it follows teamscan/map (fusion.enabled, fusion.map_interval_s > 0)");
    }
  }
  // The live fusion stage runs from the hooks, after each sample is stored (storage first: a failing
  // fusion stage never costs a received sample; the station counts the failure and goes on).
  std::vector<teamscan_msg_MapVoxel> map_voxels;
  CorrectionShare corrections;  // each robot's new registration correction to the team source
  if (fusion) {
    // A restart on the same session folder: the core is rebuilt from everything stored so far (the same
    // code, arrival order), so it decides as before; the robots' DDS history then fills the outage.
    store->sync();
    auto replayed = fusion->replay_session(store->dir());
    if (!replayed) {
      log(kErr, std::string("fusion: cannot replay the session folder: ") + replayed.error().what);
      store->log_event(now_realtime(), std::string("fusion: session replay failed: ") + replayed.error().what);
    } else if (replayed.value() > 0) {
      char text[160];
      std::snprintf(text, sizeof text, "fusion: rebuilt from the session folder: %llu samples, %llu scans fused",
                    static_cast<unsigned long long>(replayed.value()),
                    static_cast<unsigned long long>(fusion->counters().replayed_scans));
      log(kInfo, text);
      store->log_event(now_realtime(), text);
    }
    // With the registration on, the core's pose history corrects the poses teamscan/team is published
    // from; each robot's correction in force (a match, or the drift rates' extrapolation since one) goes
    // to the team source in wire form when it changes, so the members carry it too (docs/registration.md).
    corrections.share(fusion->core(), *team, now_realtime());  // after the session replay
    // The hooks outlive this block; what they refer to lives as long as this function.
    st.add_pose_hook([&fusion, &corrections, team](const PoseObservation& p) {
      fusion->add_pose(p);
      corrections.share(fusion->core(), *team, now_realtime());
    });
    st.add_scan_hook([&fusion, &corrections, team](const StoredScan& s) {
      fusion->add_scan(s);
      corrections.share(fusion->core(), *team, now_realtime());
    });
    log(kInfo, "fusion: method " + cfg.fusion.method + ", model " + store->dir() + "/fused.pcd");
    for (const std::string& m : cfg.fusion.compare_methods)
      log(kInfo, "fusion: compared method " + m + ", model " + store->dir() + "/" + method_file_name("fused.pcd", m));
  }
  // The fused models written from the cores' memory (no read-back of the session): periodic writes
  // take a snapshot in this loop and are written on the fusion stage's writer thread; the shutdown
  // write is synchronous. Every finished write is logged here, in the loop, with the latency so far.
  bool writer_told = false;
  bool match_told = false;  // a refused registration.cpus warned once
  auto log_write = [&](const ModelWriteReport& w) {
    if (!w.ok) {
      log(kErr, std::string("fusion: ") + w.error.what + " (" + std::strerror(w.error.sys_errno) + ")");
      store->log_event(now_realtime(), std::string("fused model write failed: ") + w.error.what);
    } else {
      const fusion::CoreCounters& c = fusion->core().counters();
      const FusionCounters& fc = fusion->counters();
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
                    static_cast<unsigned long long>(c.stored_points), fusion->core().model_voxels(),
                    static_cast<unsigned long long>(c.capped_points),
                    static_cast<double>(fusion->core().model_memory_bytes()) / (1024.0 * 1024.0),
                    static_cast<double>(fusion->model_memory_bytes()) / (1024.0 * 1024.0),
                    static_cast<double>(fusion->filter_memory_bytes()) / (1024.0 * 1024.0),
                    static_cast<double>(fusion->live_map().memory_bytes()) / (1024.0 * 1024.0),
                    static_cast<unsigned long long>(c.scans_forced), static_cast<unsigned long long>(c.scans_out_of_stamp_order));
      store->log_event(now_realtime(), text);
      if (w.on_writer_thread && !writer_told) {
        // Once: where the writer thread runs (fusion.writer_cpus), as the kernel reports it.
        writer_told = true;
        const ThreadScheduling ws = fusion->writer_scheduling();
        std::string line = "model writer thread: " + describe(ws);
        if (ws.affinity_error != 0) line += std::string(" (fusion.writer_cpus refused: ") + std::strerror(ws.affinity_error) + ")";
        store->log_event(now_realtime(), line);
        if (ws.affinity_error != 0) log(kWarning, line);
      }
      // Where the registration's matches run (registration.cpus), and how often the loop waited for one.
      if (const registration::Registration* reg = fusion->core().registration(); reg != nullptr && reg->worker() != nullptr) {
        const ThreadScheduling ms = reg->worker()->scheduling();
        std::string line = "registration match thread: " + describe(ms) + "; the loop waited for " +
                           std::to_string(reg->worker()->waits_blocked()) + " matches";
        if (ms.affinity_error != 0) line += std::string(" (registration.cpus refused: ") + std::strerror(ms.affinity_error) + ")";
        store->log_event(now_realtime(), line);
        if (ms.affinity_error != 0 && !match_told) log(kWarning, line);
        match_told = true;
      }
    }
    // Scan -> fused-map latency so far (latency.csv; docs/demo.md "Scale").
    const LatencyHistogram& lat = fusion->fused_latency();
    char line[160];
    std::snprintf(line, sizeof line, "scan -> fused map latency: %llu scans, p50 %.1f ms, p99 %.1f ms, max %.1f ms",
                  static_cast<unsigned long long>(lat.count()), static_cast<double>(lat.quantile_ns(0.5)) * 1e-6,
                  static_cast<double>(lat.quantile_ns(0.99)) * 1e-6, static_cast<double>(lat.max_ns()) * 1e-6);
    store->log_event(now_realtime(), line);
    if (const Status l = fusion->write_latency(); !l.ok()) log(kWarning, std::string("fusion: ") + l.error().what);
  };
  if (fusion) fusion->set_write_callback(log_write);
  // The browser view (docs/view.md): its own thread serves HTTP/WebSocket; the loop only offers copies
  // to its bounded feed (ViewFeeder). A view that cannot listen is logged and left off: the station runs on.
  std::unique_ptr<view::ViewFeed> view_feed;
  std::unique_ptr<ViewFeeder> view_feeder;
  std::unique_ptr<view::ViewServer> view_server;
  if (!cfg.view.listen.empty()) {
    view::ServerOptions vo;
    std::string why;
    (void)view::parse_listen(cfg.view.listen, vo.listen, why);  // validated with the config
    vo.web_root = cfg.view.web_root.empty() ? default_view_web_root() : cfg.view.web_root;
    vo.hub.map_resolution_mm = static_cast<std::uint32_t>(std::lround(cfg.fusion.map_resolution_m * 1000.0));
    vo.cpus = cfg.view.cpus;
    view_feed = std::make_unique<view::ViewFeed>();
    auto server = view::ViewServer::start(vo, *view_feed);
    if (!server) {
      log(kErr, std::string(server.error().what) + " " + cfg.view.listen + " (" + std::strerror(server.error().sys_errno) +
                    "); the view is off");
      view_feed.reset();
    } else {
      view_server = std::move(server.value());
      view_feeder = std::make_unique<ViewFeeder>(
          *view_feed, [&](std::uint32_t id) -> const RobotRecord& { return st.robot(id); }, *team,
          from_seconds(cfg.view.period_s), vo.hub.map_resolution_mm);
      st.add_pose_hook([&](const PoseObservation& p) { view_feeder->on_pose(p); });
      // After the fusion stage's hook: the growth of its live_removed counter is this scan's ghosts.
      st.add_scan_hook([&](const StoredScan& s) { view_feeder->on_scan(s, fusion ? fusion->counters().live_removed : 0); });
      log(kInfo, "view: " + view_server->url() +
                     (view_server->files() > 0 ? "" : " (no page found: give [view] web_root; API and /ws only)"));
      store->log_event(now_realtime(), "view: serving " + view_server->url() + " from " + (vo.web_root.empty() ? "-" : vo.web_root));
      const ThreadScheduling vs = view_server->scheduling();
      std::string placed = "view server thread: " + describe(vs);
      if (vs.affinity_error != 0) placed += std::string(" (view.cpus refused: ") + std::strerror(vs.affinity_error) + ")";
      store->log_event(now_realtime(), placed);
      if (vs.affinity_error != 0) log(kWarning, placed);
    }
  }

  const Duration wd = dds::watchdog_interval();
  const Duration ping_period = wd.count() > 0 ? wd / 2 : Duration{0};
  dds::notify_ready();
  dds::notify_status(("receiving; session " + store->dir()).c_str());
  log(kInfo, "ready" + std::string(wd.count() > 0 ? ", watchdog on" : ""));

  // The session files reach the disk every sync_interval from a thread of their own (disk_sync.hpp):
  // a slow fdatasync never holds the receive loop.
  auto disk_sync = DiskSync::start(store->file_descriptors(), cfg.sync_interval);
  if (!disk_sync) {
    log(kErr, disk_sync.error().what);
    return 1;
  }

  Time now = now_monotonic();
  Time next_ping = now;
  Time next_status = now + cfg.status_interval;
  Time next_write = now + cfg.fusion.write_interval;
  Time next_map = now + cfg.fusion.map_interval;
  std::uint64_t scans_at_write = 0;
  std::uint32_t lost_before = 0;
  std::uint64_t rejected_before = 0;
  Time next_reject_log = now;
  // Loop-time counters (STYLE.md 8): the longest handling of one poll's samples, and the teamscan/map
  // publications, which run in this loop too and hold the next take back (docs/demo.md "Scale").
  Duration handle_max{0}, map_max{0}, map_total{0};
  std::uint64_t map_count = 0;
  while (g_stop == 0) {
    // One loop, one tick: wait for data at most until the next team publication is due.
    const Time before_poll = now_monotonic();
    const std::size_t handled = st.poll(std::min<Duration>(cfg.station.team_period, std::chrono::milliseconds(50)));
    now = now_monotonic();
    if (handled > 0) handle_max = std::max(handle_max, now - before_poll);
    if (fusion) {
      // Held scans that waited long enough go now (the clock, not a sample, releases them: a burst, a
      // feed that stopped); their matches may move a correction, so the correction the core applies now
      // goes to the team source before the team is published, not only after the next sample.
      const Time rt = now_realtime();
      fusion->tick(rt.ns());
      corrections.share(fusion->core(), *team, rt);
    }
    st.publish_team_if_due(now);
    if (ros2) ros2->tick(now, *team);
    if (view_feeder) view_feeder->tick(now);
    if (ping_period.count() > 0 && now >= next_ping) {
      dds::notify_watchdog();
      next_ping = now + ping_period;
    }
    if (fusion) (void)fusion->poll_write();  // a finished write logged; a coalesced one started
    // The periodic model write: the snapshot in this loop, the files on the writer thread (events.log).
    if (fusion && cfg.fusion.write_interval.count() > 0 && now >= next_write) {
      if (fusion->counters().scans != scans_at_write) {
        scans_at_write = fusion->counters().scans;
        fusion->request_write();
        now = now_monotonic();
      }
      next_write = now + cfg.fusion.write_interval;
    }
    if (fusion && cfg.fusion.map_interval.count() > 0 && now >= next_map) {
      // Only the voxels changed since the last publication, and the whole map every kFullMapEvery-th
      // (teamscan/map is keep-last 1, volatile: a late or lagging viewer catches up from a full one;
      // total_voxels == the update's length marks a full map). Was the whole map every time: up to
      // 149 ms per publication in this loop at 32 robots (docs/demo.md "Scale").
      constexpr std::uint64_t kFullMapEvery = 10;
      const bool whole = map_count % kFullMapEvery == 0 || (view_feeder && view_feeder->wants_whole_map());
      if (whole) {
        fusion->map_voxels(map_voxels);
        fusion->clear_map_changes();
      } else {
        fusion->map_voxels_changed(map_voxels);
      }
      const std::uint32_t total = fusion->map_total_voxels();
      if (!map_voxels.empty() && !st.publish_map(map_voxels, fusion->map_resolution_mm(), total).ok()) {
        log(kWarning, "fusion: teamscan/map write failed");
      }
      if (ros2 && !map_voxels.empty()) ros2->offer_map(map_voxels, total);
      if (view_feeder) view_feeder->offer_map(map_voxels, whole, total);
      const Duration took = now_monotonic() - now;
      map_max = std::max(map_max, took);
      map_total += took;
      ++map_count;
      now = now_monotonic();
      next_map = now + cfg.fusion.map_interval;
    }
    if (now >= next_status) {
      const std::string line = st.status_line();
      dds::notify_status(line.c_str());
      if (st.robots_lost() != lost_before) {
        log(kWarning, line);
        lost_before = st.robots_lost();
      }
      // Refused samples and clock reports (docs/validation.md): in the journal at most every 10 s.
      if (st.counters().rejected != rejected_before && now >= next_reject_log) {
        log(kWarning, line);
        rejected_before = st.counters().rejected;
        next_reject_log = now + std::chrono::seconds(10);
      }
      if (!st.write_validation()) log(kWarning, "cannot write validation.csv in the session folder");
      next_status = now + cfg.status_interval;
    }
  }
  dds::notify_stopping();
  {
    char line[200];
    std::snprintf(line, sizeof line, "loop: longest poll (wait + handling) that took samples %.1f ms; teamscan/map %llu publications, longest %.1f ms, mean %.1f ms",
                  to_seconds(handle_max) * 1e3, static_cast<unsigned long long>(map_count), to_seconds(map_max) * 1e3,
                  map_count ? to_seconds(map_total) * 1e3 / static_cast<double>(map_count) : 0.0);
    store->log_event(now_realtime(), line);
  }
  if (ros2) {
    const Ros2Counters c = ros2->counters();
    char line[400];
    std::snprintf(line, sizeof line, "ros2: %llu map updates, %llu clouds (last %llu points, longest %.1f ms, mean %.1f ms on "
                  "its thread), %llu tf, %llu odometry, %llu write errors; loop's longest hand-over %.3f ms, %llu deferred",
                  static_cast<unsigned long long>(c.map_updates), static_cast<unsigned long long>(c.clouds),
                  static_cast<unsigned long long>(c.last_cloud_points), to_seconds(c.cloud_max) * 1e3,
                  c.clouds ? to_seconds(c.cloud_total) * 1e3 / static_cast<double>(c.clouds) : 0.0,
                  static_cast<unsigned long long>(c.tf_messages), static_cast<unsigned long long>(c.odometry),
                  static_cast<unsigned long long>(c.write_errors), to_seconds(c.offer_max) * 1e3,
                  static_cast<unsigned long long>(c.handovers_deferred));
    store->log_event(now_realtime(), line);
    ros2.reset();
  }
  if (view_server) {
    store->log_event(now_realtime(), view_server->counters().line());
    view_server.reset();  // its thread stops before the station's state goes
  }
  log(kInfo, "stopping: " + st.status_line());
  (void)st.write_validation();
  store->log_event(now_realtime(), "station stopping: " + st.status_line());
  station.value().reset();  // leave DDS before closing the files
  disk_sync.value()->stop();
  {
    const DiskSyncFigures f = disk_sync.value()->figures();
    char text[160];
    std::snprintf(text, sizeof text, "disk sync: %llu rounds off the loop, %llu failed fdatasync, slowest %.1f ms",
                  static_cast<unsigned long long>(f.syncs), static_cast<unsigned long long>(f.failures),
                  static_cast<double>(f.longest_ns) * 1e-6);
    store->log_event(now_realtime(), text);
    if (f.failures > 0) log(kErr, text);
  }
  store->sync();  // the session is complete on disk before the final model write
  if (fusion) {
    fusion->flush();              // every held scan decided with what arrived
    (void)fusion->write_model();  // after any write in flight, synchronous: the models are complete at exit
  }
  return 0;
}
