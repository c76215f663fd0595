// The fused model's writer: snapshots, PCD files and the writer thread (model_writer.hpp).
#include "groundstation/fusion/model_writer.hpp"

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstdio>
#include <cstring>

#include <pthread.h>
#include <sched.h>
#include <sys/resource.h>

#include "common/clock.hpp"
#include "common/dataset/pcd.hpp"
#include "groundstation/fusion/core.hpp"

namespace teamscan::fusion {

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

Result<ModelFigures> write_model_files(const FusionCore& core, const std::string& kept_path, const std::string& all_path) {
  ModelFileWriter w(kept_path, all_path);
  ModelSnapshot part;
  for (std::size_t next = 0; next < core.model_voxels();) {
    part.points.clear();
    part.removed.clear();
    part.kept = 0;
    next = core.snapshot_model_part(part, next, 256);
    w.add(part);
  }
  return w.finish();
}

// One PCD being streamed: rows into NAME.rows.tmp, then NAME.tmp = header + rows, renamed to NAME.
struct ModelFileWriter::File {
  File(std::string p, bool with_keep) : path{std::move(p)}, rows_path{path + ".rows.tmp"}, all{with_keep} {
    rows_file = std::fopen(rows_path.c_str(), "w+b");
    if (rows_file == nullptr) error = errno != 0 ? errno : EIO;
  }
  ~File() {
    if (rows_file != nullptr) std::fclose(rows_file);
    std::remove(rows_path.c_str());
  }
  void add(const ModelPoint& m, bool removed) {
    std::uint8_t rec[21];
    std::memcpy(rec + 0, &m.p.x, 4);
    std::memcpy(rec + 4, &m.p.y, 4);
    std::memcpy(rec + 8, &m.p.z, 4);
    rec[12] = m.robot;
    std::memcpy(rec + 13, &m.seq, 4);
    std::memcpy(rec + 17, &m.beam, 2);
    rec[19] = removed ? 0 : 1;
    rec[20] = m.removed_at_release ? 0 : 1;
    const std::size_t n = all ? 21 : 19;
    if (used + n > buffer.size()) drain();
    std::memcpy(buffer.data() + used, rec, n);
    used += n;
    ++rows;
  }
  void drain() {
    if (used > 0 && error == 0 && std::fwrite(buffer.data(), 1, used, rows_file) != used) error = errno != 0 ? errno : EIO;
    used = 0;
  }
  // encode_pcd's header (common/dataset/pcd.hpp) for these fields, so the bytes are write_pcd's.
  [[nodiscard]] std::string header() const {
    const std::string n = std::to_string(rows);
    std::string h = "# .PCD v0.7 - Point Cloud Data file format\nVERSION 0.7\nFIELDS x y z robot scan beam";
    h += all ? " keep live_keep\nSIZE 4 4 4 1 4 2 1 1\nTYPE F F F U U U U U\nCOUNT 1 1 1 1 1 1 1 1"
             : "\nSIZE 4 4 4 1 4 2\nTYPE F F F U U U\nCOUNT 1 1 1 1 1 1";
    return h + "\nWIDTH " + n + "\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS " + n + "\nDATA binary\n";
  }
  [[nodiscard]] Status finish() {
    drain();
    if (error != 0) return Error{"fusion: cannot write the fused PCD", error};
    const std::string tmp = path + ".tmp";
    std::FILE* out = std::fopen(tmp.c_str(), "wb");
    if (out == nullptr) return Error{"fusion: cannot create the fused PCD", errno};
    const std::string h = header();
    bool ok = std::fwrite(h.data(), 1, h.size(), out) == h.size() && std::fflush(rows_file) == 0 && std::fseek(rows_file, 0, SEEK_SET) == 0;
    int err = ok ? 0 : (errno != 0 ? errno : EIO);
    while (ok) {
      const std::size_t got = std::fread(buffer.data(), 1, buffer.size(), rows_file);
      if (got > 0 && std::fwrite(buffer.data(), 1, got, out) != got) {
        ok = false;
        err = errno != 0 ? errno : EIO;
      }
      if (got < buffer.size()) {
        if (std::ferror(rows_file)) {
          ok = false;
          err = EIO;
        }
        break;
      }
    }
    if (std::fclose(out) != 0 && ok) {
      ok = false;
      err = errno;
    }
    if (!ok) {
      std::remove(tmp.c_str());
      return Error{"fusion: cannot write the fused PCD", err};
    }
    if (std::rename(tmp.c_str(), path.c_str()) != 0) {
      err = errno;
      std::remove(tmp.c_str());
      return Error{"fusion: cannot rename the fused PCD into place", err};
    }
    return ok_status();
  }

  std::string path, rows_path;
  bool all = false;
  std::FILE* rows_file = nullptr;
  int error = 0;
  std::array<std::uint8_t, 1 << 16> buffer{};
  std::size_t used = 0;
  std::uint64_t rows = 0;
};

ModelFileWriter::ModelFileWriter(std::string kept_path, std::string all_path)
    : kept_{std::make_unique<File>(std::move(kept_path), false)} {
  if (!all_path.empty()) all_ = std::make_unique<File>(std::move(all_path), true);
}

ModelFileWriter::~ModelFileWriter() = default;

void ModelFileWriter::add(std::span<const ModelPoint> points, std::span<const std::uint8_t> removed) {
  const std::size_t n = std::min(points.size(), removed.size());
  for (std::size_t i = 0; i < n; ++i) {
    const bool r = removed[i] != 0;
    if (r) {
      ++figures_.removed;
    } else {
      ++figures_.kept;
      kept_->add(points[i], false);
    }
    if (all_) all_->add(points[i], r);
  }
}

Result<ModelFigures> ModelFileWriter::finish() {
  if (Status st = kept_->finish(); !st.ok()) return st.error();
  if (all_) {
    if (Status st = all_->finish(); !st.ok()) return st.error();
  }
  return figures_;
}


ModelWriter::ModelWriter(std::vector<ModelTarget> targets, ModelWriterOptions options,
                         std::function<void(const ModelWriteReport&)> on_finished)
    : options_{std::move(options)}, on_finished_{std::move(on_finished)} {
  for (ModelTarget& t : targets) {
    Target x;
    static_cast<ModelTarget&>(x) = std::move(t);
    targets_.push_back(std::move(x));
  }
}

ModelWriter::~ModelWriter() {
  if (!writer_.joinable()) return;
  {
    std::lock_guard<std::mutex> lock(writer_mutex_);
    writer_stop_ = true;
  }
  writer_cv_.notify_all();
  writer_.join();  // a write in flight finishes first
}

// A periodic write in the caller's thread: every core's model voxels taken with their decisions
// (snapshot_model_part) in parts of at most kRowsPerPart rows, handed to the writer thread, which
// streams them into the files; at most options().write_slice_ms per call (`all`: to the end). The
// parts in the queue are bounded (kMaxQueuedParts): when the writer lags, the loop waits for a later
// turn instead of holding more of the model. True when every model is taken.
bool ModelWriter::advance_snapshot(bool all) {
  constexpr std::size_t kVoxelsPerStep = 64, kRowsPerPart = 16384, kMaxQueuedParts = 16;
  const Time t0 = now_monotonic();
  const auto slice = std::chrono::duration<double, std::milli>(options_.write_slice_ms);
  bool done = false, out_of_time = false, took = false;
  while (!done && !out_of_time) {
    ModelSnapshot part;
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
    while (snapshot_model_ < targets_.size() && part.points.size() < kRowsPerPart) {
      Target& m = targets_[snapshot_model_];
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
    done = snapshot_model_ >= targets_.size();
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

void ModelWriter::begin_snapshot() {
  snapshotting_ = true;
  write_pending_ = false;
  snapshot_started_ = now_monotonic();
  snapshot_model_ = 0;
  for (Target& m : targets_) {
    m.snapshot_next = 0;
    m.snapshot_end = m.core->model_voxels();  // voxels stored later wait for the next write
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

ThreadScheduling ModelWriter::scheduling() const {
  ThreadScheduling out = thread_scheduling(writer_handle_, writer_tid_.load());  // tid 0: not started yet
  out.affinity_error = writer_affinity_error_.load();
  return out;
}

void ModelWriter::wait_writer_idle() {
  std::unique_lock<std::mutex> lock(writer_mutex_);
  writer_cv_.wait(lock, [&] { return !writer_busy_; });
}

void ModelWriter::wait() {
  if (snapshotting_) (void)advance_snapshot(true);
  wait_writer_idle();
}

bool ModelWriter::in_flight() const {
  if (snapshotting_) return true;
  // The loop does not wait for the writer: a mutex the writer holds means it is at work.
  std::unique_lock<std::mutex> lock(writer_mutex_, std::try_to_lock);
  return !lock.owns_lock() || writer_busy_;
}

// A finished write of the writer thread into the counters and the callback (the caller's thread).
bool ModelWriter::collect_finished(bool wait) {
  {
    std::unique_lock<std::mutex> lock(writer_mutex_, std::defer_lock);
    if (wait) {
      lock.lock();
    } else if (!lock.try_lock()) {
      return false;  // the writer holds it: next turn
    }
    if (!writer_done_) return false;
    writer_done_ = false;
    last_ = writer_report_;
  }
  finish_write();
  return true;
}

void ModelWriter::finish_write() {
  if (on_finished_) on_finished_(last_);
}

const ModelWriteReport& ModelWriter::write_now() {
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
  for (const Target& m : targets_) {
    auto fig = write_model_files(*m.core, m.kept_path, m.all_path);
    if (!fig.ok()) {
      if (report.ok) report.error = fig.error();
      report.ok = false;
      continue;
    }
    report.points += fig.value().kept + fig.value().removed;
    if (&m == &targets_.front()) {
      report.kept = fig.value().kept;
      report.removed = fig.value().removed;
    }
  }
  // All of it on this thread: the decisions and the files, in one piece.
  report.write_s = report.snapshot_s = report.snapshot_slice_max_s = report.snapshot_span_s = to_seconds(now_monotonic() - t0);
  report.snapshot_slices = 1;
  last_ = report;
  finish_write();
  return last_;
}

bool ModelWriter::request() {
  if (in_flight()) {
    write_pending_ = true;
    return false;
  }
  (void)collect_finished(true);  // its report before the next write's (the writer is idle: no wait)
  begin_snapshot();
  (void)advance_snapshot(false);
  return true;
}

bool ModelWriter::poll() {
  const bool finished = collect_finished(false);
  if (snapshotting_) {
    (void)advance_snapshot(false);
  } else if (write_pending_ && !in_flight()) {
    begin_snapshot();
    (void)advance_snapshot(false);
  }
  return finished;
}

// The writer thread: a write's parts, in order, into each model's files; the last part finishes them.
void ModelWriter::writer_main() {
  std::vector<std::unique_ptr<ModelFileWriter>> files;
  double write_s = 0;  // this write's time on this thread
  std::unique_lock<std::mutex> lock(writer_mutex_);
  for (;;) {
    writer_cv_.wait(lock, [&] { return writer_begin_ || !writer_queue_.empty() || writer_stop_; });
    if (writer_begin_) {
      writer_begin_ = false;
      write_s = 0;
      lock.unlock();
      files.clear();
      for (const Target& m : targets_) files.push_back(std::make_unique<ModelFileWriter>(m.kept_path, m.all_path));
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

}  // namespace teamscan::fusion
