// FusionStage's catch-up after a radio shadow (fusion.hpp): when it starts, the session read and fed
// to the rebuilt cores on a loader thread, the live inputs behind it a slice per loop turn, the
// take-over; and the whole catch-up in one call (shutdown, catch_up_slice_scans = 0); and the cores
// rebuilt on the pose graph's poses.
#include <algorithm>
#include <chrono>
#include <exception>
#include <future>
#include <set>
#include <system_error>
#include <utility>

#include "common/clock.hpp"
#include "common/dataset/dataset.hpp"
#include "common/error_message.hpp"
#include "common/thread_placement.hpp"
#include "groundstation/fusion/graph_map.hpp"
#include "groundstation/fusion/time_line.hpp"
#include "groundstation/station/catch_up_run.hpp"
#include "groundstation/station/fusion.hpp"
#include "groundstation/station/session_replay.hpp"

namespace teamscan::station {

namespace {

// The inputs a core took after it had decided past their stamps: back-filled scans and poses.
std::uint64_t late_inputs(const fusion::CoreCounters& c) { return c.scans_late + c.poses_late; }

// A rebuild whose session folder changed under it: some scans' records, read when the folder was
// indexed, no longer read back when they were fed (SessionScanPoints).
Error unread_scans(std::uint64_t unread, const char* rebuild) {
  return make_error("fusion: " + std::to_string(unread) + " scans of the session folder no longer read back in the " + rebuild);
}

}  // namespace

std::uint64_t FusionStage::late_since_catch_up() const {
  return late_inputs(core().counters()) - late_base_;
}

void FusionStage::flush(const std::function<void(double)>& progress) {
  if (follow_) continue_rigid_follow(true);  // the releases since it began are in the moved models only
  // A follow of the graph under way with nothing late: dropped (the live cores are final as they are;
  // the final model follows the graph's last poses: rebuild_on_graph).
  if (run_ && run_->follow && counters_.catch_ups == 0 && late_since_catch_up() == 0) drop_catch_up();
  // Once a scan was released late in this run, the final model is the time order's, whatever came
  // after the last catch-up (a catch-up in slices under way is replaced by the whole one now). So it is
  // when the graph took scans out of stamp order (a robot's scans delayed less than hold_s, released
  // after a teammate's later ones): the graph follows its input order, and the final model its poses.
  const bool graph_out_of_order = graph_ && graph_->counters().out_of_stamp_order > 0;
  if ((counters_.catch_ups > 0 || late_since_catch_up() > 0 || run_ || graph_out_of_order) && !catch_up(now_realtime().ns(), progress).ok())
    ++counters_.catch_up_failures;
  cores_->flush();
}

void FusionStage::tick(std::int64_t realtime_ns) {
  if (resume_) return;
  cores_->advance_to(realtime_ns);
  if (follow_) {
    continue_rigid_follow(false, realtime_ns);
    return;
  }
  if (run_) {
    run_->rebuild.advance_to(realtime_ns);  // the live clock's step, behind the session for the rebuilt cores
    continue_catch_up();
    return;
  }
  const std::uint64_t late = late_inputs(core().counters());
  if (late != late_seen_) {
    late_seen_ = late;
    late_at_ns_ = realtime_ns;
  }
  if (options_.catch_up_min_scans > 0 && late_since_catch_up() >= options_.catch_up_min_scans &&
      realtime_ns - late_at_ns_ >= from_seconds(options_.catch_up_quiet_s).count()) {
    if (options_.catch_up_slice_scans > 0) {
      start_catch_up(realtime_ns);
    } else if (!catch_up(realtime_ns).ok()) {
      ++counters_.catch_up_failures;  // not tried again before more scans come late
      late_base_ = late;
    }
    return;
  }
  // The graph has a newer estimate than the cores follow: the same rebuild on its poses.
  if (graph_ && options_.catch_up_slice_scans > 0) {
    const std::shared_ptr<const fusion::GraphEstimate> estimate = graph_->latest();
    if (estimate && estimate->version != followed_version_) {
      // Rigidly only while the graph is what places the scans (with the registration on, its corrections
      // place them live and the graph only the final model) and there is a model to move (without a
      // model store the live map is the releases' points, which a move cannot reach).
      if (!options_.follow_rigidly) start_catch_up(realtime_ns, true);
      else if (!core().options().registration && core().options().max_points_per_voxel > 0) start_rigid_follow(estimate);
    }
  }
}

void FusionStage::start_catch_up(std::int64_t realtime_ns, bool follow) {
  const Time started = now_monotonic();
  if (session_dir_.empty()) {
    ++counters_.catch_up_failures;
    late_base_ = late_inputs(core().counters());
    return;
  }
  auto run = std::make_unique<CatchUpRun>(realtime_ns, options_.map_resolution_m);
  run->started = started;
  run->follow = follow;
  // The cores are rebuilt on the graph's newest estimate once there is one (a catch-up too: the live map
  // does not go back to the registration's placement); a catch-up starts a new graph fed in time order.
  if (graph_) run->on_graph = graph_->latest();
  if (options_.pose_graph && !follow) run->graph = std::make_unique<fusion::GraphBackend>(*options_.pose_graph);
  run->scans_needed = core().counters().scans_released + core().held_scans();
  // The folder as it is now: the store wrote every sample the cores took, each record whole.
  const SessionExtent extent = session_extent_now(session_dir_);
  try {
    // The loader reads the folder and feeds the new cores the whole session in time order, below the
    // loop (SCHED_BATCH, nice 10, on fusion.writer_cpus): the loop feeds them only the live inputs
    // queued behind it. It touches nothing but the run's own state (add_rebuilt_release); the run waits
    // for it before it goes.
    run->loading = std::async(std::launch::async, [dir = session_dir_, extent, core = options_.core, compared = options_.compare_methods,
                                                   on_graph = run->on_graph, r = run.get(), cpus = options_.writer_cpus]() -> Result<fusion::RebuildSource> {
      (void)set_current_thread_cpus(cpus);  // with the model writer, off the loop's CPUs (none: unchanged)
      set_current_thread_below_loop();
      SessionReadStats stats;
      Result<SessionIndex> session = read_session_index(dir, stats, extent);
      if (!session) return session.error();
      const SessionScanPoints& points = *session->points;
      Result<fusion::RebuildSource> source =
          on_graph ? fusion::rebuild_source_on_graph(std::move(session->dataset), core, compared, on_graph->poses(), std::move(session->points))
                   : fusion::make_rebuild_source(std::move(session->dataset), core, compared, std::move(session->points));
      if (!source) return source;
      if (source->dataset->scans.size() < r->scans_needed) return source;  // not fed: refused on the loop
      source->cores->primary().set_release_callback([r](const fusion::FusedScan& f) { add_rebuilt_release(*r, f); });
      fusion::feed_time_line(source.value());
      if (points.failures() > 0)
        return unread_scans(points.failures(), "catch-up");
      return source;
    });
  } catch (const std::system_error&) {
    ++counters_.catch_up_failures;  // no thread: not tried again before more scans come late
    late_base_ = late_inputs(core().counters());
    return;
  }
  run->slice_max = now_monotonic() - started;
  run_ = std::move(run);
}

bool FusionStage::catch_up_has_work() const { return run_ && run_->rebuild.loaded(); }

fusion::RebuildProgress FusionStage::catch_up_progress() const {
  return run_ ? run_->rebuild.progress() : fusion::RebuildProgress{};
}

void FusionStage::drop_catch_up() {
  if (!run_) return;
  if (run_->loading.valid()) run_->loading.wait();
  run_.reset();
}

void FusionStage::continue_catch_up() {
  CatchUpRun& run = *run_;
  const Time started = now_monotonic();
  if (!run.rebuild.loaded()) {
    if (run.loading.wait_for(std::chrono::seconds(0)) != std::future_status::ready) return;
    // The loader's exception (out of memory reading a large session) is a failed catch-up, not the loop's.
    Result<fusion::RebuildSource> source = Error{"fusion: the catch-up's session read failed"};
    try {
      source = run.loading.get();
    } catch (const std::exception&) {
    }
    if (!source || source->dataset->scans.size() < run.scans_needed) {
      // Not read, or not this station's folder: the cores stay as they are, no new try before more
      // scans come late (or, following the graph, before its next estimate).
      ++counters_.catch_up_failures;
      late_base_ = late_seen_ = late_inputs(core().counters());
      if (run.follow && run.on_graph) followed_version_ = run.on_graph->version;
      if (run.follow) exact_follow_ = {run.started, now_monotonic() - run.started, run.scans_needed};  // counts as one made
      run_.reset();
      return;
    }
    run.rebuild.load(std::move(source.value()));
    run.rebuild.cores().primary().set_release_callback([this](const fusion::FusedScan& f) { on_rebuilt_release(f); });
  }
  if (!run.behind && run.rebuild.time_line_done()) {
    // The session is fed (step() stops at its end): the queued live inputs from here on.
    run.behind = true;
    run.late_base = late_inputs(run.rebuild.cores().primary().counters());
  }
  const bool done = run.rebuild.step(options_.catch_up_slice_scans);
  ++run.turns;
  run.slice_max = std::max(run.slice_max, now_monotonic() - started);
  // A periodic write's snapshot reads the live cores over several turns: the take-over waits for it.
  if (done && run.behind && !writer_->snapshotting()) finish_catch_up();
}

void FusionStage::finish_catch_up() {
  CatchUpRun& run = *run_;
  const Time started = now_monotonic();
  cores_->take_state(run.rebuild.cores());
  std::swap(map_, run.map);  // the old live map goes with the run's leftovers
  if (run.graph) {
    graph_ = std::move(run.graph);
    followed_version_ = 0;  // the new graph's estimates are its own
  } else if (run.on_graph) {
    followed_version_ = run.on_graph->version;
  }
  // The rebuilt cores placed each scan of the estimate at its pose, a later one by its robot's last
  // correction in it (fusion/graph_map.hpp); without one, where the odometry put them.
  placement_ = fusion::ScanPlacement::on(run.on_graph);
  map_replaced_ = true;
  if (run.on_graph) {
    followed_ = run.on_graph;
    ++counters_.graph_follows;
    counters_.followed_nodes = run.on_graph->nodes;
    counters_.followed_closures = run.on_graph->closures;
  }
  counters_.scans = run.scans;
  counters_.points = run.points;
  counters_.live_removed = run.live_removed;
  // The scans the rebuilt primary released from the queue but the live one had not: they are fused and
  // in the map from now. Those the live primary released that the rebuilt one still holds are released
  // again later: not counted twice.
  std::set<std::pair<std::uint8_t, std::uint32_t>> rebuilt;
  for (const CatchUpRun::Released& r : run.rebuilt_released) {
    rebuilt.emplace(r.robot, r.scan);
    if (!run.live_released.count({r.robot, r.scan})) record_fused(r.robot, r.scan, r.stamp_ns, r.arrival_ns, r.map_from_robot);
  }
  released_before_.clear();
  for (const auto& key : run.live_released)
    if (!rebuilt.count(key) && core().holds(key.first, key.second)) released_before_.insert(key);
  resume_ = false;
  late_base_ = late_seen_ = run.late_base;
  if (!run.follow) ++counters_.catch_ups;
  counters_.last_rebuild_followed_graph = run.follow;
  counters_.last_follow_rigid = false;
  counters_.caught_up_scans = run.rebuild.progress().time_line_scans;
  counters_.caught_up_live_scans = run.rebuild.progress().queued_fed_scans;
  counters_.catch_up_turns = run.turns;
  const Duration slice_max = run.slice_max;
  const Time catch_up_started = run.started;
  const bool follow = run.follow;
  const std::uint64_t session_scans = run.scans_needed;
  free_off_loop(std::move(run_));  // the session read and the cores' and map's old states
  const Time done = now_monotonic();
  if (follow) exact_follow_ = {catch_up_started, done - catch_up_started, session_scans};
  counters_.catch_up_slice_max_s = to_seconds(std::max(slice_max, done - started));
  counters_.last_catch_up_s = to_seconds(done - catch_up_started);
  if (on_catch_up_) on_catch_up_(counters_);
}

Result<SessionIndex> FusionStage::read_own_session() {
  if (session_dir_.empty()) return Error{"fusion: no session folder to read back"};
  drop_catch_up();
  SessionReadStats stats;
  Result<SessionIndex> session = read_session_index(session_dir_, stats);
  if (!session) return session.error();
  // Storage comes first, so the folder holds every scan the core took; if not (not this station's
  // folder), the cores stay as they are.
  if (session->dataset.scans.size() < core().counters().scans_released + core().held_scans())
    return Error{"fusion: the session folder holds fewer scans than the fusion core took"};
  return session;
}

Status FusionStage::catch_up(std::int64_t realtime_ns, const std::function<void(double)>& progress) {
  const Time started = now_monotonic();
  if (follow_) continue_rigid_follow(true);
  Result<SessionIndex> session = read_own_session();
  if (!session) return with_context("fusion: no catch-up", session.error());
  writer_->wait();  // a snapshot in progress reads the cores
  map_ = LiveMap{options_.map_resolution_m};
  map_replaced_ = true;
  placement_ = {};  // fed on the odometry (a new graph, no estimate yet)
  counters_.scans = counters_.points = counters_.live_removed = 0;
  if (options_.pose_graph) {
    graph_ = std::make_unique<fusion::GraphBackend>(*options_.pose_graph);  // fed the releases again
    followed_version_ = 0;
  }
  catching_up_ = true;
  const Result<std::size_t> fed = fusion::refeed_in_time_order(session->dataset, *cores_, progress, session->points.get());
  catching_up_ = false;
  if (!fed) return fed.error();
  if (const std::uint64_t unread = session->points->failures(); unread > 0)
    return unread_scans(unread, "catch-up");
  cores_->resume_at(realtime_ns);
  resume_ = false;
  released_before_.clear();
  late_base_ = late_seen_ = late_inputs(core().counters());
  ++counters_.catch_ups;
  counters_.last_rebuild_followed_graph = false;
  counters_.last_follow_rigid = false;
  counters_.caught_up_scans = fed.value();
  counters_.caught_up_live_scans = 0;
  counters_.catch_up_turns = 0;
  counters_.last_catch_up_s = to_seconds(now_monotonic() - started);
  counters_.catch_up_slice_max_s = counters_.last_catch_up_s;
  if (on_catch_up_) on_catch_up_(counters_);
  return ok_status();
}

Status FusionStage::rebuild_on_graph(const std::function<void(double)>& progress) {
  if (!graph_) return ok_status();
  const Time started = now_monotonic();
  if (follow_) continue_rigid_follow(true);
  Result<SessionIndex> session = read_own_session();
  if (!session) return session.error();
  LiveMap map{options_.map_resolution_m};
  std::uint64_t scans = 0, points = 0, removed = 0;
  Result<std::unique_ptr<fusion::CoreSet>> rebuilt = fusion::cores_on_graph(
      session->dataset, graph_->poses(), options_.core, options_.compare_methods,
      [&](const fusion::FusedScan& f) {
        map.add_all(f.view->points, f.removed, f.stored, f.view->robot, f.release);
        ++scans;
        points += f.view->points.size();
        for (std::uint8_t r : f.removed) removed += r != 0 ? 1 : 0;
      },
      progress, session->points.get());
  if (!rebuilt) return rebuilt.error();
  if (const std::uint64_t unread = session->points->failures(); unread > 0)
    return with_context("fusion: the model stays as it was", unread_scans(unread, "final model's rebuild on the graph"));
  writer_->wait();  // a snapshot in progress reads the cores
  cores_->take_state(*rebuilt.value());
  map_ = std::move(map);
  map_replaced_ = true;
  counters_.scans = scans;
  counters_.points = points;
  counters_.live_removed = removed;
  ++counters_.graph_rebuilds;
  counters_.last_graph_rebuild_s = to_seconds(now_monotonic() - started);
  return ok_status();
}

}  // namespace teamscan::station
