// FusionStage: received samples into the fusion core, the teamscan/map voxel maps and latency from its
// released scans, the fused model from its memory (fusion.hpp).
#include "groundstation/station/fusion.hpp"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>

#include "common/clock.hpp"
#include "common/dataset/dataset.hpp"
#include "common/point_flags.hpp"
#include "common/pose.hpp"
#include "common/scan_points.hpp"
#include "common/units.hpp"
#include "groundstation/station/config.hpp"
#include "groundstation/station/session_replay.hpp"
#include "teamscan.h"

namespace teamscan::station {

FusionOptions fusion_options_from_config(const FusionConfig& f, const KalmanConfig& k) {
  FusionOptions o;
  o.core.method = f.method;
  mapping::MethodOptions& m = o.core.methods;
  m.frequency.resolution_m = f.resolution_m;
  m.frequency.k = f.frequency_k;
  m.frequency.grid_origin_z_m = f.grid_origin_z_m;
  m.visibility.resolution_m = f.resolution_m;
  m.visibility.grid_origin_z_m = f.grid_origin_z_m;
  m.position.sigma_m = f.position_sigma_m;
  m.position.n = f.position_n;
  m.direction.half_angle_rad = deg_to_rad(f.half_angle_deg);
  m.direction.source = f.direction_from_flags ? mapping::DirectionSource::flags : mapping::DirectionSource::recompute;
  m.combined_half_angle_rad = deg_to_rad(f.half_angle_deg);
  m.combined_resolution_m = f.resolution_m;
  m.combined_grid_origin_z_m = f.grid_origin_z_m;
  o.core.tracker = tracker_options(k);
  o.core.hold_s = f.hold_s;
  o.core.tracker.team_lag_s = f.team_lag_s;
  o.core.model_resolution_m = f.model_resolution_m;
  o.core.max_points_per_voxel = f.max_points_per_voxel;
  o.map_resolution_m = f.map_resolution_m;
  if (f.write_all_points) o.all_points_pcd = "fused_all.pcd";
  if (f.latency_log) o.latency_log_csv = "fused_latency.csv";
  return o;
}

fusion::PoseInput pose_input(const PoseObservation& p) {
  fusion::PoseInput in;
  in.robot = static_cast<std::uint8_t>(p.robot_id <= kMaxRobots ? p.robot_id : 0);
  in.stamp_ns = p.stamp.ns();
  in.arrival_ns = p.received.ns();
  in.odom = Pose2{p.x_m, p.y_m, p.yaw_rad};
  in.v_mps = forward_speed_mps(p.vx_mps, p.vy_mps, p.yaw_rad);
  in.w_radps = p.yaw_rate_radps;
  return in;
}

fusion::ScanInput scan_input(const StoredScan& s, ScanBuffers& b) {
  const std::size_t n = std::min<std::size_t>(s.count, kMaxBeams);
  b.points.clear();
  b.flags.clear();
  b.beams.clear();
  for (std::size_t i = 0; i < n; ++i) {
    const StoredPoint& sp = s.points[i];
    // Beams without a 3-D point (no echo, dazzled, unplaced) are stored in scans.bin but are not part
    // of the model, as in the data set's points.pcd.
    if (sp.flags & kPointUnplaced) continue;
    b.points.push_back({static_cast<float>(sp.x_mm * 1e-3), static_cast<float>(sp.y_mm * 1e-3), static_cast<float>(sp.z_mm * 1e-3)});
    b.flags.push_back(dataset_flags_from_wire(sp.flags));
    b.beams.push_back(sp.beam);
  }
  fusion::ScanInput in;
  in.robot = static_cast<std::uint8_t>(s.robot_id <= kMaxRobots ? s.robot_id : 0);
  in.seq = s.seq;
  in.stamp_ns = s.stamp_ns;
  in.arrival_ns = s.recv_realtime_ns;
  in.origin_m = {s.origin_x_mm * 1e-3, s.origin_y_mm * 1e-3, s.origin_z_mm * 1e-3};
  in.points = b.points;
  in.flags = b.flags;
  in.beams = b.beams;
  return in;
}

Result<std::unique_ptr<FusionStage>> FusionStage::create(const FusionOptions& options, std::string session_dir) {
  if (!(options.map_resolution_m > 0.0)) return Error{"fusion: map resolution must be > 0 (fusion.map_resolution_m)"};
  auto core = fusion::FusionCore::create(options.core);
  if (!core.ok()) return core.error();
  return std::unique_ptr<FusionStage>(new FusionStage(options, std::move(session_dir), std::move(core.value())));
}

FusionStage::FusionStage(const FusionOptions& options, std::string session_dir, std::unique_ptr<fusion::FusionCore> core)
    : options_{options},
      session_dir_{std::move(session_dir)},
      core_{std::move(core)},
      map_all_{options.map_resolution_m},
      map_kept_{options.map_resolution_m},
      map_touched_{options.map_resolution_m} {
  if (!options_.latency_log_csv.empty()) {
    latency_log_ = std::fopen((session_dir_ + "/" + options_.latency_log_csv).c_str(), "a");
    if (latency_log_ != nullptr && std::ftell(latency_log_) == 0) std::fputs("robot,seq,stamp_ns,received_ns,fused_ns\n", latency_log_);
  }
  scratch_.points.reserve(kMaxBeams);
  scratch_.flags.reserve(kMaxBeams);
  scratch_.beams.reserve(kMaxBeams);
  core_->set_release_callback([this](const fusion::FusedScan& f) { on_release(f); });
}

FusionStage::~FusionStage() {
  if (latency_log_ != nullptr) std::fclose(latency_log_);
}

void FusionStage::add_pose(const PoseObservation& p) {
  if (p.robot_id == 0 || p.robot_id > kMaxRobots) return;
  ++counters_.poses;
  const fusion::PoseInput in = pose_input(p);
  if (resume_ && !replaying_) {
    core_->resume_at(in.arrival_ns);
    resume_ = false;
  }
  core_->add_pose(in);
}

void FusionStage::add_scan(const StoredScan& s) {
  if (s.robot_id == 0 || s.robot_id > kMaxRobots) return;
  if (!replaying_) stored_latency_.add(s.recv_realtime_ns - s.stamp_ns);
  if (resume_) {
    core_->resume_at(s.recv_realtime_ns);
    resume_ = false;
  }
  if (!core_->add_scan(scan_input(s, scratch_))) ++counters_.duplicates;
}

void FusionStage::on_release(const fusion::FusedScan& f) {
  ++counters_.scans;
  if (replaying_) ++counters_.replayed_scans;
  const std::span<const mapping::MapPoint> points = f.view->points;
  counters_.points += points.size();
  for (std::size_t i = 0; i < points.size(); ++i) {
    map_all_.insert(points[i]);
    map_touched_.insert(points[i]);
    if (f.removed[i]) {
      ++counters_.live_removed;
    } else {
      map_kept_.insert(points[i]);
    }
  }
  if (replaying_) return;
  // The scan is now decided and in the fused map: its latency from the end of its sweep. Both stamps
  // are CLOCK_REALTIME (the robots' clocks are NTP-disciplined, DESIGN.md "Frames, units, time").
  const std::int64_t fused_ns = now_realtime().ns();
  fused_latency_.add(fused_ns - f.stamp_ns);
  if (latency_log_ != nullptr) {
    std::fprintf(latency_log_, "%u,%u,%lld,%lld,%lld\n", f.robot, f.seq, static_cast<long long>(f.stamp_ns),
                 static_cast<long long>(f.arrival_ns), static_cast<long long>(fused_ns));
  }
}

Result<std::uint64_t> FusionStage::replay_session(const std::string& dir) {
  replaying_ = true;
  SessionReadStats stats;
  ScanBuffers buffers;
  Status st = replay_session_files(
      dir, [&](const PoseObservation& p) { add_pose(p); },
      [&](const StoredScan& s) {
        if (s.robot_id == 0 || s.robot_id > kMaxRobots) return;
        if (!core_->add_scan(scan_input(s, buffers))) ++counters_.duplicates;
      },
      stats);
  replaying_ = false;
  resume_ = true;
  if (!st.ok()) return st.error();
  return stats.poses + stats.scans;
}

Status FusionStage::write_model() {
  auto fig = core_->write_model(session_dir_ + "/" + options_.kept_pcd,
                                options_.all_points_pcd.empty() ? std::string{} : session_dir_ + "/" + options_.all_points_pcd);
  if (!fig.ok()) {
    ++counters_.write_failures;
    return fig.error();
  }
  ++counters_.writes;
  counters_.last_write_kept = fig.value().kept;
  counters_.last_write_removed = fig.value().removed;
  return ok_status();
}

Status FusionStage::write_latency() const {
  if (latency_log_ != nullptr) std::fflush(latency_log_);
  if (options_.latency_csv.empty()) return ok_status();
  const std::string path = session_dir_ + "/" + options_.latency_csv, tmp = path + ".tmp";
  const std::string text = "# scan -> stored: stamp (end of sweep) -> taken from DDS and written to scans.bin\n" +
                           stored_latency_.csv("scan -> stored") + "\n# scan -> fused map: stamp -> classified and in the live map\n" +
                           fused_latency_.csv("scan -> fused map");
  std::FILE* f = std::fopen(tmp.c_str(), "w");
  if (f == nullptr) return Error{"fusion: cannot write the latency file", errno};
  const bool ok = std::fwrite(text.data(), 1, text.size(), f) == text.size();
  if (std::fclose(f) != 0 || !ok) return Error{"fusion: cannot write the latency file", errno};
  if (std::rename(tmp.c_str(), path.c_str()) != 0) return Error{"fusion: cannot rename the latency file into place", errno};
  return ok_status();
}

std::uint32_t FusionStage::map_resolution_mm() const {
  return static_cast<std::uint32_t>(std::lround(options_.map_resolution_m * 1000.0));
}

void FusionStage::map_voxels_changed(std::vector<teamscan_msg_MapVoxel>& out) {
  out.clear();
  const double r = map_all_.resolution_m();
  map_touched_.for_each_voxel([&](mapping::VoxelKey k, std::uint32_t) {
    teamscan_msg_MapVoxel v{};
    v.x_mm = static_cast<std::int32_t>(std::lround((k.x + 0.5) * r * 1000.0));
    v.y_mm = static_cast<std::int32_t>(std::lround((k.y + 0.5) * r * 1000.0));
    v.z_mm = static_cast<std::int32_t>(std::lround((k.z + 0.5) * r * 1000.0));
    v.hits = static_cast<std::uint16_t>(std::min<std::uint32_t>(map_all_.count(k), 0xFFFFu));
    v.flags = map_kept_.count(k) == 0 ? 1 : 0;
    out.push_back(v);
  });
  map_touched_.clear();
}

void FusionStage::map_voxels(std::vector<teamscan_msg_MapVoxel>& out) const {
  out.clear();
  out.reserve(map_all_.occupied_voxels());
  const double r = map_all_.resolution_m();
  map_all_.for_each_voxel([&](mapping::VoxelKey k, std::uint32_t hits) {
    teamscan_msg_MapVoxel v{};
    v.x_mm = static_cast<std::int32_t>(std::lround((k.x + 0.5) * r * 1000.0));
    v.y_mm = static_cast<std::int32_t>(std::lround((k.y + 0.5) * r * 1000.0));
    v.z_mm = static_cast<std::int32_t>(std::lround((k.z + 0.5) * r * 1000.0));
    v.hits = static_cast<std::uint16_t>(std::min<std::uint32_t>(hits, 0xFFFFu));
    v.flags = map_kept_.count(k) == 0 ? 1 : 0;
    out.push_back(v);
  });
}

}  // namespace teamscan::station
