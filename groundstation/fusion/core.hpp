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
// The scans ready at once are released in stamp order (robot, seq on a tie), whatever their arrival
// order: the registration (optional) matches each released scan and corrects its robot's poses from
// the scan's stamp on (PoseHistory), so its state must follow the same sequence live and offline.
// The map is a sum over the released scans, so its state and every map part are the same live and
// offline.
//
// Memory is bounded by the mapped space, not the mission: the map, the poses of the last keep_s, the
// scans held (hold_s), and the model store: at most `max_points_per_voxel` points per model voxel.
#pragma once

#include <array>
#include <cstdint>
#include <functional>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "common/capacities.hpp"
#include "common/laser_geometry.hpp"
#include "common/result.hpp"
#include "groundstation/fusion/model_store.hpp"
#include "groundstation/fusion/model_writer.hpp"
#include "groundstation/fusion/pose_history.hpp"
#include "groundstation/mapping/filter.hpp"
#include "common/flat_key_map.hpp"
#include "groundstation/registration/registration.hpp"

namespace teamscan::fusion {

class ScanMoves;  // model_move.hpp

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
  // The model store (model_store.hpp): points kept per voxel of this edge. Beyond the cap a voxel's
  // further points are counted (`capped_points`) and not stored: the model is bounded by the mapped
  // space; the session files keep every point. 8 per 5 cm voxel = 3 200 points per m² of surface,
  // ~200 bytes a full voxel (docs/groundstation.md "Memory"). 0: no model store (`teamscan eval` keeps
  // its own per-point bits).
  double model_resolution_m = 0.05;
  std::uint32_t max_points_per_voxel = 8;
  // Scan-to-map registration (docs/registration.md), off by default (odometry alone): every released
  // scan is matched against the team's map and its robot's correction map_from_odom is set in the
  // pose history from the scan's stamp on, so this scan, the later ones, the team state the filters
  // use and the model are corrected. Teammates' bodies are masked with the `tracked` filter's box
  // (methods.tracked).
  bool registration = false;
  registration::RegistrationOptions registration_options{};
  // With the registration, scans are released in stamp order: a scan waits until no earlier-stamped one
  // can still arrive, i.e. until every robot still sending scans has sent one stamped later than it
  // minus this interval (a robot's scans arrive in order, each stamped at least this long after the one
  // before). The LMS-200's mirror turns 75 times a second, a scan every 13.3 ms or more; half of that
  // leaves room for the stamps' jitter. 0: wait for a scan stamped at or after it (up to a scan period
  // more). A scan stamped closer to its predecessor is released out of order (counted).
  double min_scan_interval_s = to_seconds(kLmsRevolution) / 2;
  // Scans released in stamp order (as with the registration, by min_scan_interval_s) without the
  // registration too: a pose graph fed the releases (graph_backend.hpp) has the release order as its
  // state. Whoever gives a core a graph sets it (with_graph_order), so a core rebuilt without the
  // registration on the graph's poses releases in the order the first one did.
  bool stamp_order = false;
  // Each released scan also carries the team as the robots' odometry alone places it
  // (FusedScan::odom_team, from a second pose history the corrections never touch): a pose graph takes
  // its returns in the odometry's frame and leaves the teammates out with it, so what the graph is given
  // does not depend on the corrections in force (the registration's, or the graph's own once the map
  // follows it).
  bool odometry_team = false;
};

// `o` as a core that feeds a pose graph runs: stamp_order and odometry_team set.
[[nodiscard]] inline CoreOptions with_graph_order(CoreOptions o) {
  o.stamp_order = true;
  o.odometry_team = true;
  return o;
}

// One scan as the core takes, holds and releases it: who measured it, its sequence number and stamp,
// its sensor origin and map-frame points before map_from_odom in metres with their onboard flags in the
// data set's vocabulary (common/point_flags.hpp) and their beams, and when it arrived. Made once per
// source: the station's scan_input from a stored scan, the evaluation from a data set's scan. It owns
// its points: the core keeps a copy until the scan is released (in a reused slot, without allocating
// once the slots have grown), corrects it in place, and shows it to the filters and the release
// callback through view(), which it completes with the scan's pose and team state.
struct ScanInput {
  std::uint8_t robot = 0;       // 1..kMaxRobots: checked where the scan entered (the station's sample
                                // validation, the data set and session readers), not again here
  std::uint32_t scan = 0;       // the robot's sequence number
  std::int64_t stamp_ns = 0;
  Vec3 origin_m;                // sensor origin, map frame
  std::int64_t arrival_ns = 0;  // offline: the stamp
  std::vector<mapping::MapPoint> points;
  std::vector<std::uint16_t> flags;  // empty or one per point
  std::vector<std::uint16_t> beams;  // empty or one per point
  // The filters' view of it: robot, seq, stamp, origin, points and flags (map_from_robot and team unset).
  [[nodiscard]] mapping::ScanView view() const {
    mapping::ScanView v;
    v.robot = robot;
    v.scan = scan;
    v.stamp_ns = stamp_ns;
    v.origin_m = origin_m;
    v.points = points;
    v.flags = flags;
    return v;
  }
};

// A released scan, as the core decided it (handed to the release callback).
struct FusedScan {
  const mapping::ScanView* view = nullptr;    // the released ScanInput's view, with its pose and team
  Pose2 map_from_odom;                        // the correction its points and origin were moved by (identity: none)
  Pose2 odom_from_robot;                      // its pose before the correction (the robot's odometry)
  std::span<const mapping::MapPoint> odom_points;  // its points before the correction, as the robot placed them
  Vec3 odom_origin_m;                         // its sensor origin before the correction
  // The teammates as their odometry alone places them at its stamp (CoreOptions::odometry_team; else
  // nullptr), in the frame of odom_points.
  const mapping::TeamState* odom_team = nullptr;
  std::int64_t arrival_ns = 0;
  bool forced = false;                        // released by hold_s, not by the poses
  std::span<const std::uint16_t> beams;
  std::span<const std::uint8_t> bits;         // the point part per point
  std::span<const std::uint8_t> removed;      // the decision at release (map so far)
  // Per point: 1 if it was stored in the model store (not capped, finite); empty without a model store
  // (CoreOptions::max_points_per_voxel 0). The stored points are the fused model's.
  std::span<const std::uint8_t> stored;
  // The core's instant: this scan is the release-th released (CoreCounters::scans_released after it).
  std::uint64_t release = 0;
};

struct CoreCounters {
  std::uint64_t scans_in = 0;
  std::uint64_t duplicate_scans = 0;   // (robot, seq) fused recently: a DDS history replay
  std::uint64_t scans_released = 0;
  std::uint64_t scans_forced = 0;      // released by hold_s
  // Released after a scan stamped later (with the registration: it arrived later than the release
  // order allowed for, e.g. stamped closer to its predecessor than min_scan_interval_s).
  std::uint64_t scans_out_of_stamp_order = 0;
  // Of those, released stamped more than hold_s before a scan released earlier: a scan that arrived after
  // the core had moved on past its stamp (a robot's back-fill after a radio shadow), not a transport's
  // jitter of a few milliseconds. The station catches up after them (station/fusion.hpp).
  std::uint64_t scans_late = 0;
  std::uint64_t poses_in = 0;
  // Poses stamped more than hold_s before a scan released earlier: the scans of their time were decided
  // without them (a robot's pose back-fill after a radio shadow). The station catches up after them too.
  std::uint64_t poses_late = 0;
  std::uint64_t poses_rejected = 0;    // duplicates, bad ids, non-finite
  std::uint64_t points = 0;
  std::uint64_t removed_at_release = 0;
  std::uint64_t stored_points = 0;
  std::uint64_t capped_points = 0;
  std::uint64_t registration_masked_points = 0;  // kept out of the match (onboard-flagged, teammates' bodies)
  std::uint64_t registration_corrections = 0;    // corrections set in the pose history
};

// The core's figures for one robot: its scans released, their points and their decisions at release.
struct RobotCounters {
  std::uint64_t scans_released = 0;
  std::uint64_t points = 0;
  std::uint64_t removed_at_release = 0;  // points of this robot's scans removed when released
  std::uint64_t stored_points = 0;       // points of this robot's scans in the model store
};

class FusionCore {
 public:
  // Fails on an unknown method or bad options.
  [[nodiscard]] static Result<std::unique_ptr<FusionCore>> create(const CoreOptions& options);

  void add_pose(const PoseInput& pose);
  // false: a replay of a (robot, seq) fused recently, not fused again. The scan is copied (the caller
  // may reuse it at once).
  bool add_scan(const ScanInput& scan);
  // Releases every held scan (end of the data; shutdown).
  void flush();
  // The arrival clock moved on without a sample (the station's loop, idle): scans that waited hold_s
  // are released. Offline there is no idle time: the next sample or flush() does it.
  void advance_to(std::int64_t arrival_ns);
  // The arrival clock jumped (a restarted station resumes after replaying its session): the held scans
  // and the robots' last pose arrivals count from `arrival_ns`, so the outage itself forces nothing.
  void resume_at(std::int64_t arrival_ns);

  // Back to a fresh core with the same options, as create() makes it (the station's catch-up replays
  // its session into it): held scans, poses, map, model store and registration dropped, the release
  // callback kept. The object stays, so references to it and to its pose history stay valid.
  [[nodiscard]] Status reset();
  // Takes over `other`'s whole state (held scans, poses, map, model store, registration, counters), its
  // release callback excepted: this object keeps its own, and references to it and to its pose history
  // stay valid (the station's catch-up built `other` from its session while this one ran live). This
  // core's old state goes to `other` (without a release callback), so its owner decides where the old
  // state's memory is freed (the station: off its loop).
  void take_state(FusionCore& other);

  // Called for every released scan, in release order.
  void set_release_callback(std::function<void(const FusedScan&)> f) { on_release_ = std::move(f); }

  // The decision now for points with their bits (the map part read from the map as it is).
  void decide(std::span<const mapping::MapPoint> points, std::span<const std::uint8_t> bits,
              std::span<std::uint8_t> removed) const {
    filter_->decide(points, bits, removed);
  }
  // Every stored point with its decision now (f(const ModelPoint&, bool removed)), voxel by voxel.
  void for_each_model_point(const std::function<void(const ModelPoint&, bool removed)>& f) const;
  // The model store in parts, so a loop can spread a write over several turns: appends the model voxels
  // [from, min(from + count, model_voxels())) with their decisions now to `out` and returns the next
  // voxel to take. Voxels are never removed or reordered, so a model taken in parts holds every point
  // stored before it started (each voxel's decisions as of the part that took it).
  std::size_t snapshot_model_part(ModelSnapshot& out, std::size_t from, std::size_t count) const;

  // The model moved rigidly with the pose graph (model_move.hpp; the station's live map following the
  // graph): begin_model_move() starts a new model store (the same cap per voxel) that takes the points of
  // every scan released from then on (placed where `moves` lead: the caller set the corrections first);
  // continue_model_move() moves the old store's points into it, each by its scan's move, at most `voxels`
  // voxels a call (a point the new store caps is dropped and counted in capped_points; `on_moved` is
  // called with each one it keeps); once every voxel is moved, the new store takes the old one's place
  // and the old one goes to `old` (for the caller to free where it likes): true. Until then the model's
  // readers (for_each_model_point, snapshot_model_part, model_voxels) read the old store, which lacks
  // the scans released since the move began. The filters' map and every point's bits stay as they are.
  // `store`: the new store, made (and reserved: ModelStore::reserve) off the loop by the caller; none: made here.
  void begin_model_move(std::shared_ptr<const ScanMoves> moves, std::unique_ptr<ModelStore> store = nullptr);
  bool continue_model_move(std::size_t voxels, std::unique_ptr<ModelStore>& old,
                           const std::function<void(const ModelPoint&)>& on_moved = {});
  [[nodiscard]] bool moving_model() const { return moving_ != nullptr; }
  // The newest stamp of a scan released so far (INT64_MIN: none): a correction set after it places only
  // scans still to be released (held or to come; a late one excepted).
  [[nodiscard]] std::int64_t newest_released_stamp_ns() const { return newest_released_stamp_ns_; }

  [[nodiscard]] PoseHistory& poses() { return poses_; }
  [[nodiscard]] const PoseHistory& poses() const { return poses_; }
  [[nodiscard]] const mapping::Filter& filter() const { return *filter_; }
  // The registration (nullptr when CoreOptions::registration is off).
  [[nodiscard]] const registration::Registration* registration() const { return registration_.get(); }
  [[nodiscard]] const CoreCounters& counters() const { return counters_; }
  // Robot 1..kMaxRobots (any other id: index 0, the scans released without a valid robot id).
  [[nodiscard]] const RobotCounters& robot_counters(std::uint32_t robot) const {
    return robot_counters_[robot <= kMaxRobots ? robot : 0];
  }
  [[nodiscard]] const CoreOptions& options() const { return options_; }
  [[nodiscard]] std::size_t held_scans() const { return held_.size(); }
  // True if (robot, scan) is held (not released yet).
  [[nodiscard]] bool holds(std::uint8_t robot, std::uint32_t scan) const;
  [[nodiscard]] std::size_t model_voxels() const { return model_.voxels(); }
  [[nodiscard]] std::size_t model_memory_bytes() const {
    return model_.memory_bytes() + (moving_ ? moving_->store->memory_bytes() : 0);
  }
  // The filter's map state (voxel counts, free-space grid), bytes.
  [[nodiscard]] std::size_t map_memory_bytes() const { return filter_->memory_bytes(); }

 private:
  FusionCore(const CoreOptions& options, std::unique_ptr<mapping::Filter> filter);
  FusionCore(FusionCore&&) = default;             // take_state()
  FusionCore& operator=(FusionCore&&) = default;  // reset(), take_state()
  // A held scan in the queue: what release_ready() tests, and its slot. Small, so that a pass over a
  // long queue (a station catching up holds thousands) and taking the ready ones out stay cheap.
  struct Held {
    std::int64_t stamp_ns;
    std::int64_t arrival_ns;
    std::uint32_t scan;
    std::uint32_t slot;  // in slots_: the held copy of the scan
    std::uint8_t robot;
    bool forced;  // released by hold_s (set when it is released)
  };
  bool seen_before(std::uint8_t robot, std::uint32_t seq);
  void release_ready(std::int64_t now_arrival_ns, bool all);
  void release(ScanInput& s, std::int64_t arrival_ns, bool forced);
  void store(const ScanInput& s);
  void decide_voxel(std::size_t k, std::vector<ModelPoint>& points, std::vector<mapping::MapPoint>& pts,
                    std::vector<std::uint8_t>& bits, std::vector<std::uint8_t>& removed) const;
  void register_scan(const ScanInput& s);

  CoreOptions options_;
  std::unique_ptr<mapping::Filter> filter_;
  PoseHistory poses_;
  PoseHistory odometry_poses_;  // the same poses, never corrected (CoreOptions::odometry_team; else empty)
  std::vector<Held> held_;  // arrival order
  // The held scans' copies, reused: a released scan's vectors keep their capacity for the next one.
  std::vector<ScanInput> slots_;
  std::vector<std::uint32_t> free_slots_;
  std::int64_t newest_arrival_ns_ = INT64_MIN;
  std::int64_t first_arrival_ns_ = INT64_MIN;
  std::int64_t newest_released_stamp_ns_ = INT64_MIN;
  std::array<std::int64_t, kMaxRobots + 1> last_pose_arrival_ns_{};
  // Per robot: its newest scan's stamp and the arrival of its last scan (the scan watermark, used with
  // the registration: release_ready).
  std::array<std::int64_t, kMaxRobots + 1> newest_scan_stamp_ns_ = filled(INT64_MIN);
  std::array<std::int64_t, kMaxRobots + 1> last_scan_arrival_ns_ = filled(INT64_MIN);
  static constexpr std::array<std::int64_t, kMaxRobots + 1> filled(std::int64_t v) {
    std::array<std::int64_t, kMaxRobots + 1> a{};
    a.fill(v);
    return a;
  }
  std::function<void(const FusedScan&)> on_release_;
  // Per robot: the newest seq fused and a bitmap of the kSeqWindow seqs up to it (bit k = newest − k).
  static constexpr std::uint32_t kSeqWindow = 1024;
  struct SeqWindow {
    bool any = false;
    std::uint32_t newest = 0;
    std::array<std::uint64_t, kSeqWindow / 64> seen{};
  };
  std::vector<SeqWindow> seq_windows_;
  ModelStore model_;
  // A move of the model under way (begin_model_move): the new store and the next old voxel to move.
  struct ModelMove {
    std::shared_ptr<const ScanMoves> moves;
    std::unique_ptr<ModelStore> store;
    std::size_t next_voxel = 0;
    std::array<std::uint64_t, kMaxRobots + 1> robot_points{};  // per robot: its points in the new store
  };
  std::unique_ptr<ModelMove> moving_;
  std::uint64_t capped_before_ = 0;  // points capped by model stores a move replaced
  std::unique_ptr<registration::Registration> registration_;
  // Scratch of a release.
  std::vector<std::uint8_t> bits_, removed_, stored_;
  std::vector<mapping::MapPoint> odom_points_;  // the released scan's points before its correction
  std::vector<ModelPoint> model_points_;  // store()'s scratch
  std::vector<Held> releasing_;
  std::vector<Vec3> registration_points_;
  std::vector<std::uint8_t> registration_usable_;
  std::vector<mapping::MapPoint> registration_corrected_;  // register_scan's points in the corrected frame
  CoreCounters counters_;
  std::array<RobotCounters, kMaxRobots + 1> robot_counters_{};
};

}  // namespace teamscan::fusion
