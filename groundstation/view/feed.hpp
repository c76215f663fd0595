// ViewFeed: the bounded, lock-protected hand-off from the station's receive loop to the view's server
// thread. The loop copies what it offers into preallocated buffers under a mutex held for a copy at
// most; the view swaps the buffers out under the same mutex (O(1)) and works on them outside it. Nothing
// here waits for the view: a view that falls behind loses tap scans (counted; the Foxglove /robotN/scan
// channels miss them) and its pending voxel changes (counted; the loop then offers the whole map,
// wants_full_map()), never the station's memory or time.
#pragma once

#include <array>
#include <atomic>
#include <cstddef>
#include <cstdint>
#include <mutex>
#include <optional>
#include <span>
#include <vector>

#include "groundstation/view/snapshot.hpp"

namespace teamscan::view {

struct FeedLimits {
  std::size_t max_scans = 512;        // tap scans held between two drains (≈ 0.2 s of 32 robots at 75 Hz)
  std::size_t max_voxels = 1u << 20;  // changed voxels held between two drains
};

struct FeedCounters {
  std::uint64_t scans_offered = 0;
  std::uint64_t scans_dropped = 0;  // the tap buffer was full: the view did not drain in time
  std::uint64_t voxels_offered = 0;
  std::uint64_t voxel_overflows = 0;  // pending changes dropped; the whole map was asked for instead
  std::uint64_t snapshots_offered = 0;
  std::uint64_t snapshots_replaced = 0;  // a snapshot not drained before the next one (only the latest counts)
};

// A scan's placed points, as the tap keeps them.
struct TapScan {
  std::uint32_t robot_id = 0;
  std::uint32_t count = 0;
  std::array<TapPoint, kMaxBeams> points{};
};

// What one drain hands the view: buffers swapped out of the feed, valid until the next drain.
struct FeedBatch {
  std::vector<TapScan> scans;  // scans[0..scan_count)
  std::size_t scan_count = 0;
  std::vector<VoxelUpdate> voxels;
  bool voxels_are_full_map = false;  // voxels is the whole map (after an overflow)
  std::optional<TeamSnapshot> snapshot;
};

class ViewFeed {
 public:
  explicit ViewFeed(FeedLimits limits = {});

  // Loop side (one thread).
  void offer_scan(std::uint32_t robot_id, std::span<const TapPoint> points);
  // Changed voxels since the last offer. `full_map`: `voxels` is the whole map (answers wants_full_map()).
  void offer_voxels(std::span<const VoxelUpdate> voxels, bool full_map = false);
  void offer_snapshot(const TeamSnapshot& snapshot);
  // True after pending changes were dropped: the next offer_voxels should be the whole map.
  [[nodiscard]] bool wants_full_map() const { return want_full_.load(std::memory_order_relaxed); }

  // View side: swaps everything offered since the last drain into `into` (its old contents are reused).
  void drain(FeedBatch& into);

  [[nodiscard]] FeedCounters counters() const;
  [[nodiscard]] const FeedLimits& limits() const { return limits_; }

 private:
  FeedLimits limits_;
  mutable std::mutex mutex_;
  FeedBatch pending_;
  std::atomic<bool> want_full_{false};
  FeedCounters counters_;
};

}  // namespace teamscan::view
