// FusionStage: received samples into the fusion core, the teamscan/map voxel maps and latency from its
// released scans, the fused model from its memory (fusion.hpp).
#include "groundstation/station/fusion.hpp"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>

#include <pthread.h>
#include <sched.h>
#include <sys/resource.h>
#include <sys/syscall.h>
#include <unistd.h>

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

namespace {

// The calling thread yields to every other thread of normal priority: nice 19 on its own thread id
// (Linux: per thread), then SCHED_IDLE (allowed unprivileged: it only lowers the priority). Best
// effort: a kernel that refuses one keeps the other.
void yield_to_the_loop() {
  (void)::setpriority(PRIO_PROCESS, static_cast<id_t>(current_thread_id()), 19);
  sched_param p{};
  p.sched_priority = 0;
  (void)::pthread_setschedparam(::pthread_self(), SCHED_IDLE, &p);
}

}  // namespace

FusionOptions fusion_options_from_config(const FusionConfig& f, const KalmanConfig& k, const RegistrationConfig& reg) {
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
  o.core.min_scan_interval_s = f.min_scan_interval_s;
  o.core.model_resolution_m = f.model_resolution_m;
  o.core.max_points_per_voxel = f.max_points_per_voxel;
  o.core.registration = f.registration;
  o.core.registration_options = reg;  // the [registration] keys on the registration's defaults
  o.map_resolution_m = f.map_resolution_m;
  if (f.write_all_points) o.all_points_pcd = "fused_all.pcd";
  if (f.latency_log) o.latency_log_csv = "fused_latency.csv";
  o.compare_methods = f.compare_methods;
  o.write_slice_ms = f.write_slice_ms;
  o.writer_cpus = f.writer_cpus;
  return o;
}

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

FusionOptions fusion_options_from_config(const FusionConfig& f, const KalmanConfig& k) {
  return fusion_options_from_config(f, k, RegistrationConfig{});
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
    const ScanPoint& sp = s.points[i];
    // Beams without a 3-D point (no echo, dazzled, unplaced) are stored in scans.bin but are not part
    // of the model, as in the data set's points.pcd.
    if (sp.flags & kPointUnplaced) continue;
    b.points.push_back({static_cast<float>(sp.x_mm * 1e-3), static_cast<float>(sp.y_mm * 1e-3), static_cast<float>(sp.z_mm * 1e-3)});
    b.flags.push_back(dataset_flags_from_wire(sp.flags));
    b.beams.push_back(sp.beam);
  }
  fusion::ScanInput in;
  in.view.robot = static_cast<std::uint8_t>(s.robot_id <= kMaxRobots ? s.robot_id : 0);
  in.view.scan = s.seq;
  in.view.stamp_ns = s.stamp_ns;
  in.view.origin_m = {s.origin_x_mm * 1e-3, s.origin_y_mm * 1e-3, s.origin_z_mm * 1e-3};
  in.view.points = b.points;
  in.view.flags = b.flags;
  in.arrival_ns = s.recv_realtime_ns;
  in.beams = b.beams;
  return in;
}

Result<std::unique_ptr<FusionStage>> FusionStage::create(const FusionOptions& options, std::string session_dir) {
  if (!(options.map_resolution_m > 0.0)) return Error{"fusion: map resolution must be > 0 (fusion.map_resolution_m)"};
  std::vector<std::unique_ptr<Model>> models;
  std::vector<std::string> methods{options.core.method};
  for (const std::string& m : options.compare_methods) {
    if (std::find(methods.begin(), methods.end(), m) != methods.end())
      return Error{"fusion: a compared method is the primary method or listed twice (fusion.compare_methods)"};
    methods.push_back(m);
  }
  for (const std::string& m : methods) {
    const FusionOptions o = compared_options(options, m);
    auto core = fusion::FusionCore::create(o.core);
    if (!core.ok()) {
      if (m == options.core.method) return core.error();
      return Error{"fusion: unknown compared method (fusion.compare_methods)"};
    }
    auto model = std::make_unique<Model>();
    model->core = std::move(core.value());
    model->kept_path = session_dir + "/" + o.kept_pcd;
    if (!o.all_points_pcd.empty()) model->all_path = session_dir + "/" + o.all_points_pcd;
    models.push_back(std::move(model));
  }
  return std::unique_ptr<FusionStage>(new FusionStage(options, std::move(session_dir), std::move(models)));
}

FusionStage::FusionStage(const FusionOptions& options, std::string session_dir, std::vector<std::unique_ptr<Model>> models)
    : options_{options},
      session_dir_{std::move(session_dir)},
      models_{std::move(models)},
      map_{options.map_resolution_m} {
  if (!options_.latency_log_csv.empty()) {
    latency_log_ = std::fopen((session_dir_ + "/" + options_.latency_log_csv).c_str(), "a");
    if (latency_log_ != nullptr && std::ftell(latency_log_) == 0) std::fputs("robot,seq,stamp_ns,received_ns,fused_ns\n", latency_log_);
  }
  scratch_.points.reserve(kMaxBeams);
  scratch_.flags.reserve(kMaxBeams);
  scratch_.beams.reserve(kMaxBeams);
  core().set_release_callback([this](const fusion::FusedScan& f) { on_release(f); });
}

FusionStage::~FusionStage() {
  if (writer_.joinable()) {
    {
      std::lock_guard<std::mutex> lock(writer_mutex_);
      writer_stop_ = true;
    }
    writer_cv_.notify_all();
    writer_.join();  // a write in flight finishes first
  }
  if (latency_log_ != nullptr) std::fclose(latency_log_);
}

const fusion::FusionCore* FusionStage::compared_core(const std::string& method) const {
  for (std::size_t i = 1; i < models_.size(); ++i)
    if (models_[i]->core->options().method == method) return models_[i]->core.get();
  return nullptr;
}

std::size_t FusionStage::model_memory_bytes() const {
  std::size_t n = 0;
  for (const auto& m : models_) n += m->core->model_memory_bytes();
  return n;
}

std::size_t FusionStage::filter_memory_bytes() const {
  std::size_t n = 0;
  for (const auto& m : models_) n += m->core->map_memory_bytes();
  return n;
}

void FusionStage::flush() {
  for (const auto& m : models_) m->core->flush();
}

void FusionStage::tick(std::int64_t realtime_ns) {
  if (resume_) return;
  for (const auto& m : models_) m->core->advance_to(realtime_ns);
}

// Every core takes the same input in the same order; the primary's answer counts the duplicates.
void FusionStage::add_scan_to_cores(const fusion::ScanInput& in) {
  if (!core().add_scan(in)) ++counters_.duplicates;
  for (std::size_t i = 1; i < models_.size(); ++i) (void)models_[i]->core->add_scan(in);
}

void FusionStage::add_pose(const PoseObservation& p) {
  if (p.robot_id == 0 || p.robot_id > kMaxRobots) return;
  ++counters_.poses;
  const fusion::PoseInput in = pose_input(p);
  if (resume_ && !replaying_) {
    for (const auto& m : models_) m->core->resume_at(in.arrival_ns);
    resume_ = false;
  }
  for (const auto& m : models_) m->core->add_pose(in);
}

void FusionStage::add_scan(const StoredScan& s) {
  if (s.robot_id == 0 || s.robot_id > kMaxRobots) return;
  if (!replaying_) stored_latency_.add(s.recv_realtime_ns - s.stamp_ns);
  if (resume_) {
    for (const auto& m : models_) m->core->resume_at(s.recv_realtime_ns);
    resume_ = false;
  }
  add_scan_to_cores(scan_input(s, scratch_));
}

void FusionStage::on_release(const fusion::FusedScan& f) {
  ++counters_.scans;
  if (replaying_) ++counters_.replayed_scans;
  const std::span<const mapping::MapPoint> points = f.view->points;
  counters_.points += points.size();
  map_.add_all(points, f.removed);
  for (std::uint8_t r : f.removed) counters_.live_removed += r != 0 ? 1 : 0;
  if (replaying_) return;
  // The scan is now decided and in the fused map: its latency from the end of its sweep. Both stamps
  // are CLOCK_REALTIME (the robots' clocks are NTP-disciplined, DESIGN.md "Frames, units, time").
  const std::int64_t fused_ns = now_realtime().ns();
  fused_latency_.add(fused_ns - f.view->stamp_ns);
  if (latency_log_ != nullptr) {
    std::fprintf(latency_log_, "%u,%u,%lld,%lld,%lld\n", f.view->robot, f.view->scan, static_cast<long long>(f.view->stamp_ns),
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
        add_scan_to_cores(scan_input(s, buffers));
      },
      stats);
  replaying_ = false;
  resume_ = true;
  if (!st.ok()) return st.error();
  return stats.poses + stats.scans;
}

// A periodic write in the caller's thread: every core's model voxels taken with their decisions
// (snapshot_model_part) in parts of at most kRowsPerPart rows, handed to the writer thread, which
// streams them into the files; at most options().write_slice_ms per call (`all`: to the end). The
// parts in the queue are bounded (kMaxQueuedParts): when the writer lags, the loop waits for a later
// turn instead of holding more of the model. True when every model is taken.
bool FusionStage::advance_snapshot(bool all) {
  constexpr std::size_t kVoxelsPerStep = 64, kRowsPerPart = 16384, kMaxQueuedParts = 16;
  const Time t0 = now_monotonic();
  const auto slice = std::chrono::duration<double, std::milli>(options_.write_slice_ms);
  bool done = false, out_of_time = false, took = false;
  while (!done && !out_of_time) {
    fusion::ModelSnapshot part;
    {
      // In a loop turn the writer's mutex is only tried: held by the writer, the part waits a turn.
      std::unique_lock<std::mutex> lock(writer_mutex_, std::defer_lock);
      if (all) {
        lock.lock();
        writer_cv_.wait(lock, [&] { return writer_queue_.size() < kMaxQueuedParts; });
      } else if (!lock.try_lock()) {
        break;
      }
      if (writer_queue_.size() >= kMaxQueuedParts) break;
      if (!writer_spare_.empty()) {
        part = std::move(writer_spare_.back());
        writer_spare_.pop_back();
      }
    }
    part.points.clear();
    part.removed.clear();
    part.kept = 0;
    std::size_t part_model = snapshot_model_;
    while (snapshot_model_ < models_.size() && part.points.size() < kRowsPerPart) {
      Model& m = *models_[snapshot_model_];
      if (m.snapshot_next >= m.snapshot_end) {
        if (!part.points.empty()) break;  // a part holds one model's rows
        part_model = ++snapshot_model_;
        continue;
      }
      m.snapshot_next = m.core->snapshot_model_part(part, m.snapshot_next, std::min(kVoxelsPerStep, m.snapshot_end - m.snapshot_next));
      took = true;
      if (!all && now_monotonic() - t0 >= slice) {
        out_of_time = true;
        break;
      }
    }
    done = snapshot_model_ >= models_.size();
    if (!part.points.empty()) {
      std::lock_guard<std::mutex> lock(writer_mutex_);
      snapshot_report_.points += part.points.size();
      writer_queue_.push_back(WriterPart{part_model, std::move(part), false});
    }
    writer_cv_.notify_all();
  }
  const Time now = now_monotonic();
  const double took_s = to_seconds(now - t0);
  // The loop's figures without the writer's mutex: the writer reads snapshot_report_ only after it took
  // the write's last part, which is queued below, under the mutex, after these.
  snapshot_report_.snapshot_s += took_s;
  snapshot_report_.snapshot_slice_max_s = std::max(snapshot_report_.snapshot_slice_max_s, took_s);
  if (took) ++snapshot_report_.snapshot_slices;  // a turn that waited for the writer took nothing
  if (done) {
    snapshot_report_.snapshot_span_s = to_seconds(now - snapshot_started_);
    std::lock_guard<std::mutex> lock(writer_mutex_);
    writer_queue_.push_back(WriterPart{0, {}, true});  // the write ends: the writer finishes the files
  }
  writer_cv_.notify_all();
  if (!done) return false;
  snapshotting_ = false;
  return true;
}

void FusionStage::begin_snapshot() {
  snapshotting_ = true;
  write_pending_ = false;
  snapshot_started_ = now_monotonic();
  snapshot_model_ = 0;
  for (const auto& m : models_) {
    m->snapshot_next = 0;
    m->snapshot_end = m->core->model_voxels();  // voxels stored later wait for the next write
  }
  {
    std::lock_guard<std::mutex> lock(writer_mutex_);
    snapshot_report_ = ModelWriteReport{};
    snapshot_report_.on_writer_thread = true;
    writer_busy_ = true;
    writer_begin_ = true;
  }
  if (!writer_.joinable()) {
    writer_ = std::thread([this] {
      yield_to_the_loop();
      writer_affinity_error_.store(set_current_thread_cpus(options_.writer_cpus));
      writer_tid_.store(current_thread_id());
      writer_main();
    });
    writer_handle_ = writer_.native_handle();
  }
  writer_cv_.notify_all();
}

ThreadScheduling FusionStage::writer_scheduling() const {
  ThreadScheduling out = thread_scheduling(writer_handle_, writer_tid_.load());  // tid 0: not started yet
  out.affinity_error = writer_affinity_error_.load();
  return out;
}

void FusionStage::wait_writer_idle() {
  std::unique_lock<std::mutex> lock(writer_mutex_);
  writer_cv_.wait(lock, [&] { return !writer_busy_; });
}

void FusionStage::wait_for_write() {
  if (snapshotting_) (void)advance_snapshot(true);
  wait_writer_idle();
}

bool FusionStage::write_in_flight() const {
  if (snapshotting_) return true;
  // The loop does not wait for the writer: a mutex the writer holds means it is at work.
  std::unique_lock<std::mutex> lock(writer_mutex_, std::try_to_lock);
  return !lock.owns_lock() || writer_busy_;
}

// A finished write of the writer thread into the counters and the callback (the caller's thread).
bool FusionStage::collect_finished(bool wait) {
  {
    std::unique_lock<std::mutex> lock(writer_mutex_, std::defer_lock);
    if (wait) {
      lock.lock();
    } else if (!lock.try_lock()) {
      return false;  // the writer holds it: next turn
    }
    if (!writer_done_) return false;
    writer_done_ = false;
    last_write_ = writer_report_;
  }
  finish_write();
  return true;
}

void FusionStage::finish_write() {
  if (!last_write_.ok) {
    ++counters_.write_failures;
  } else {
    ++counters_.writes;
    counters_.last_write_kept = last_write_.kept;
    counters_.last_write_removed = last_write_.removed;
  }
  if (on_write_) on_write_(last_write_);
}

Status FusionStage::write_model() {
  if (snapshotting_) {  // a periodic write still being taken: this write replaces it (not in one piece here)
    {
      std::lock_guard<std::mutex> lock(writer_mutex_);
      writer_queue_.push_back(WriterPart{0, {}, true, true});
    }
    writer_cv_.notify_all();
    snapshotting_ = false;
  }
  wait_writer_idle();  // a periodic write being written finishes first
  (void)collect_finished(true);
  write_pending_ = false;  // this write serves a coalesced request
  const Time t0 = now_monotonic();
  ModelWriteReport report;
  for (const auto& m : models_) {
    auto fig = m->core->write_model(m->kept_path, m->all_path);
    if (!fig.ok()) {
      if (report.ok) report.error = fig.error();
      report.ok = false;
      continue;
    }
    report.points += fig.value().kept + fig.value().removed;
    if (m == models_.front()) {
      report.kept = fig.value().kept;
      report.removed = fig.value().removed;
    }
  }
  // All of it on this thread: the decisions and the files, in one piece.
  report.write_s = report.snapshot_s = report.snapshot_slice_max_s = report.snapshot_span_s = to_seconds(now_monotonic() - t0);
  report.snapshot_slices = 1;
  last_write_ = report;
  finish_write();
  if (!last_write_.ok) return last_write_.error;
  return ok_status();
}

void FusionStage::request_write() {
  if (write_in_flight()) {
    ++counters_.writes_coalesced;
    write_pending_ = true;
    return;
  }
  (void)collect_finished(true);  // its report before the next write's (the writer is idle: no wait)
  begin_snapshot();
  (void)advance_snapshot(false);
}

bool FusionStage::poll_write() {
  const bool finished = collect_finished(false);
  if (snapshotting_) {
    (void)advance_snapshot(false);
  } else if (write_pending_ && !write_in_flight()) {
    begin_snapshot();
    (void)advance_snapshot(false);
  }
  return finished;
}

// The writer thread: a write's parts, in order, into each model's files; the last part finishes them.
void FusionStage::writer_main() {
  std::vector<std::unique_ptr<fusion::ModelFileWriter>> files;
  double write_s = 0;  // this write's time on this thread
  std::unique_lock<std::mutex> lock(writer_mutex_);
  for (;;) {
    writer_cv_.wait(lock, [&] { return writer_begin_ || !writer_queue_.empty() || writer_stop_; });
    if (writer_begin_) {
      writer_begin_ = false;
      write_s = 0;
      lock.unlock();
      files.clear();
      for (const auto& m : models_) files.push_back(std::make_unique<fusion::ModelFileWriter>(m->kept_path, m->all_path));
      lock.lock();
      continue;
    }
    if (writer_queue_.empty()) return;  // stop, nothing in flight
    WriterPart part = std::move(writer_queue_.front());
    writer_queue_.pop_front();
    writer_cv_.notify_all();  // room in the queue
    lock.unlock();
    const Time t0 = now_monotonic();
    if (part.model < files.size()) files[part.model]->add(part.rows);
    ModelWriteReport done;
    if (part.abandon) {
      files.clear();  // no file written, the temporary ones removed
    } else if (part.last) {
      for (std::size_t i = 0; i < files.size(); ++i) {
        auto fig = files[i]->finish();
        if (!fig.ok()) {
          if (done.ok) done.error = fig.error();
          done.ok = false;
        } else if (i == 0) {
          done.kept = fig.value().kept;
          done.removed = fig.value().removed;
        }
      }
      files.clear();
    }
    write_s += to_seconds(now_monotonic() - t0);
    lock.lock();
    writer_spare_.push_back(std::move(part.rows));
    if (part.abandon) {
      writer_busy_ = false;
      writer_cv_.notify_all();
    } else if (part.last) {
      // The loop's figures of this write are final once its last part is queued.
      writer_report_ = snapshot_report_;
      writer_report_.write_s = write_s;
      writer_report_.ok = done.ok;
      writer_report_.error = done.error;
      writer_report_.kept = done.kept;
      writer_report_.removed = done.removed;
      writer_done_ = true;
      writer_busy_ = false;
      writer_cv_.notify_all();
    }
  }
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

void CorrectionShare::share(const fusion::FusionCore& core, TeamSource& team, Time at) {
  const registration::Registration* reg = core.registration();
  if (reg == nullptr) return;
  for (std::uint8_t id = 1; id <= kMaxRobots; ++id) {
    const fusion::PoseHistory::Correction* c = core.poses().correction_at(id, at.ns());
    if (c == nullptr) continue;
    Shared& s = shared_[id];
    const Pose2& m = c->map_from_odom;
    if (s.any && s.from_stamp_ns == c->from_stamp_ns && s.map_from_odom == m) continue;
    const registration::RobotCorrection* r = reg->correction(id);
    const std::uint64_t accepted = r != nullptr ? r->accepted : 0;
    team.set_correction(id, m.x_m, m.y_m, m.theta_rad, c->position_sigma_m, c->heading_sigma_rad, accepted != s.accepted);
    s = Shared{c->from_stamp_ns, m, accepted, true};
  }
}

}  // namespace teamscan::station
