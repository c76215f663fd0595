// ModelWriter: the fused model written from the session files on a worker thread (model_writer.hpp).
#include "groundstation/station/model_writer.hpp"

#include <fcntl.h>
#include <malloc.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cinttypes>
#include <cstdio>
#include <cstring>

namespace teamscan::station {
namespace {

// Reads [0, limit) of `path` in chunks, handing each chunk to `f(bytes, n, at_end)`; f returns how
// many bytes it consumed (the rest is kept for the next chunk: a record may straddle two).
template <class F>
Status read_prefix(const std::string& path, std::uint64_t limit, F&& f) {
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) return Error{"fusion: cannot open a session file for the model", errno};
  constexpr std::size_t kChunk = 4u << 20;
  std::vector<std::uint8_t> buf(kChunk + kScanRecordMaxBytes);
  std::size_t have = 0;
  std::uint64_t read_total = 0;
  Status st = ok_status();
  for (;;) {
    const std::uint64_t want = std::min<std::uint64_t>(buf.size() - have, limit - read_total);
    ssize_t n = 0;
    if (want > 0) {
      n = ::read(fd, buf.data() + have, static_cast<std::size_t>(want));
      if (n < 0) {
        if (errno == EINTR) continue;
        st = Error{"fusion: cannot read a session file for the model", errno};
        break;
      }
    }
    have += static_cast<std::size_t>(n);
    read_total += static_cast<std::uint64_t>(n);
    const bool at_end = n == 0 || read_total >= limit;
    const std::size_t used = f(buf.data(), have, at_end);
    std::memmove(buf.data(), buf.data() + used, have - used);
    have -= used;
    if (at_end) break;
  }
  ::close(fd);
  return st;
}

// One poses.csv line (session_store.cpp append_pose) as the station's PoseObservation (station.cpp).
// `rejected`: the station refused the pose at receipt (the line's last column; older files have none).
bool parse_pose(const char* line, PoseObservation& p, unsigned& rejected) {
  long long recv_rt = 0, recv_mono = 0, stamp = 0;
  unsigned robot = 0, seq = 0;
  int x = 0, y = 0, yaw = 0, vx = 0, vy = 0, w = 0;
  rejected = 0;
  if (std::sscanf(line, "%lld,%lld,%u,%u,%lld,%d,%d,%d,%d,%d,%d,%u", &recv_rt, &recv_mono, &robot, &seq, &stamp, &x, &y,
                  &yaw, &vx, &vy, &w, &rejected) < 11) {
    return false;
  }
  p = PoseObservation{};
  p.robot_id = robot;
  p.seq = seq;
  p.stamp = Time::from_ns(stamp);
  p.received = Time::from_ns(recv_rt);
  p.x_m = x * 1e-3;
  p.y_m = y * 1e-3;
  p.yaw_rad = yaw * 1e-6;
  p.vx_mps = vx * 1e-3;
  p.vy_mps = vy * 1e-3;
  p.yaw_rate_radps = w * 1e-3;
  return true;
}

}  // namespace

Status read_received(const std::string& dir, const SessionSnapshot& snap, std::uint32_t replay_window, Dataset& out,
                     std::uint64_t& bad) {
  ReceivedBuilder b(true, replay_window, 0);
  bad = 0;
  // Poses first: the scans' own poses are recomputed from all poses at the end (refresh_scan_poses), as
  // the in-memory stage does, so only each robot's pose order (arrival order, file order) matters.
  bool header = true;
  Status st = read_prefix(dir + "/poses.csv", snap.poses_bytes, [&](const std::uint8_t* bytes, std::size_t n, bool) {
    std::size_t pos = 0;
    for (;;) {
      const void* nl = std::memchr(bytes + pos, '\n', n - pos);
      if (nl == nullptr) break;  // an incomplete line waits for the next chunk (or is the torn tail)
      const std::size_t end = static_cast<std::size_t>(static_cast<const std::uint8_t*>(nl) - bytes);
      std::string line(reinterpret_cast<const char*>(bytes + pos), end - pos);
      pos = end + 1;
      if (header) {
        header = false;
        if (line.rfind("recv_realtime_ns", 0) == 0) continue;
      }
      PoseObservation p;
      unsigned rejected = 0;
      if (!parse_pose(line.c_str(), p, rejected)) {
        ++bad;
        continue;
      }
      // Refused at the edge (sample_validation.hpp): stored raw, never fused.
      if (rejected != 0 || p.robot_id == 0 || p.robot_id > kMaxRobots) continue;
      b.add_pose(p);
    }
    return pos;
  });
  if (!st.ok()) return st;

  static thread_local StoredScan scan;
  ScanRecord rec;
  std::vector<mapping::MapPoint> points;
  std::vector<std::uint16_t> flags;
  points.reserve(kMaxBeams);
  flags.reserve(kMaxBeams);
  ScanDecodeStats stats;
  bool header_checked = false;
  bool bad_header = false;
  st = read_prefix(dir + "/scans.bin", snap.scans_bytes, [&](const std::uint8_t* bytes, std::size_t n, bool at_end) {
    std::size_t pos = 0;
    if (!header_checked) {
      if (n < kScanFileHeaderBytes && !at_end) return std::size_t{0};
      header_checked = true;
      if (n < kScanFileHeaderBytes || !std::equal(kScanFileMagic, kScanFileMagic + 8, bytes)) {
        bad_header = true;
        return n;
      }
      pos = kScanFileHeaderBytes;
    }
    if (bad_header) return n;
    // The decoder's resync (decode_scan_file): skip a byte on a bad record, wait for more on a short one.
    while (pos < n) {
      const long r = decode_scan_record(std::span<const std::uint8_t>(bytes + pos, n - pos), scan, stats);
      if (r > 0) {
        pos += static_cast<std::size_t>(r);
        // Refused at the edge (sample_validation.hpp): stored raw, never fused.
        if (scan.rejected != 0 || scan.robot_id == 0 || scan.robot_id > kMaxRobots) continue;
        b.add_scan(scan, rec, points, flags);
      } else if (r == 0) {
        if (at_end) pos = n;  // the torn tail of the snapshot: nothing more to read
        break;
      } else {
        ++pos;
        ++stats.bytes_skipped;
      }
    }
    return pos;
  });
  if (!st.ok()) return st;
  if (bad_header) return Error{"fusion: scans.bin has no teamscan header"};
  bad += stats.bad_crc + stats.bad_length;
  b.refresh_scan_poses();
  out = std::move(b.dataset());
  return ok_status();
}

ModelWriter::ModelWriter(FusionOptions options, std::string session_dir)
    : options_{std::move(options)}, dir_{std::move(session_dir)} {}

ModelWriter::~ModelWriter() { wait(); }

void ModelWriter::wait() {
  if (worker_.joinable()) worker_.join();
}

bool ModelWriter::start(SessionSnapshot snapshot) {
  if (in_flight_.load(std::memory_order_acquire)) return false;
  wait();  // the previous worker has finished: reap it
  in_flight_.store(true, std::memory_order_release);
  cancel_.store(false, std::memory_order_release);
  ++started_;
  worker_ = std::thread([this, snap = std::move(snapshot)]() {
    if (worker_hook_) worker_hook_();
    ModelWriteReport r = write(snap, {}, true);
    {
      std::lock_guard<std::mutex> lock(mutex_);
      report_ = std::move(r);
    }
    in_flight_.store(false, std::memory_order_release);
  });
  return true;
}

std::optional<ModelWriteReport> ModelWriter::take_report() {
  std::lock_guard<std::mutex> lock(mutex_);
  std::optional<ModelWriteReport> r = std::move(report_);
  report_.reset();
  return r;
}

ModelWriteReport ModelWriter::run(const SessionSnapshot& snap, const std::string& dataset_dir) {
  return write(snap, dataset_dir, false);
}

ModelWriteReport ModelWriter::write(const SessionSnapshot& snap, const std::string& dataset_dir, bool cancellable) {
  const auto t0 = std::chrono::steady_clock::now();
  ModelWriteReport r;
  r.why = snap.why;
  auto cancelled = [&] { return cancellable && cancel_.load(std::memory_order_acquire); };
  auto fail = [&](const Error& e) {
    r.ok = false;
    r.error = e.what;
    r.sys_errno = e.sys_errno;
  };
  try {
    Dataset received;
    Status st = read_received(dir_, snap, options_.replay_window, received, r.bad_records);
    if (st.ok() && cancelled()) {
      r.cancelled = true;
      r.error = "fusion: model write cancelled";
    } else if (st.ok()) {
      r.scans = received.scans.size();
      std::vector<std::uint8_t> removed;
      ModelFigures fig;
      st = write_fused_model(received, options_, dir_, snap.live_removed, removed, fig, cancelled);
      if (!st.ok() && cancelled()) r.cancelled = true;
      r.kept = fig.kept;
      r.removed = fig.removed;
    }
    if (st.ok() && !dataset_dir.empty()) st = write_received_as_dataset(received, dataset_dir);
    if (r.cancelled) {
      r.ok = false;
    } else if (st.ok()) {
      r.ok = true;
    } else {
      fail(st.error());
    }
  } catch (const std::exception& e) {  // bad_alloc on a huge session: reported, the station goes on
    r.ok = false;
    r.error = std::string("fusion: model write failed: ") + e.what();
  }
  // The read-back data set is gone: hand its pages back (glibc keeps a thread's freed arena otherwise,
  // and the station's RSS would stay at the size of the largest write).
  ::malloc_trim(0);
  r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return r;
}

}  // namespace teamscan::station
