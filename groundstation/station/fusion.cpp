// FusionStage: received samples into the fusion core, the teamscan/map voxel maps and latency from its
// released scans, the fused model from its memory (fusion.hpp).
#include "groundstation/station/fusion.hpp"

#include "groundstation/station/catch_up_run.hpp"
#include "groundstation/station/rigid_follow.hpp"

#include <algorithm>
#include <map>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <future>
#include <system_error>
#include <utility>

#include "common/clock.hpp"
#include "common/dataset/dataset.hpp"
#include "common/point_flags.hpp"
#include "common/pose.hpp"
#include "common/scan_points.hpp"
#include "common/units.hpp"
#include "groundstation/fusion/time_line.hpp"
#include "groundstation/station/session_replay.hpp"
#include "teamscan.h"

namespace teamscan::station {

std::string method_file_name(const std::string& name, const std::string& method) {
  const std::size_t dot = name.rfind('.');
  if (dot == std::string::npos || dot == 0 || name.find('/', dot) != std::string::npos) return name + "." + method;
  return name.substr(0, dot) + "." + method + name.substr(dot);
}

FusionOptions compared_options(const FusionOptions& o, const std::string& method) {
  FusionOptions c = o;
  c.compare_methods.clear();
  if (method == o.core.method) return c;
  c.core.method = method;
  c.kept_pcd = method_file_name(o.kept_pcd, method);
  if (!o.all_points_pcd.empty()) c.all_points_pcd = method_file_name(o.all_points_pcd, method);
  return c;
}

fusion::PoseInput pose_input(const PoseObservation& p) {
  fusion::PoseInput in;
  in.robot = static_cast<std::uint8_t>(p.robot_id);  // 1..kMaxRobots, checked at the edge
  in.stamp_ns = p.stamp.ns();
  in.arrival_ns = p.received.ns();
  in.odom = Pose2{p.x_m, p.y_m, p.yaw_rad};
  in.v_mps = forward_speed_mps(p.vx_mps, p.vy_mps, p.yaw_rad);
  in.w_radps = p.yaw_rate_radps;
  return in;
}

const fusion::ScanInput& scan_input(const ScanPoints& s, const Receipt& receipt, fusion::ScanInput& out) {
  const std::size_t n = std::min<std::size_t>(s.count, kMaxBeams);
  out.robot = static_cast<std::uint8_t>(s.robot_id);
  out.scan = s.seq;
  out.stamp_ns = s.stamp.ns();
  out.origin_m = {s.origin_x_mm * 1e-3, s.origin_y_mm * 1e-3, s.origin_z_mm * 1e-3};
  out.arrival_ns = receipt.recv_realtime_ns;
  out.points.clear();
  out.flags.clear();
  out.beams.clear();
  for (std::size_t i = 0; i < n; ++i) {
    const ScanPoint& sp = s.points[i];
    // Beams without a 3-D point (no echo, dazzled, unplaced) are stored in scans.bin but are not part
    // of the model, as in the data set's points.pcd.
    if (sp.flags & kPointUnplaced) continue;
    out.points.push_back({static_cast<float>(sp.x_mm * 1e-3), static_cast<float>(sp.y_mm * 1e-3), static_cast<float>(sp.z_mm * 1e-3)});
    out.flags.push_back(dataset_flags_from_wire(sp.flags));
    out.beams.push_back(sp.beam);
  }
  return out;
}

Result<std::unique_ptr<FusionStage>> FusionStage::create(const FusionOptions& given, std::string session_dir) {
  if (!(given.map_resolution_m > 0.0)) return Error{"fusion: map resolution must be > 0 (fusion.map_resolution_m)"};
  FusionOptions options = given;
  if (options.pose_graph) options.core = fusion::with_graph_order(options.core);
  auto cores = fusion::CoreSet::create(options.core, options.compare_methods);
  if (!cores.ok()) return cores.error();
  return std::unique_ptr<FusionStage>(new FusionStage(options, std::move(session_dir), std::move(cores.value())));
}

FusionStage::FusionStage(const FusionOptions& options, std::string session_dir, std::unique_ptr<fusion::CoreSet> cores)
    : options_{options},
      session_dir_{std::move(session_dir)},
      cores_{std::move(cores)},
      map_{options.map_resolution_m} {
  if (!options_.latency_log_csv.empty()) {
    latency_log_ = std::fopen((session_dir_ + "/" + options_.latency_log_csv).c_str(), "a");
    if (latency_log_ != nullptr && std::ftell(latency_log_) == 0) std::fputs("robot,seq,stamp_ns,received_ns,fused_ns\n", latency_log_);
  }
  scratch_.points.reserve(kMaxBeams);
  scratch_.flags.reserve(kMaxBeams);
  scratch_.beams.reserve(kMaxBeams);
  if (!session_dir_.empty()) trajectories_ = std::make_unique<trajectory::TumAppender>(session_dir_);
  if (options_.pose_graph) graph_ = std::make_unique<fusion::GraphBackend>(*options_.pose_graph);
  core().set_release_callback([this](const fusion::FusedScan& f) { on_release(f); });
  // Each core's model files: the primary's as configured, a compared method's by method_file_name.
  std::vector<fusion::ModelTarget> targets;
  for (std::size_t i = 0; i < cores_->size(); ++i) {
    const FusionOptions o = compared_options(options_, cores_->at(i).options().method);
    targets.push_back(fusion::ModelTarget{&cores_->at(i), session_dir_ + "/" + o.kept_pcd,
                                          o.all_points_pcd.empty() ? std::string{} : session_dir_ + "/" + o.all_points_pcd});
  }
  writer_ = std::make_unique<fusion::ModelWriter>(std::move(targets), fusion::ModelWriterOptions{options_.write_slice_ms, options_.writer_cpus},
                                                  [this](const ModelWriteReport& r) { finish_write(r); });
}

Status FusionStage::write_graph_trajectories() {
  if (!graph_) return ok_status();
  if (session_dir_.empty()) return Error{"fusion: no session folder to write the graph's trajectories into"};
  std::map<std::uint8_t, std::vector<trajectory::StampedPose>> by_robot;
  for (const fusion::GraphScanPose& p : graph_->poses()) by_robot[p.robot].push_back({(p.stamp_ns + 500) / 1000, p.graph});
  return trajectory::write_tum_files(session_dir_, by_robot, ".graph");
}

Status FusionStage::write_model() {
  const ModelWriteReport& r = writer_->write_now();
  if (!r.ok) return r.error;
  return ok_status();
}

void FusionStage::finish_write(const ModelWriteReport& r) {
  if (trajectories_) trajectories_->flush();  // robot<N>.tum as far as the model files
  if (!r.ok) {
    ++counters_.write_failures;
  } else {
    ++counters_.writes;
    counters_.last_write_kept = r.kept;
    counters_.last_write_removed = r.removed;
  }
  if (on_write_) on_write_(r);
}

FusionStage::~FusionStage() {
  drop_catch_up();  // a session read under way finishes first
  if (freeing_.valid()) freeing_.wait();
  writer_.reset();  // a write in flight finishes first
  if (latency_log_ != nullptr) std::fclose(latency_log_);
}

std::size_t FusionStage::model_memory_bytes() const {
  std::size_t n = 0;
  for (std::size_t i = 0; i < cores_->size(); ++i) n += cores_->at(i).model_memory_bytes();
  return n;
}

std::size_t FusionStage::filter_memory_bytes() const {
  std::size_t n = 0;
  for (std::size_t i = 0; i < cores_->size(); ++i) n += cores_->at(i).map_memory_bytes();
  return n;
}

// Every core takes the same input in the same order; the primary's answer counts the duplicates.
void FusionStage::add_scan_to_cores(const fusion::ScanInput& in) {
  if (!cores_->add_scan(in)) ++counters_.duplicates;
}

void FusionStage::add_pose(const PoseObservation& p) {
  ++counters_.poses;
  const fusion::PoseInput in = pose_input(p);
  if (resume_ && !replaying_) {
    cores_->resume_at(in.arrival_ns);
    resume_ = false;
  }
  cores_->add_pose(in);
  if (run_) run_->rebuild.add_pose(in);
}

void FusionStage::add_scan(const ScanPoints& s, const Receipt& receipt) {
  if (!replaying_) stored_latency_.add(receipt.recv_realtime_ns - s.stamp.ns());
  if (resume_) {
    cores_->resume_at(receipt.recv_realtime_ns);
    resume_ = false;
  }
  const fusion::ScanInput& in = scan_input(s, receipt, scratch_);
  add_scan_to_cores(in);
  if (run_) run_->rebuild.add_scan(in);
}

void FusionStage::on_release(const fusion::FusedScan& f) {
  ++counters_.scans;
  if (replaying_) ++counters_.replayed_scans;
  const std::span<const mapping::MapPoint> points = f.view->points;
  counters_.points += points.size();
  // The live map is the model: the points the core stored, where it placed them, with their class.
  map_.add_all(points, f.removed, f.stored, f.view->robot, f.release);
  on_released_while_following(f);
  for (std::uint8_t r : f.removed) counters_.live_removed += r != 0 ? 1 : 0;
  if (graph_) graph_->add(f);
  if (replaying_ || catching_up_) return;
  if (run_) run_->live_released.emplace(f.view->robot, f.view->scan);
  if (!released_before_.empty() && released_before_.erase({f.view->robot, f.view->scan}) > 0) return;
  record_fused(f.view->robot, f.view->scan, f.view->stamp_ns, f.arrival_ns, f.view->map_from_robot);
}

// A scan now decided and in the live map: its pose and latency.
void FusionStage::record_fused(std::uint8_t robot, std::uint32_t scan, std::int64_t stamp_ns, std::int64_t arrival_ns,
                               const Pose2& map_from_robot) {
  // Its pose as decided, one TUM line at its own stamp (a replay's scans were written by the first run).
  if (trajectories_) (void)trajectories_->add(robot, {(stamp_ns + 500) / 1000, map_from_robot});
  // Its latency from the end of its sweep. Both stamps are CLOCK_REALTIME (the robots' clocks are
  // NTP-disciplined, DESIGN.md "Frames, units, time").
  const std::int64_t fused_ns = now_realtime().ns();
  fused_latency_.add(fused_ns - stamp_ns);
  if (latency_log_ != nullptr) {
    std::fprintf(latency_log_, "%u,%u,%lld,%lld,%lld\n", robot, scan, static_cast<long long>(stamp_ns),
                 static_cast<long long>(arrival_ns), static_cast<long long>(fused_ns));
  }
}

// A scan released by the catch-up's rebuilt primary: into the map it will show (and the catch-up's new
// graph); from the queue (a live input), remembered for the take-over.
void FusionStage::add_rebuilt_release(CatchUpRun& run, const fusion::FusedScan& f) {
  ++run.scans;
  const std::span<const mapping::MapPoint> points = f.view->points;
  run.points += points.size();
  run.map.add_all(points, f.removed, f.stored, f.view->robot, f.release);
  for (std::uint8_t r : f.removed) run.live_removed += r != 0 ? 1 : 0;
  if (run.graph) run.graph->add(f);
}

void FusionStage::on_rebuilt_release(const fusion::FusedScan& f) {
  CatchUpRun& run = *run_;
  add_rebuilt_release(run, f);
  // Following the graph, it keeps taking the live releases; a queued scan the rebuilt cores release
  // first goes to it from here (one it took already is ignored).
  if (run.follow && run.behind && graph_) graph_->add(f);
  if (run.behind)
    run.rebuilt_released.push_back({f.view->robot, f.view->scan, f.view->stamp_ns, f.arrival_ns, f.view->map_from_robot});
}

Result<std::uint64_t> FusionStage::replay_session(const std::string& dir, const std::function<void()>& progressing) {
  const Time started = now_monotonic();
  replaying_ = true;
  SessionReadStats stats;
  fusion::ScanInput scan;
  std::uint64_t samples = 0;
  const auto progress = [&] {
    if (progressing && ++samples % 256 == 0) progressing();
  };
  Status st = replay_session_files(
      dir,
      [&](const PoseObservation& p) {
        add_pose(p);
        progress();
      },
      [&](const ScanPoints& s, const Receipt& receipt) {
        add_scan_to_cores(scan_input(s, receipt, scan));
        progress();
      },
      stats);
  replaying_ = false;
  resume_ = true;
  if (!st.ok()) return st.error();
  // The replay fed the cores the session as an exact follow would: it stands for one made, so an exact
  // follow of a long session is not tried (exact_follow_due).
  exact_follow_ = ExactFollow{started, now_monotonic() - started, stats.scans};
  return stats.poses + stats.scans;
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
  return to_mm_as<std::uint32_t>(options_.map_resolution_m);
}

void CorrectionShare::share(const fusion::FusionCore& core, TeamSource& team, Time at) {
  // Without the registration (off, or the cores follow the pose graph) a changed correction is a change
  // of frame, never a measurement.
  const registration::Registration* reg = core.registration();
  for (std::uint8_t id = 1; id <= kMaxRobots; ++id) {
    const fusion::PoseHistory::Correction* c = core.poses().correction_at(id, at.ns());
    if (c == nullptr) continue;
    Shared& s = shared_[id];
    const Pose2& m = c->map_from_odom;
    if (s.any && s.from_stamp_ns == c->from_stamp_ns && s.map_from_odom == m) continue;
    const registration::RobotCorrection* r = reg != nullptr ? reg->correction(id) : nullptr;
    const std::uint64_t accepted = r != nullptr ? r->accepted : s.accepted;
    team.set_correction(id, m.x_m, m.y_m, m.theta_rad, c->position_sigma_m, c->heading_sigma_rad, accepted != s.accepted);
    s = Shared{c->from_stamp_ns, m, accepted, true};
  }
}

}  // namespace teamscan::station
