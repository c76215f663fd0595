// The ground station's live fusion stage (issue 5): every received pose feeds a Kalman tracker, every
// received scan goes into the configured filter (observe + classify, live) and an incremental voxel map
// for teamscan/map; the fused model is written as PCD by the offline path of `teamscan eval` over
// everything received so far (docs/groundstation.md "Live vs offline").
// It runs from Station hooks, after the sample is stored: a failure here never loses a received sample.
#pragma once

#include <array>
#include <cstdint>
#include <cstdio>
#include <functional>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "common/dataset/dataset.hpp"
#include "common/result.hpp"
#include "groundstation/mapping/filter.hpp"
#include "groundstation/mapping/tracker.hpp"
#include "groundstation/mapping/voxel_map.hpp"
#include "groundstation/station/latency_histogram.hpp"
#include "groundstation/station/scan_record.hpp"
#include "groundstation/station/team_source.hpp"

struct teamscan_msg_MapVoxel;

namespace teamscan::station {

struct FusionOptions {
  // One of mapping::known_methods(); default the paper's combined method (direction 7°, then
  // visibility 0.1 m, PAPER_NOTES 8 / Table 6).
  std::string method = "combined";
  mapping::MethodOptions methods;
  mapping::TrackerOptions tracker;
  // Voxel edge of the teamscan/map updates (metres).
  double map_resolution_m = 0.1;
  // File names inside the session folder. `all_points_pcd` empty: not written.
  std::string kept_pcd = "fused.pcd";
  std::string all_points_pcd;
  // Sub-folder of the session written on shutdown with everything received as a data set; empty: none.
  std::string received_dataset = "received";
  // Per-scan latency histograms (scan stamp -> taken from DDS, scan stamp -> in the fused map), written
  // by write_latency(); empty: not written.
  std::string latency_csv = "latency.csv";
  // Per fused scan a line `robot,seq,stamp_ns,received_ns,fused_ns` (CLOCK_REALTIME), through one stdio
  // buffer (no allocation per scan); empty: none. For measuring a time window (the demo's run).
  std::string latency_log_csv;
  // A scan seq up to this far below a robot's newest is a replay of its DDS history (fused already, or
  // late); further below, a restarted robot. As the station's dds.scan_history_depth (at most 1023).
  std::uint32_t replay_window = 300;
  // Points reserved up front for everything received (kept in memory for the model writes). Growing a
  // vector of millions of points by doubling copied up to ~200 MB inside the receive loop and held scans
  // back for hundreds of ms at 32 robots (docs/demo.md "Scale"); a reservation costs address space only,
  // pages are touched as points arrive. 16 M points ≈ 37 s of 32 robots at 75 Hz; beyond it, doubling.
  std::size_t reserve_points = 16u << 20;
  // true: every received point stays in memory (received(), write_model(), write_received_dataset();
  // the unit tests). false (the daemon): the loop keeps only the live map, the tracker and the newest
  // kLivePosesPerRobot poses per robot; the model and the data set are built from the session files by
  // ModelWriter (model_writer.hpp), so the loop's memory does not grow with the session.
  bool keep_received = true;
};

// What the loop keeps of a robot's poses when keep_received is false: the live own pose of a scan is
// its newest pose at or before the scan's stamp, and scans arrive within ~1 s of their poses (10 Hz).
inline constexpr std::size_t kLivePosesPerRobot = 256;

// Everything received as a data set, built one sample at a time in arrival order: the same code feeds
// the live stage (FusionStage) and the model writer reading the session files back (model_writer.hpp),
// so the model written from disk equals the one built from memory by construction.
class ReceivedBuilder {
 public:
  ReceivedBuilder(bool keep, std::uint32_t replay_window, std::size_t reserve_points);
  void add_pose(const PoseObservation& pose);
  // Converts the scan (record + model points in `points`/`flags`). false: a replay of a (robot, seq)
  // seen recently (kSeqWindow), not to be fused again. Appends to dataset() when keeping.
  bool add_scan(const StoredScan& scan, ScanRecord& rec, std::vector<mapping::MapPoint>& points,
                std::vector<std::uint16_t>& flags);
  // Recomputes every scan's own pose from all poses received (a pose may arrive after its scan).
  void refresh_scan_poses();
  // The robot's own pose at `stamp_ns`: its newest pose stamped at or before, moved on with its velocity.
  [[nodiscard]] Pose2 own_pose(std::uint32_t robot, std::int64_t stamp_ns, double origin_x_m, double origin_y_m) const;
  [[nodiscard]] Dataset& dataset() { return received_; }
  [[nodiscard]] const Dataset& dataset() const { return received_; }
  [[nodiscard]] std::size_t poses_held() const;

 private:
  bool seen_before(std::uint32_t robot, std::uint32_t seq);
  bool keep_;
  std::uint32_t replay_window_;
  Dataset received_;
  std::vector<std::vector<PoseObservation>> poses_by_robot_;  // index robot id, stamp order as received
  // Per robot: the newest seq fused and a bitmap of the kSeqWindow seqs up to it (bit k = newest − k).
  static constexpr std::uint32_t kSeqWindow = 1024;  // > the robots' scan history (300, dds.scan_history_depth)
  struct SeqWindow {
    bool any = false;
    std::uint32_t newest = 0;
    std::array<std::uint64_t, kSeqWindow / 64> seen{};
  };
  std::vector<SeqWindow> seq_windows_;
};

// The offline pass (prepare_dataset + run_offline, the code of `teamscan eval`) over `received`, written
// as binary PCD(s) into `dir` (NAME.tmp then rename(2)). `live_removed`: the live decision per point
// (fused_all.pcd's live_keep; empty: all kept). `removed` receives the offline decisions.
struct ModelFigures {
  std::uint64_t kept = 0;
  std::uint64_t removed = 0;
};
[[nodiscard]] Status write_fused_model(Dataset& received, const FusionOptions& options, const std::string& dir,
                                       std::span<const std::uint8_t> live_removed, std::vector<std::uint8_t>& removed,
                                       ModelFigures& figures, const std::function<bool()>& cancelled = {});
// Writes `received` (with its robots listed and the odometry as truth) as a data set folder.
[[nodiscard]] Status write_received_as_dataset(Dataset& received, const std::string& dir);

struct FusionCounters {
  std::uint64_t scans = 0;
  std::uint64_t poses = 0;
  std::uint64_t points = 0;
  std::uint64_t live_removed = 0;     // points the live classification removed at arrival
  std::uint64_t duplicates = 0;       // scans received again (DDS history replay): stored, not fused twice
  std::uint64_t writes = 0;           // fused PCDs written
  std::uint64_t write_failures = 0;
  std::uint64_t last_write_kept = 0;  // points in the last fused PCD
  std::uint64_t last_write_removed = 0;
};

struct FusionConfig;
struct KalmanConfig;
// The daemon's [fusion] and [team.kalman] config as FusionOptions (the tracker is the team source's).
[[nodiscard]] FusionOptions fusion_options_from_config(const FusionConfig& fusion, const KalmanConfig& kalman);

class FusionStage {
 public:
  // Fails if `options.method` is not a known method.
  [[nodiscard]] static Result<std::unique_ptr<FusionStage>> create(const FusionOptions& options,
                                                                   std::string session_dir);

  // Hooks (Station::add_pose_hook / add_scan_hook). A scan whose (robot, seq) was fused recently (within
  // kSeqWindow) is a replay of the robots' DDS history: counted in `duplicates`, not fused again.
  void add_pose(const PoseObservation& pose);
  void add_scan(const StoredScan& scan);

  // Runs the offline path (prepare_dataset + run_offline, the code of `teamscan eval`) over every
  // received scan and writes the kept points (and optionally all points with a `keep` field) as
  // binary PCD: written to NAME.tmp, then rename(2), so a reader never sees a half file.
  // Needs keep_received (else an Error: the daemon writes through ModelWriter from the session files).
  [[nodiscard]] Status write_model();
  // Writes everything received as a data set folder (common/dataset: points.pcd, scans.csv, odom.csv,
  // ...; no labels), so `teamscan eval DIR --method M` reproduces the fused model's decisions offline.
  [[nodiscard]] Status write_received_dataset(const std::string& dir);
  // Writes the latency histograms (options().latency_csv) into the session folder, atomically.
  [[nodiscard]] Status write_latency() const;
  // Scan stamp (end of sweep, CLOCK_REALTIME) -> the scan classified and inserted into the live map, and
  // scan stamp -> taken from DDS (the station stores it right then, before fusion), one sample per scan.
  [[nodiscard]] const LatencyHistogram& fused_latency() const { return fused_latency_; }
  [[nodiscard]] const LatencyHistogram& stored_latency() const { return stored_latency_; }
  // The live classification at arrival, per point in received().points order (1 = removed). Kept when
  // keep_received is true or fused_all.pcd is written (its live_keep column); else empty.
  [[nodiscard]] const std::vector<std::uint8_t>& live_removed() const { return live_removed_points_; }
  // Removed flags of the last write_model(), in received().points order.
  [[nodiscard]] const std::vector<std::uint8_t>& last_removed() const { return last_removed_; }

  // The occupied voxels of the live map as teamscan/map voxels (flags 1: every point in the voxel
  // was removed by the live classification). Returns the number written to `out`.
  void map_voxels(std::vector<teamscan_msg_MapVoxel>& out) const;
  // Only the voxels that changed (new points) since the last call or clear_map_changes(), with their
  // whole counts and flags (a viewer replaces its voxel), then forgets them: teamscan/map's work per
  // publication is the change, not the map (issue 6). total: map_total_voxels().
  void map_voxels_changed(std::vector<teamscan_msg_MapVoxel>& out);
  void clear_map_changes() { map_touched_.clear(); }
  [[nodiscard]] std::uint32_t map_total_voxels() const {
    return static_cast<std::uint32_t>(map_all_.occupied_voxels());
  }
  [[nodiscard]] std::uint32_t map_resolution_mm() const;

  // Everything received, as a data set (points in mm-exact metres, scan = seq, pose at the stamp).
  [[nodiscard]] const Dataset& received() const { return received_.dataset(); }
  // Poses the stage holds (bounded by kLivePosesPerRobot per robot when keep_received is false).
  [[nodiscard]] std::size_t poses_held() const { return received_.poses_held(); }
  [[nodiscard]] const FusionCounters& counters() const { return counters_; }
  [[nodiscard]] const FusionOptions& options() const { return options_; }

 private:
  FusionStage(const FusionOptions& options, std::string session_dir, std::unique_ptr<mapping::Filter> live);

  FusionOptions options_;
  std::string session_dir_;
  std::unique_ptr<mapping::Filter> live_;
  mapping::TeamTracker tracker_;
  mapping::VoxelMap map_all_;
  mapping::VoxelMap map_kept_;
  mapping::VoxelMap map_touched_;  // voxels with new points since the last teamscan/map publication
  ReceivedBuilder received_;
  std::vector<mapping::MapPoint> scratch_points_;
  std::vector<std::uint16_t> scratch_flags_;
  std::vector<std::uint8_t> scratch_removed_;
  std::vector<std::uint8_t> last_removed_;
  std::vector<std::uint8_t> live_removed_points_;  // grows with received_.points (amortised, as they do)
  LatencyHistogram fused_latency_;
  LatencyHistogram stored_latency_;
  FusionCounters counters_;
  std::FILE* latency_log_ = nullptr;
  bool keep_live_ = false;  // live_removed_points_ kept (keep_received or fused_all.pcd)

 public:
  ~FusionStage();
  FusionStage(const FusionStage&) = delete;
  FusionStage& operator=(const FusionStage&) = delete;
};

}  // namespace teamscan::station
