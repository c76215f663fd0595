// ViewFeed: the station -> view hand-off (feed.hpp).
#include "groundstation/view/feed.hpp"

#include <algorithm>

namespace teamscan::view {

ViewFeed::ViewFeed(FeedLimits limits) : limits_{limits} { pending_.scans.resize(limits_.max_scans); }

void ViewFeed::offer_scan(std::uint32_t robot_id, std::span<const TapPoint> points) {
  std::lock_guard<std::mutex> lock(mutex_);
  ++counters_.scans_offered;
  if (pending_.scan_count >= pending_.scans.size()) {
    ++counters_.scans_dropped;
    return;
  }
  TapScan& s = pending_.scans[pending_.scan_count++];
  s.robot_id = robot_id;
  s.count = static_cast<std::uint32_t>(std::min(points.size(), s.points.size()));
  std::copy_n(points.begin(), s.count, s.points.begin());
}

void ViewFeed::offer_voxels(std::span<const VoxelUpdate> voxels, bool full_map) {
  std::lock_guard<std::mutex> lock(mutex_);
  counters_.voxels_offered += voxels.size();
  if (full_map) {
    pending_.voxels.assign(voxels.begin(), voxels.end());
    pending_.voxels_are_full_map = true;
    want_full_.store(false, std::memory_order_relaxed);
    return;
  }
  if (want_full_.load(std::memory_order_relaxed)) return;  // the whole map comes next: changes are in it
  if (pending_.voxels.size() + voxels.size() > limits_.max_voxels) {
    ++counters_.voxel_overflows;
    pending_.voxels.clear();
    pending_.voxels_are_full_map = false;
    want_full_.store(true, std::memory_order_relaxed);
    return;
  }
  pending_.voxels.insert(pending_.voxels.end(), voxels.begin(), voxels.end());
}

void ViewFeed::offer_snapshot(const TeamSnapshot& snapshot) {
  std::lock_guard<std::mutex> lock(mutex_);
  ++counters_.snapshots_offered;
  if (pending_.snapshot) ++counters_.snapshots_replaced;
  pending_.snapshot = snapshot;
}

void ViewFeed::drain(FeedBatch& into) {
  into.scan_count = 0;
  into.voxels.clear();
  into.voxels_are_full_map = false;
  into.snapshot.reset();
  if (into.scans.size() != limits_.max_scans) into.scans.resize(limits_.max_scans);  // outside the lock
  std::lock_guard<std::mutex> lock(mutex_);
  std::swap(into.scans, pending_.scans);
  std::swap(into.scan_count, pending_.scan_count);
  std::swap(into.voxels, pending_.voxels);
  std::swap(into.voxels_are_full_map, pending_.voxels_are_full_map);
  std::swap(into.snapshot, pending_.snapshot);
}

FeedCounters ViewFeed::counters() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return counters_;
}

}  // namespace teamscan::view
