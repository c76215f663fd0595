// FusionStage: live tracker + filter + voxel map over the received samples, and the fused PCD written
// by the offline evaluation code (docs/groundstation.md).
#include "groundstation/station/fusion.hpp"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <span>

#include "common/clock.hpp"
#include "common/dataset/pcd.hpp"
#include "common/scan_points.hpp"
#include "common/units.hpp"
#include "groundstation/mapping/evaluation.hpp"
#include "groundstation/station/config.hpp"
#include "teamscan.h"

namespace teamscan::station {

FusionOptions fusion_options_from_config(const FusionConfig& f, const KalmanConfig& k) {
  FusionOptions o;
  o.method = f.method;
  mapping::MethodOptions& m = o.methods;
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
  o.tracker = tracker_options(k);
  o.map_resolution_m = f.map_resolution_m;
  if (f.write_all_points) o.all_points_pcd = "fused_all.pcd";
  if (f.latency_log) o.latency_log_csv = "fused_latency.csv";
  return o;
}

Result<std::unique_ptr<FusionStage>> FusionStage::create(const FusionOptions& options, std::string session_dir) {
  std::unique_ptr<mapping::Filter> live = mapping::make_filter(options.method, options.methods);
  if (!live) return Error{"fusion: unknown filter method (fusion.method)"};
  if (!(options.map_resolution_m > 0.0)) return Error{"fusion: map resolution must be > 0 (fusion.map_resolution_m)"};
  return std::unique_ptr<FusionStage>(new FusionStage(options, std::move(session_dir), std::move(live)));
}

FusionStage::FusionStage(const FusionOptions& options, std::string session_dir, std::unique_ptr<mapping::Filter> live)
    : options_{options},
      session_dir_{std::move(session_dir)},
      live_{std::move(live)},
      tracker_{options.tracker},
      map_all_{options.map_resolution_m},
      map_kept_{options.map_resolution_m},
      map_touched_{options.map_resolution_m},
      received_{options.keep_received, options.replay_window, options.reserve_points} {
  keep_live_ = options.keep_received || !options.all_points_pcd.empty();
  if (options.keep_received) live_removed_points_.reserve(options.reserve_points);
  if (!options_.latency_log_csv.empty()) {
    latency_log_ = std::fopen((session_dir_ + "/" + options_.latency_log_csv).c_str(), "w");
    if (latency_log_ != nullptr) std::fputs("robot,seq,stamp_ns,received_ns,fused_ns\n", latency_log_);
  }
  scratch_points_.reserve(kMaxBeams);
  scratch_flags_.reserve(kMaxBeams);
  scratch_removed_.reserve(kMaxBeams);
}

namespace {
// Forward speed as KalmanTeamSource feeds the tracker: the map-frame velocity projected on the heading.
double forward_speed(const PoseObservation& p) { return forward_speed_mps(p.vx_mps, p.vy_mps, p.yaw_rad); }
}  // namespace

ReceivedBuilder::ReceivedBuilder(bool keep, std::uint32_t replay_window, std::size_t reserve_points)
    : keep_{keep}, replay_window_{replay_window}, poses_by_robot_(kMaxRobots + 1), seq_windows_(kMaxRobots + 1) {
  received_.scenario = "live";
  if (keep_) {
    received_.points.reserve(reserve_points);
    received_.scans.reserve(reserve_points / 128);
  }
}

std::size_t ReceivedBuilder::poses_held() const {
  std::size_t n = 0;
  for (const auto& l : poses_by_robot_) n += l.size();
  return n;
}

void ReceivedBuilder::add_pose(const PoseObservation& p) {
  const double v = forward_speed(p);
  // Kept in stamp order (DDS delivers a robot's samples in order; a restarted robot may go back).
  auto& list = poses_by_robot_[p.robot_id];
  auto at = std::upper_bound(list.begin(), list.end(), p.stamp.ns(),
                             [](std::int64_t t, const PoseObservation& q) { return t < q.stamp.ns(); });
  list.insert(at, p);
  if (keep_) {
    received_.odom.push_back({static_cast<std::uint8_t>(p.robot_id), p.stamp.ns(), Pose2{p.x_m, p.y_m, p.yaw_rad}, v,
                              p.yaw_rate_radps});
  } else if (list.size() >= 2 * kLivePosesPerRobot) {
    // Bounded: drop the oldest half at once (amortised O(1) per pose, no growth with the session).
    list.erase(list.begin(), list.end() - static_cast<std::ptrdiff_t>(kLivePosesPerRobot));
  }
}

Pose2 ReceivedBuilder::own_pose(std::uint32_t robot, std::int64_t stamp_ns, double ox, double oy) const {
  const auto& list = poses_by_robot_[robot];
  if (list.empty()) return Pose2{ox, oy, 0.0};
  auto after = std::upper_bound(list.begin(), list.end(), stamp_ns,
                                [](std::int64_t t, const PoseObservation& q) { return t < q.stamp.ns(); });
  const PoseObservation& p = after == list.begin() ? *after : *(after - 1);
  const double dt_s = static_cast<double>(stamp_ns - p.stamp.ns()) * 1e-9;
  return Pose2{p.x_m + p.vx_mps * dt_s, p.y_m + p.vy_mps * dt_s, p.yaw_rad + p.yaw_rate_radps * dt_s};
}

// True if (robot, seq) was fused before; else marks it. A seq far below the newest is a restarted robot.
bool ReceivedBuilder::seen_before(std::uint32_t robot, std::uint32_t seq) {
  SeqWindow& w = seq_windows_[robot];
  auto bit = [&](std::uint32_t k) -> bool { return (w.seen[k / 64] >> (k % 64)) & 1u; };
  auto set = [&](std::uint32_t k) { w.seen[k / 64] |= std::uint64_t{1} << (k % 64); };
  if (w.any && seq <= w.newest) {
    const std::uint32_t back = w.newest - seq;
    if (back <= std::min(replay_window_, kSeqWindow - 1)) {
      if (bit(back)) return true;
      set(back);  // late but new (out of order)
      return false;
    }
    // Far below the newest: a restarted robot counts from 1 again.
    w = SeqWindow{};
  }
  if (!w.any) {
    w.any = true;
    w.newest = seq;
    w.seen = {};
    set(0);
    return false;
  }
  // Newer: shift the bitmap by (seq − newest) bits.
  const std::uint32_t shift = seq - w.newest;
  if (shift >= kSeqWindow) {
    w.seen = {};
  } else {
    const std::uint32_t words = shift / 64, bits = shift % 64;
    for (std::size_t i = w.seen.size(); i-- > 0;) {
      std::uint64_t v = i >= words ? w.seen[i - words] << bits : 0;
      if (bits != 0 && i >= words + 1) v |= w.seen[i - words - 1] >> (64 - bits);
      w.seen[i] = v;
    }
  }
  w.newest = seq;
  set(0);
  return false;
}

bool ReceivedBuilder::add_scan(const StoredScan& s, ScanRecord& rec, std::vector<mapping::MapPoint>& points,
                               std::vector<std::uint16_t>& flags) {
  if (seen_before(s.robot_id, s.seq)) return false;
  const std::size_t n = std::min<std::size_t>(s.count, kMaxBeams);
  rec = ScanRecord{};
  rec.robot = static_cast<std::uint8_t>(s.robot_id);
  rec.scan = s.seq;
  rec.stamp_ns = s.stamp_ns;
  rec.beams = static_cast<std::uint16_t>(n);
  rec.origin = {s.origin_x_mm * 1e-3, s.origin_y_mm * 1e-3, s.origin_z_mm * 1e-3};
  rec.pose = own_pose(s.robot_id, s.stamp_ns, rec.origin.x, rec.origin.y);
  rec.true_pose = rec.pose;

  points.clear();
  flags.clear();
  for (std::size_t i = 0; i < n; ++i) {
    const StoredPoint& sp = s.points[i];
    // Beams without a 3-D point (no echo, dazzled, unplaced) are stored in scans.bin but are not part
    // of the model, as in the data set's points.pcd.
    if (sp.flags & kPointUnplaced) continue;
    LabelledPoint lp;
    lp.x = static_cast<float>(sp.x_mm * 1e-3);
    lp.y = static_cast<float>(sp.y_mm * 1e-3);
    lp.z = static_cast<float>(sp.z_mm * 1e-3);
    lp.robot = rec.robot;
    lp.scan = s.seq;
    lp.beam = sp.beam;
    lp.flags = dataset_flags_from_wire(sp.flags);
    lp.tx = lp.x;
    lp.ty = lp.y;
    lp.tz = lp.z;
    if (keep_) received_.points.push_back(lp);
    points.push_back({lp.x, lp.y, lp.z});
    flags.push_back(lp.flags);
  }
  rec.points = static_cast<std::uint16_t>(points.size());
  if (keep_) received_.scans.push_back(rec);
  return true;
}

void ReceivedBuilder::refresh_scan_poses() {
  for (ScanRecord& r : received_.scans) {
    r.pose = own_pose(r.robot, r.stamp_ns, r.origin.x, r.origin.y);
    r.true_pose = r.pose;
  }
}

void FusionStage::add_pose(const PoseObservation& p) {
  if (p.robot_id == 0 || p.robot_id > kMaxRobots) return;
  ++counters_.poses;
  tracker_.add_pose(static_cast<std::uint8_t>(p.robot_id), p.stamp.ns(), Pose2{p.x_m, p.y_m, p.yaw_rad}, forward_speed(p));
  received_.add_pose(p);
}

void FusionStage::add_scan(const StoredScan& s) {
  if (s.robot_id == 0 || s.robot_id > kMaxRobots) return;
  ScanRecord rec;
  if (!received_.add_scan(s, rec, scratch_points_, scratch_flags_)) {
    ++counters_.duplicates;
    return;
  }
  ++counters_.scans;
  counters_.points += scratch_points_.size();

  // Live: the team predicted to the scan's stamp, observe then classify against the map so far.
  const mapping::TeamState team = tracker_.predict(s.stamp_ns);
  mapping::ScanView view;
  view.robot = rec.robot;
  view.scan = rec.scan;
  view.stamp_ns = rec.stamp_ns;
  view.origin_m = rec.origin;
  view.map_from_robot = rec.pose;
  view.points = scratch_points_;
  view.flags = scratch_flags_;
  view.team = &team;
  live_->observe(view);
  scratch_removed_.assign(scratch_points_.size(), 0);
  live_->classify(view, scratch_removed_);
  for (std::size_t i = 0; i < scratch_points_.size(); ++i) {
    map_all_.insert(scratch_points_[i]);
    map_touched_.insert(scratch_points_[i]);
    if (keep_live_) live_removed_points_.push_back(scratch_removed_[i]);
    if (scratch_removed_[i]) {
      ++counters_.live_removed;
    } else {
      map_kept_.insert(scratch_points_[i]);
    }
  }
  // The scan is now in the fused map (classified, inserted): its latency from the end of its sweep.
  // Both stamps are CLOCK_REALTIME (the robots' clocks are NTP-disciplined, DESIGN.md "Frames, units, time").
  const std::int64_t fused_ns = now_realtime().ns();
  fused_latency_.add(fused_ns - s.stamp_ns);
  stored_latency_.add(s.recv_realtime_ns - s.stamp_ns);
  if (latency_log_ != nullptr) {
    std::fprintf(latency_log_, "%u,%u,%lld,%lld,%lld\n", s.robot_id, s.seq, static_cast<long long>(s.stamp_ns),
                 static_cast<long long>(s.recv_realtime_ns), static_cast<long long>(fused_ns));
  }
}

FusionStage::~FusionStage() {
  if (latency_log_ != nullptr) std::fclose(latency_log_);
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

namespace {

Status write_atomically(const std::string& path, const PcdCloud& cloud, const std::vector<PcdField>& layout) {
  const std::string tmp = path + ".tmp";
  if (Status st = write_pcd(tmp, cloud, layout); !st.ok()) return st;
  if (std::rename(tmp.c_str(), path.c_str()) != 0) return Error{"fusion: cannot rename the fused PCD into place", errno};
  return ok_status();
}

}  // namespace

Status write_received_as_dataset(Dataset& received, const std::string& dir) {
  received.truth = received.odom;  // no ground truth at the station: the odometry stands in
  received.robots.clear();
  std::array<bool, kMaxRobots + 1> has_pose{};
  for (const TrajectorySample& s : received.odom) has_pose[s.robot] = true;
  for (std::uint32_t id = 1; id <= kMaxRobots; ++id) {
    if (!has_pose[id]) continue;
    DatasetRobot r;
    r.id = static_cast<std::uint8_t>(id);
    r.name = "robot" + std::to_string(id);
    received.robots.push_back(r);
  }
  Status st = write_dataset(dir, received);
  received.truth.clear();
  return st;
}

Status FusionStage::write_received_dataset(const std::string& dir) {
  if (!options_.keep_received) return Error{"fusion: received points not kept in memory (keep_received false)"};
  received_.refresh_scan_poses();
  return write_received_as_dataset(received_.dataset(), dir);
}

Status write_fused_model(Dataset& received, const FusionOptions& options, const std::string& dir,
                         std::span<const std::uint8_t> live_removed, std::vector<std::uint8_t>& removed,
                         ModelFigures& figures, const std::function<bool()>& cancelled) {
  const mapping::PreparedDataset prepared = mapping::prepare_dataset(received, options.tracker);
  std::unique_ptr<mapping::Filter> filter = mapping::make_filter(options.method, options.methods);
  if (!filter) return Error{"fusion: unknown filter method (fusion.method)"};
  removed = mapping::run_offline(prepared, *filter);
  if (cancelled && cancelled()) return Error{"fusion: model write cancelled"};

  const bool all = !options.all_points_pcd.empty();
  PcdCloud kept, every;
  kept.fields = {"x", "y", "z", "robot", "scan", "beam"};
  kept.columns.assign(kept.fields.size(), {});
  std::vector<PcdField> layout = {{"x", 4, 'F', 1},     {"y", 4, 'F', 1},    {"z", 4, 'F', 1},
                                  {"robot", 1, 'U', 1}, {"scan", 4, 'U', 1}, {"beam", 2, 'U', 1}};
  if (all) {
    every.fields = kept.fields;
    every.fields.push_back("keep");
    every.fields.push_back("live_keep");
    every.columns.assign(every.fields.size(), {});
  }
  std::uint64_t n_kept = 0;
  for (std::size_t i = 0; i < received.points.size(); ++i) {
    const LabelledPoint& p = received.points[i];
    const double row[6] = {p.x, p.y, p.z, static_cast<double>(p.robot), static_cast<double>(p.scan),
                           static_cast<double>(p.beam)};
    const bool keep = removed[i] == 0;
    if (keep) {
      ++n_kept;
      for (std::size_t c = 0; c < 6; ++c) kept.columns[c].push_back(row[c]);
    }
    if (all) {
      for (std::size_t c = 0; c < 6; ++c) every.columns[c].push_back(row[c]);
      every.columns[6].push_back(keep ? 1.0 : 0.0);
      // The decision the live stage took at arrival (map-based filters: against the map so far).
      every.columns[7].push_back(i < live_removed.size() && live_removed[i] ? 0.0 : 1.0);
    }
  }
  kept.width = n_kept;
  kept.height = 1;
  Status st = write_atomically(dir + "/" + options.kept_pcd, kept, layout);
  if (st.ok() && all) {
    every.width = received.points.size();
    every.height = 1;
    std::vector<PcdField> layout_all = layout;
    layout_all.push_back({"keep", 1, 'U', 1});
    layout_all.push_back({"live_keep", 1, 'U', 1});
    st = write_atomically(dir + "/" + options.all_points_pcd, every, layout_all);
  }
  if (!st.ok()) return st;
  figures.kept = n_kept;
  figures.removed = received.points.size() - n_kept;
  return ok_status();
}

Status FusionStage::write_model() {
  if (!options_.keep_received) {
    ++counters_.write_failures;
    return Error{"fusion: received points not kept in memory (keep_received false): write through ModelWriter"};
  }
  received_.refresh_scan_poses();
  ModelFigures fig;
  Status st = write_fused_model(received_.dataset(), options_, session_dir_, live_removed_points_, last_removed_, fig);
  if (!st.ok()) {
    ++counters_.write_failures;
    return st;
  }
  ++counters_.writes;
  counters_.last_write_kept = fig.kept;
  counters_.last_write_removed = fig.removed;
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
