// ViewHub: the view's own copy of what the station handed it (hub = the server thread's state, no I/O):
// the live map's voxels with the robot each came from, every robot's track, the newest team snapshots.
// It turns each drained FeedBatch into the messages every client gets (changed voxels, state), and builds
// the whole state for a client that is new or skipped. Its memory is the map's voxels (as the station's
// map), tracks capped per robot, and a fixed number of recent states.
#pragma once

#include <cstddef>
#include <cstdint>
#include <deque>
#include <optional>
#include <string>
#include <unordered_map>
#include <utility>
#include <vector>

#include "groundstation/view/feed.hpp"
#include "groundstation/view/protocol.hpp"

namespace teamscan::view {

struct HubOptions {
  std::uint32_t map_resolution_mm = 100;  // the station's live map voxel edge ([fusion] map_resolution_m)
  std::int32_t track_step_mm = 20;        // a track point when the robot moved this far
  std::size_t track_max_points = 4096;    // per robot; beyond, the track is thinned to every other point
  std::size_t state_history = 64;         // recent states answered by /api/state?seq=N
  double scan_rate_window_s = 1.0;
};

struct HubCounters {
  std::uint64_t batches = 0;
  std::uint64_t states = 0;
  std::uint64_t voxels_changed = 0;
  std::uint64_t whole_maps = 0;  // whole maps taken from the station (after a feed overflow)
  std::uint64_t replacing_maps = 0;  // ... of which left out voxels held (the map decided again): sent whole
  std::uint64_t tap_scans = 0;
};

class ViewHub {
 public:
  explicit ViewHub(HubOptions options = {});

  // Applies one drained batch (tap scans first, then voxels, then the snapshot) and appends to `out` the
  // messages for every client: the changed voxels (if any), then the state (if a snapshot came).
  void apply(const FeedBatch& batch, std::vector<SharedMessage>& out);
  // The whole map and the whole state with complete tracks, for a new or skipped client.
  void whole(std::vector<SharedMessage>& out) const;
  // /api/state: the newest state (no tracks), or state `seq` while still held; nullopt if none.
  [[nodiscard]] std::optional<std::string> state_json(std::optional<std::uint64_t> seq) const;

  // Calls f(const WireVoxel&) for every voxel in the map (hits > 0), removed ones included (flags bit 0).
  template <class F>
  void for_each_map_voxel(F&& f) const {
    for (const auto& entry : voxels_)
      if (entry.second.hits != 0) f(entry.second);
  }
  [[nodiscard]] std::size_t map_voxels() const { return in_map_; }
  [[nodiscard]] std::uint64_t state_seq() const { return seq_; }
  [[nodiscard]] const HubCounters& counters() const { return counters_; }
  // Heap held (voxels, tracks, states), approximately.
  [[nodiscard]] std::size_t memory_bytes() const;

 private:
  struct Track {
    std::vector<float> xy;
    std::size_t sent = 0;  // floats already in a state message
    bool resend = true;    // send the whole track in the next state message
  };
  struct RobotExtra {
    Track track;
    double rate_hz = 0.0;
    std::uint64_t rate_scans = 0;
    std::int64_t rate_stamp_ns = 0;
  };
  [[nodiscard]] std::uint64_t key_of(std::int32_t x_mm, std::int32_t y_mm, std::int32_t z_mm) const;
  // The map's voxels, every one with hits, as one whole-map message.
  [[nodiscard]] SharedMessage whole_map_message() const;
  void add_track_point(RobotExtra& r, double x_m, double y_m);
  [[nodiscard]] std::vector<RobotView> robot_views(bool whole_tracks) const;
  [[nodiscard]] StateHeader header(bool whole) const;

  HubOptions options_;
  std::unordered_map<std::uint64_t, WireVoxel> voxels_;  // hits 0: attributed to a robot, not in the map yet
  std::size_t in_map_ = 0;
  std::vector<RobotExtra> extra_;  // index robot id
  std::optional<TeamSnapshot> latest_;
  std::uint64_t seq_ = 0;
  std::deque<std::pair<std::uint64_t, std::string>> history_;
  std::vector<WireVoxel> changed_scratch_;
  HubCounters counters_;
};

}  // namespace teamscan::view
