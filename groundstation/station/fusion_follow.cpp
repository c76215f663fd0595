// FusionStage's rigid follow of the pose graph (fusion.hpp FusionOptions::follow_rigidly): the moves from
// where the live cores placed their scans to the estimate's poses made off the loop, the corrections set
// from the newest release on, every core's model moved a slice per loop turn, the live map built again
// from the primary's moved model, and the old model and map freed off the loop; or, when one is due, an
// exact follow (the catch-up's rebuild on the estimate) in its place.
#include <algorithm>
#include <chrono>
#include <exception>
#include <future>
#include <system_error>
#include <utility>

#include "common/clock.hpp"
#include "common/thread_placement.hpp"
#include "groundstation/station/fusion.hpp"
#include "groundstation/station/rigid_follow.hpp"

namespace teamscan::station {

namespace {

// Old voxels moved per call between two looks at the clock.
constexpr std::size_t kVoxelsPerStep = 256;
// The reach a scan's turn is weighed with (FusionOptions::follow_min_shift_m): the LMS-200's range in its
// millimetre mode (ScanPointsOptions::max_range_mm).
constexpr double kReachM = 8.0;

}  // namespace

void FusionStage::start_rigid_follow(std::shared_ptr<const fusion::GraphEstimate> estimate) {
  auto f = std::make_unique<RigidFollow>();
  f->estimate = estimate;
  f->started = now_monotonic();
  // Decided now, so the thread makes the new models only for a rigid follow.
  f->exact = exact_follow_due();
  // What the thread needs of the cores: each one's store options and voxels, the live map's.
  struct Store {
    double resolution_m;
    std::uint32_t cap;
    std::size_t voxels;
  };
  std::vector<Store> stores;
  for (std::size_t i = 0; i < cores_->size(); ++i) {
    const fusion::CoreOptions& c = cores_->at(i).options();
    stores.push_back({c.model_resolution_m, c.max_points_per_voxel, cores_->at(i).model_voxels()});
  }
  try {
    // Off the loop, below it, with the model writer: the moves read every scan of both estimates.
    f->preparing = std::async(std::launch::async, [from = placement_, estimate, stores, map_voxels = map_.occupied_voxels(),
                                                   resolution_m = options_.map_resolution_m, min_shift_m = options_.follow_min_shift_m,
                                                   cpus = options_.writer_cpus, exact = f->exact]() {
      (void)set_current_thread_cpus(cpus);
      set_current_thread_below_loop();
      RigidFollow::Prepared p;
      p.to = fusion::ScanPlacement::on(estimate);
      p.moves = std::make_shared<const fusion::ScanMoves>(from, p.to);
      if (p.moves->largest_shift_m(kReachM) <= min_shift_m) return p;  // not followed: nothing more to make
      if (exact) return p;  // decided again, not moved: no new models
      for (const Store& s : stores) {
        p.stores.push_back(std::make_unique<fusion::ModelStore>(s.resolution_m, s.cap));
        p.stores.back()->reserve(s.voxels + s.voxels / 8);  // the moved model's voxels and some new ones
      }
      p.map = std::make_unique<LiveMap>(resolution_m);
      p.map->reserve(map_voxels + map_voxels / 8);
      return p;
    });
  } catch (const std::system_error&) {
    ++counters_.follow_failures;  // no thread: this estimate is not followed
    followed_version_ = estimate->version;
    return;
  }
  follow_ = std::move(f);
}

bool FusionStage::exact_follow_due() const {
  if (options_.exact_follow_share <= 0.0 || options_.exact_follow_max_s <= 0.0) return false;
  if (!exact_follow_) return true;
  const double took_s = to_seconds(exact_follow_->took);
  const double scans = static_cast<double>(core().counters().scans_released + core().held_scans());
  const double expected_s = took_s * scans / static_cast<double>(std::max<std::uint64_t>(exact_follow_->scans, 1));
  return expected_s <= options_.exact_follow_max_s &&
         took_s <= options_.exact_follow_share * to_seconds(now_monotonic() - exact_follow_->started);
}

void FusionStage::continue_rigid_follow(bool to_the_end, std::int64_t realtime_ns) {
  RigidFollow& f = *follow_;
  const Time started = now_monotonic();
  if (!f.begun) {
    if (!to_the_end && f.preparing.wait_for(std::chrono::seconds(0)) != std::future_status::ready) return;
    try {
      f.prepared = f.preparing.get();
    } catch (const std::exception&) {
      // Out of memory making the moves: the cores stay as they are, this estimate is not followed.
      ++counters_.follow_failures;
      followed_version_ = f.estimate->version;
      follow_.reset();
      return;
    }
    counters_.last_follow_shift_m = f.prepared.moves->largest_shift_m(kReachM);
    if (counters_.last_follow_shift_m <= options_.follow_min_shift_m) {
      // Not worth a pass over the model: the scans stay where they are (placement_ unchanged).
      ++counters_.follows_skipped;
      followed_version_ = f.estimate->version;
      free_off_loop(std::move(follow_));
      return;
    }
    // Worth following, and an exact follow is affordable: the session decided again on the graph's newest
    // estimate instead (the evidence and the decisions follow too). Not at the stop: the final pass does it.
    if (!to_the_end && f.exact) {
      start_catch_up(realtime_ns, true);
      if (run_) {
        free_off_loop(std::move(follow_));
        return;
      }
    }
    // The scans still to be released are placed by their robot's tail correction in the estimate (the
    // robots are handed it: CorrectionShare); those released so far are moved there.
    for (std::size_t i = 0; i < cores_->size(); ++i) {
      fusion::FusionCore& core = cores_->at(i);
      const std::int64_t newest = core.newest_released_stamp_ns();
      const std::int64_t from = newest == INT64_MIN ? INT64_MIN : newest + 1;
      for (std::uint8_t r = 1; r <= kMaxRobots; ++r)
        if (f.prepared.to.tail[r] != placement_.tail[r]) core.poses().set_map_from_odom(r, from, f.prepared.to.tail[r], 0.0, 0.0, false);
      core.begin_model_move(f.prepared.moves, i < f.prepared.stores.size() ? std::move(f.prepared.stores[i]) : nullptr);
    }
    f.map = std::move(f.prepared.map);
    if (!f.map) f.map = std::make_unique<LiveMap>(options_.map_resolution_m);  // an exact follow's, not started
    f.begun = true;
  }
  // A periodic write's snapshot reads the cores' models over several turns: the move waits for it.
  if (writer_->snapshotting()) {
    if (!to_the_end) return;
    writer_->wait();
  }
  const auto on_moved = [&](const fusion::ModelPoint& p) {
    f.map->add(p.p, p.removed_at_release != 0, p.robot);
    ++f.moved_points;
  };
  const Duration budget = from_seconds(std::max(options_.write_slice_ms, 0.0) * 1e-3);
  bool done = false;
  while (!done) {
    done = true;
    for (std::size_t i = 0; i < cores_->size(); ++i) {
      std::unique_ptr<fusion::ModelStore> old;
      if (i == 0) done = cores_->at(i).continue_model_move(kVoxelsPerStep, old, on_moved) && done;
      else done = cores_->at(i).continue_model_move(kVoxelsPerStep, old) && done;
      if (old) f.old_stores.push_back(std::move(old));
    }
    if (!to_the_end && now_monotonic() - started >= budget) break;
  }
  ++f.turns;
  f.slice_max = std::max(f.slice_max, now_monotonic() - started);
  if (done) finish_rigid_follow();
}

void FusionStage::finish_rigid_follow() {
  RigidFollow& f = *follow_;
  f.map->advance_release(map_.release());
  std::swap(map_, *f.map);  // the old live map goes with the leftovers
  placement_ = f.prepared.to;
  followed_ = f.estimate;
  followed_version_ = f.estimate->version;
  ++counters_.graph_follows;
  ++counters_.rigid_follows;
  counters_.followed_nodes = f.estimate->nodes;
  counters_.followed_closures = f.estimate->closures;
  counters_.last_rebuild_followed_graph = true;
  counters_.last_follow_rigid = true;
  counters_.follow_moved_points = f.moved_points;
  counters_.follow_scans = f.prepared.moves->scans();
  counters_.follow_turns = f.turns;
  counters_.follow_slice_max_s = to_seconds(f.slice_max);
  counters_.last_follow_s = to_seconds(now_monotonic() - f.started);
  map_replaced_ = true;
  free_off_loop(std::move(follow_));
  if (on_catch_up_) on_catch_up_(counters_);
}

void FusionStage::on_released_while_following(const fusion::FusedScan& f) {
  if (follow_ && follow_->begun) follow_->map->add_all(f.view->points, f.removed, f.stored, f.view->robot, f.release);
}

}  // namespace teamscan::station
