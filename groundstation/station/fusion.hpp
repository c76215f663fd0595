// The ground station's fusion stage: the received samples converted into the fusion core's inputs
// (groundstation/fusion/core.hpp, the same core `teamscan eval` runs), the teamscan/map voxel maps fed
// from the core's released scans, the latency histograms, and the fused model written from the core's
// memory. It runs from Station hooks, after the sample is stored: a failure here never loses a
// received sample. After a restart it first replays its session folder through the core
// (session_replay.hpp), so it decides as it did before.
#pragma once

#include <cstdint>
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include "common/result.hpp"
#include "groundstation/fusion/core.hpp"
#include "groundstation/mapping/voxel_map.hpp"
#include "groundstation/station/latency_histogram.hpp"
#include "groundstation/station/scan_record.hpp"
#include "groundstation/station/team_source.hpp"

struct teamscan_msg_MapVoxel;

namespace teamscan::station {

struct FusionOptions {
  // The core: method (mapping::known_methods() / extended_methods()), its options, the tracker, the
  // hold time and the model store's cap (fusion/core.hpp CoreOptions).
  fusion::CoreOptions core;
  // Voxel edge of the teamscan/map updates (metres).
  double map_resolution_m = 0.1;
  // File names inside the session folder. `all_points_pcd` empty: not written.
  std::string kept_pcd = "fused.pcd";
  std::string all_points_pcd;
  // Per-scan latency histograms (scan stamp -> taken from DDS, scan stamp -> decided and in the fused
  // map), written by write_latency(); empty: not written.
  std::string latency_csv = "latency.csv";
  // Per fused scan a line `robot,seq,stamp_ns,received_ns,fused_ns` (CLOCK_REALTIME), through one stdio
  // buffer (no allocation per scan); empty: none. For measuring a time window (the demo's run).
  std::string latency_log_csv;
};

// A received pose / scan as the core's input (one conversion, used live and by the session replay).
[[nodiscard]] fusion::PoseInput pose_input(const PoseObservation& pose);
// Fills `points`/`flags`/`beams` with the scan's placed points (beams without a 3-D point are stored in
// scans.bin but are not part of the model) and returns the input viewing them.
struct ScanBuffers {
  std::vector<mapping::MapPoint> points;
  std::vector<std::uint16_t> flags, beams;
};
[[nodiscard]] fusion::ScanInput scan_input(const StoredScan& scan, ScanBuffers& buffers);

struct FusionCounters {
  std::uint64_t scans = 0;            // scans fused (released by the core)
  std::uint64_t poses = 0;
  std::uint64_t points = 0;
  std::uint64_t live_removed = 0;     // points removed at release (the map so far)
  std::uint64_t duplicates = 0;       // scans received again (DDS history replay): stored, not fused twice
  std::uint64_t replayed_scans = 0;   // scans of the session folder replayed at start-up
  std::uint64_t writes = 0;           // fused PCDs written
  std::uint64_t write_failures = 0;
  std::uint64_t last_write_kept = 0;  // points in the last fused PCD
  std::uint64_t last_write_removed = 0;
};

struct FusionConfig;
struct KalmanConfig;
struct RegistrationConfig;
// The daemon's [fusion], [team.kalman] and [registration] config as FusionOptions (the tracker is the
// team source's; without `registration`: its defaults).
[[nodiscard]] FusionOptions fusion_options_from_config(const FusionConfig& fusion, const KalmanConfig& kalman);
[[nodiscard]] FusionOptions fusion_options_from_config(const FusionConfig& fusion, const KalmanConfig& kalman,
                                                       const RegistrationConfig& registration);

class FusionStage {
 public:
  // Fails if the core's options are bad (unknown method, ...).
  [[nodiscard]] static Result<std::unique_ptr<FusionStage>> create(const FusionOptions& options,
                                                                   std::string session_dir);

  // Hooks (Station::add_pose_hook / add_scan_hook). A scan whose (robot, seq) was fused recently is a
  // replay of the robots' DDS history: counted in `duplicates`, not fused again.
  void add_pose(const PoseObservation& pose);
  void add_scan(const StoredScan& scan);
  // Rebuilds the core from the session folder's scans.bin and poses.csv (a restart): every sample in
  // arrival order through the same code, before the loop takes new ones. Returns the samples replayed.
  [[nodiscard]] Result<std::uint64_t> replay_session(const std::string& dir);
  // Releases every scan the core holds (shutdown).
  void flush() { core_->flush(); }
  // The loop's clock (CLOCK_REALTIME, the receive times' clock): held scans that waited long enough go.
  void tick(std::int64_t realtime_ns) {
    if (!resume_) core_->advance_to(realtime_ns);
  }

  // Writes the fused model from the core's memory into the session folder (fused.pcd, and fused_all.pcd
  // when configured): NAME.tmp then rename(2), so a reader never sees a half file.
  [[nodiscard]] Status write_model();
  // Writes the latency histograms (options().latency_csv) into the session folder, atomically.
  [[nodiscard]] Status write_latency() const;
  // Scan stamp (end of sweep, CLOCK_REALTIME) -> the scan decided by the core and in the live map, and
  // scan stamp -> taken from DDS (the station stores it right then, before fusion), one sample per scan.
  [[nodiscard]] const LatencyHistogram& fused_latency() const { return fused_latency_; }
  [[nodiscard]] const LatencyHistogram& stored_latency() const { return stored_latency_; }

  // The occupied voxels of the live map as teamscan/map voxels (flags 1: every point in the voxel
  // was removed at release).
  void map_voxels(std::vector<teamscan_msg_MapVoxel>& out) const;
  // Only the voxels that changed (new points) since the last call or clear_map_changes(), with their
  // whole counts and flags (a viewer replaces its voxel), then forgets them.
  void map_voxels_changed(std::vector<teamscan_msg_MapVoxel>& out);
  void clear_map_changes() { map_touched_.clear(); }
  [[nodiscard]] std::uint32_t map_total_voxels() const { return static_cast<std::uint32_t>(map_all_.occupied_voxels()); }
  [[nodiscard]] std::uint32_t map_resolution_mm() const;

  [[nodiscard]] const fusion::FusionCore& core() const { return *core_; }
  [[nodiscard]] fusion::FusionCore& core() { return *core_; }
  [[nodiscard]] const FusionCounters& counters() const { return counters_; }
  [[nodiscard]] const FusionOptions& options() const { return options_; }

  ~FusionStage();
  FusionStage(const FusionStage&) = delete;
  FusionStage& operator=(const FusionStage&) = delete;

 private:
  FusionStage(const FusionOptions& options, std::string session_dir, std::unique_ptr<fusion::FusionCore> core);
  void on_release(const fusion::FusedScan& scan);

  FusionOptions options_;
  std::string session_dir_;
  std::unique_ptr<fusion::FusionCore> core_;
  mapping::VoxelMap map_all_;
  mapping::VoxelMap map_kept_;
  mapping::VoxelMap map_touched_;  // voxels with new points since the last teamscan/map publication
  ScanBuffers scratch_;
  LatencyHistogram fused_latency_;
  LatencyHistogram stored_latency_;
  FusionCounters counters_;
  std::FILE* latency_log_ = nullptr;
  bool replaying_ = false;  // replay_session(): no latency samples (they are not this run's)
  bool resume_ = false;     // the first live sample after a replay resumes the core's arrival clock
};

}  // namespace teamscan::station
