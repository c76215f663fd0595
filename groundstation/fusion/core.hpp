// The fusion core (DESIGN.md "groundstation/fusion"): the one path from received scans and poses to
// every point's decision and the fused model, run by the ground station on live data and by
// `teamscan eval` on a data set in time order. Same input, same decisions, bit for bit.
//
//   scan in ─▶ held until its team state is complete ─▶ pose + team (PoseHistory) ─▶ point part
//   (robot-based filters, decided once) ─▶ map (map-based filters: counts, order-free) ─▶ model store
//
// A point's decision = its point part (decided when its scan is released, from the scan's pose and the
// team at the scan's time) combined with its map part, read from the map whenever the decision is
// asked for (mapping::Filter::decide). A scan is released when its own robot and every robot the core
// knows have a pose stamped at or after the scan less the decision lag (tracker.team_lag_s, 0 by
// default: PoseHistory::cutoff) (so the team at its time is final whatever order the
// poses came in; a robot silent for hold_s of arrival time no longer counts), or when it has waited
// `hold_s` of arrival time; nothing is released in the first hold_s (the team is being discovered).
// The map is a sum over the released scans, so its state and every map part are the same live and
// offline.
//
// Memory is bounded by the mapped space, not the mission: the map, the poses of the last keep_s, the
// scans held (hold_s), and the model store: at most `max_points_per_voxel` points per model voxel.
#pragma once

#include <array>
#include <cstdint>
#include <deque>
#include <functional>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "common/capacities.hpp"
#include "common/result.hpp"
#include "groundstation/fusion/pose_history.hpp"
#include "groundstation/mapping/filter.hpp"
#include "groundstation/mapping/flat_key_map.hpp"

namespace teamscan::fusion {

struct CoreOptions {
  // One of mapping::known_methods() / extended_methods(), with its options.
  std::string method = "best";
  mapping::MethodOptions methods;
  mapping::TrackerOptions tracker;
  // A scan waits at most this long (arrival clock) for every known robot's poses to pass its stamp.
  // 0: every scan is decided at arrival with the poses there are (no longer the same as offline when
  // a pose arrives after a scan stamped later than it).
  double hold_s = 1.0;
  // Poses kept per robot behind its newest (PoseHistoryOptions::keep_s).
  double pose_keep_s = 30.0;
  // The model store: points kept per voxel of this edge. Beyond the cap a voxel's further points are
  // counted (`capped_points`) and not stored: the model is bounded by the mapped space; the session
  // files keep every point. 0: no model store (`teamscan eval` keeps its own per-point bits).
  double model_resolution_m = 0.05;
  std::uint32_t max_points_per_voxel = 64;
};

// One scan as the core takes it: map-frame points (before map_from_odom), their onboard flags
// (common/dataset point_flags) and beam indices.
struct ScanInput {
  std::uint8_t robot = 0;
  std::uint32_t seq = 0;
  std::int64_t stamp_ns = 0;
  std::int64_t arrival_ns = 0;  // offline: the stamp
  Vec3 origin_m;
  std::span<const mapping::MapPoint> points;
  std::span<const std::uint16_t> flags;  // empty or one per point
  std::span<const std::uint16_t> beams;  // empty or one per point
};

// A released scan, as the core decided it (handed to the release callback).
struct FusedScan {
  std::uint8_t robot = 0;
  std::uint32_t seq = 0;
  std::int64_t stamp_ns = 0;
  std::int64_t arrival_ns = 0;
  bool forced = false;                        // released by hold_s, not by the poses
  const mapping::ScanView* view = nullptr;    // pose, team, points (map frame), flags
  std::span<const std::uint16_t> beams;
  std::span<const std::uint8_t> bits;         // the point part per point
  std::span<const std::uint8_t> removed;      // the decision at release (map so far)
};

// A point of the model store.
struct ModelPoint {
  mapping::MapPoint p;
  std::uint32_t seq = 0;
  std::uint16_t beam = 0;
  std::uint8_t robot = 0;
  std::uint8_t bits = 0;
  std::uint8_t removed_at_release = 0;
};

struct CoreCounters {
  std::uint64_t scans_in = 0;
  std::uint64_t duplicate_scans = 0;   // (robot, seq) fused recently: a DDS history replay
  std::uint64_t scans_released = 0;
  std::uint64_t scans_forced = 0;      // released by hold_s
  std::uint64_t poses_in = 0;
  std::uint64_t poses_rejected = 0;    // duplicates, bad ids, non-finite
  std::uint64_t points = 0;
  std::uint64_t removed_at_release = 0;
  std::uint64_t stored_points = 0;
  std::uint64_t capped_points = 0;
};

class FusionCore {
 public:
  // Fails on an unknown method or bad options.
  [[nodiscard]] static Result<std::unique_ptr<FusionCore>> create(const CoreOptions& options);

  void add_pose(const PoseInput& pose);
  // false: a replay of a (robot, seq) fused recently, not fused again.
  bool add_scan(const ScanInput& scan);
  // Releases every held scan (end of the data; shutdown).
  void flush();
  // The arrival clock moved on without a sample (the station's loop, idle): scans that waited hold_s
  // are released. Offline there is no idle time: the next sample or flush() does it.
  void advance_to(std::int64_t arrival_ns);
  // The arrival clock jumped (a restarted station resumes after replaying its session): the held scans
  // and the robots' last pose arrivals count from `arrival_ns`, so the outage itself forces nothing.
  void resume_at(std::int64_t arrival_ns);

  // Called for every released scan, in release order.
  void set_release_callback(std::function<void(const FusedScan&)> f) { on_release_ = std::move(f); }

  // The decision now for points with their bits (the map part read from the map as it is).
  void decide(std::span<const mapping::MapPoint> points, std::span<const std::uint8_t> bits,
              std::span<std::uint8_t> removed) const {
    filter_->decide(points, bits, removed);
  }
  // Every stored point with its decision now (f(const ModelPoint&, bool removed)), voxel by voxel.
  void for_each_model_point(const std::function<void(const ModelPoint&, bool removed)>& f) const;
  // Writes the model from memory: `kept_path` (kept points: x y z robot scan beam) and, if not empty,
  // `all_path` (every stored point, plus keep and live_keep), each NAME.tmp then rename(2).
  struct ModelFigures {
    std::uint64_t kept = 0, removed = 0;
  };
  [[nodiscard]] Result<ModelFigures> write_model(const std::string& kept_path, const std::string& all_path) const;

  [[nodiscard]] PoseHistory& poses() { return poses_; }
  [[nodiscard]] const PoseHistory& poses() const { return poses_; }
  [[nodiscard]] const mapping::Filter& filter() const { return *filter_; }
  [[nodiscard]] const CoreCounters& counters() const { return counters_; }
  [[nodiscard]] const CoreOptions& options() const { return options_; }
  [[nodiscard]] std::size_t held_scans() const { return held_.size(); }
  [[nodiscard]] std::size_t model_voxels() const { return voxel_index_.size(); }
  [[nodiscard]] std::size_t model_memory_bytes() const;

 private:
  FusionCore(const CoreOptions& options, std::unique_ptr<mapping::Filter> filter);
  struct HeldScan {
    std::uint8_t robot = 0;
    std::uint32_t seq = 0;
    std::int64_t stamp_ns = 0, arrival_ns = 0;
    Vec3 origin_m;
    std::vector<mapping::MapPoint> points;
    std::vector<std::uint16_t> flags, beams;
  };
  bool seen_before(std::uint8_t robot, std::uint32_t seq);
  [[nodiscard]] bool ready(const HeldScan& s) const;
  void release_ready(std::int64_t now_arrival_ns, bool all);
  void release(HeldScan& s, bool forced);
  void store(const HeldScan& s);

  CoreOptions options_;
  std::unique_ptr<mapping::Filter> filter_;
  PoseHistory poses_;
  std::deque<HeldScan> held_;  // arrival order
  std::int64_t newest_arrival_ns_ = INT64_MIN;
  std::int64_t first_arrival_ns_ = INT64_MIN;
  std::array<std::int64_t, kMaxRobots + 1> last_pose_arrival_ns_{};
  std::function<void(const FusedScan&)> on_release_;
  // Per robot: the newest seq fused and a bitmap of the kSeqWindow seqs up to it (bit k = newest − k).
  static constexpr std::uint32_t kSeqWindow = 1024;
  struct SeqWindow {
    bool any = false;
    std::uint32_t newest = 0;
    std::array<std::uint64_t, kSeqWindow / 64> seen{};
  };
  std::vector<SeqWindow> seq_windows_;
  // Model store: voxel (packed key at model_resolution_m) -> index in voxels_.
  mapping::FlatKeyMap<std::uint32_t> voxel_index_;
  std::vector<std::vector<ModelPoint>> voxels_;
  double inverse_model_resolution_ = 20.0;
  // Scratch of a release.
  std::vector<std::uint8_t> bits_, removed_;
  CoreCounters counters_;
};

}  // namespace teamscan::fusion
