// Session folder read back in arrival order (session_replay.hpp).
#include "groundstation/station/session_replay.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <limits>
#include <memory>
#include <set>
#include <vector>

#include "groundstation/fusion/pose_history.hpp"
#include "groundstation/station/fusion.hpp"

namespace teamscan::station {

bool parse_pose_line(const char* line, PoseObservation& p, std::uint16_t* rejected_out) {
  long long recv_rt = 0, recv_mono = 0, stamp = 0;
  unsigned robot = 0, seq = 0;
  int x = 0, y = 0, yaw = 0, vx = 0, vy = 0, w = 0;
  unsigned rejected = 0;  // the trailing column (sample_validation.hpp Reject); absent in older sessions
  const int fields = std::sscanf(line, "%lld,%lld,%u,%u,%lld,%d,%d,%d,%d,%d,%d,%u", &recv_rt, &recv_mono, &robot, &seq,
                                 &stamp, &x, &y, &yaw, &vx, &vy, &w, &rejected);
  if (fields < 11) return false;
  p = PoseObservation{};
  if (rejected_out != nullptr) *rejected_out = static_cast<std::uint16_t>(fields == 12 ? rejected : 0u);
  p.robot_id = robot;
  p.seq = seq;
  p.stamp = Time::from_ns(stamp);
  p.received = Time::from_ns(recv_rt);
  // The same conversion as the station's take (station.cpp): the wire's mm, µrad, mm/s, mrad/s.
  p.x_m = x * 1e-3;
  p.y_m = y * 1e-3;
  p.yaw_rad = yaw * 1e-6;
  p.vx_mps = vx * 1e-3;
  p.vy_mps = vy * 1e-3;
  p.yaw_rate_radps = w * 1e-3;
  return true;
}

namespace {

// scans.bin streamed in chunks: next() decodes one record at a time (resyncing past bad bytes).
class ScanFileStream {
 public:
  ScanFileStream(SessionReadStats& stats, std::uint64_t limit_bytes) : stats_{stats}, left_{limit_bytes} {}
  ~ScanFileStream() {
    if (fd_ >= 0) ::close(fd_);
  }
  ScanFileStream(const ScanFileStream&) = delete;
  ScanFileStream& operator=(const ScanFileStream&) = delete;

  Status open(const std::string& path) {
    fd_ = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
    if (fd_ < 0) {
      if (errno == ENOENT) return ok_status();  // no scans yet
      return Error{"session: cannot open scans.bin", errno};
    }
    buf_.resize(kChunk + kScanRecordMaxBytes);
    if (Status st = fill(); !st.ok()) return st;
    if (have_ == 0) return ok_status();  // empty file
    version_ = scan_file_version(std::span<const std::uint8_t>(buf_.data(), have_));
    if (version_ == 0) return Error{"session: scans.bin has no teamscan header"};
    if (version_ != 1 && version_ != kScanFileVersion) return Error{"session: scans.bin of an unknown version"};
    pos_ = kScanFileHeaderBytes;
    return ok_status();
  }

  // false at the end (or on a read error: error()).
  bool next(ScanPoints& out, Receipt& receipt) {
    for (;;) {
      if (fd_ < 0) return false;
      if (pos_ < have_) {
        const long r =
            decode_scan_record(std::span<const std::uint8_t>(buf_.data() + pos_, have_ - pos_), out, receipt, decode_,
                               version_);
        if (r > 0) {
          offset_ = consumed_ + pos_;
          pos_ += static_cast<std::size_t>(r);
          return true;
        }
        if (r < 0) {
          ++pos_;
          continue;
        }
      }
      // Need more bytes (or at the end).
      if (eof_) {
        if (pos_ < have_) stats_.scans_torn_tail = true;
        stats_.bad_scan_records = decode_.bad_crc + decode_.bad_length;
        return false;
      }
      std::memmove(buf_.data(), buf_.data() + pos_, have_ - pos_);
      have_ -= pos_;
      consumed_ += pos_;
      pos_ = 0;
      if (Status st = fill(); !st.ok()) {
        error_ = st;
        return false;
      }
    }
  }
  [[nodiscard]] const Status& error() const { return error_; }
  // The file offset of the record next() returned last, and the file's version.
  [[nodiscard]] std::uint64_t offset() const { return offset_; }
  [[nodiscard]] std::uint32_t version() const { return version_; }

 private:
  static constexpr std::size_t kChunk = 4u << 20;
  Status fill() {
    while (have_ < buf_.size() && !eof_) {
      const std::size_t want = static_cast<std::size_t>(std::min<std::uint64_t>(buf_.size() - have_, left_));
      if (want == 0) {
        eof_ = true;  // the extent read
        break;
      }
      const ssize_t n = ::read(fd_, buf_.data() + have_, want);
      if (n < 0) {
        if (errno == EINTR) continue;
        return Error{"session: cannot read scans.bin", errno};
      }
      if (n == 0) eof_ = true;
      have_ += static_cast<std::size_t>(n);
      left_ -= static_cast<std::uint64_t>(n);
    }
    return ok_status();
  }
  SessionReadStats& stats_;
  ScanDecodeStats decode_;
  int fd_ = -1;
  std::vector<std::uint8_t> buf_;
  std::size_t have_ = 0, pos_ = 0;
  std::uint64_t consumed_ = 0;  // the file's bytes before buf_[0]
  std::uint64_t offset_ = 0;
  std::uint64_t left_;  // bytes of the file still to read (SessionExtent)
  bool eof_ = false;
  std::uint32_t version_ = kScanFileVersion;
  Status error_ = ok_status();
};

// poses.csv streamed line by line.
class PoseFileStream {
 public:
  PoseFileStream(SessionReadStats& stats, std::uint64_t limit_bytes) : stats_{stats}, left_{limit_bytes} {}
  void open(const std::string& path) { in_.open(path); }
  bool next(PoseObservation& out) {
    std::string line;
    while (in_ && left_ > 0 && std::getline(in_, line)) {
      // A line beyond the extent (appended after it was taken) is not read.
      if (line.size() >= left_) {
        left_ = 0;
        return false;
      }
      left_ -= line.size() + 1;
      if (line.empty() || line.rfind("recv_realtime_ns", 0) == 0) continue;
      std::uint16_t rejected = 0;
      if (!parse_pose_line(line.c_str(), out, &rejected)) {
        ++stats_.bad_pose_lines;
        continue;
      }
      if (rejected != 0) {  // refused at the edge: stored raw, never fused (live or replayed)
        ++stats_.refused_poses;
        continue;
      }
      return true;
    }
    return false;
  }

 private:
  SessionReadStats& stats_;
  std::uint64_t left_;  // bytes of the file still to read (SessionExtent)
  std::ifstream in_;
};

// The session files are an edge like the network: an accepted sample's robot id was checked at receipt,
// but a file may come from elsewhere. One with an id out of 1..kMaxRobots is skipped and counted here,
// so that no consumer checks it again.
bool valid_robot(std::uint32_t robot_id, SessionReadStats& stats) {
  if (robot_id >= 1 && robot_id <= kMaxRobots) return true;
  ++stats.bad_robot_ids;
  return false;
}

}  // namespace

SessionExtent session_extent_now(const std::string& dir) {
  SessionExtent e;
  struct stat st{};
  e.scans_bytes = ::stat((dir + "/scans.bin").c_str(), &st) == 0 ? static_cast<std::uint64_t>(st.st_size) : 0;
  e.poses_bytes = ::stat((dir + "/poses.csv").c_str(), &st) == 0 ? static_cast<std::uint64_t>(st.st_size) : 0;
  return e;
}

namespace {

// replay_session_files, each scan with its record's offset in scans.bin and the file's version.
using OnScanAt = std::function<void(const ScanPoints&, const Receipt&, std::uint64_t offset, std::uint32_t version)>;
Status replay_files(const std::string& dir, const std::function<void(const PoseObservation&)>& on_pose, const OnScanAt& on_scan,
                    SessionReadStats& stats, const SessionExtent& extent) {
  PoseFileStream poses(stats, extent.poses_bytes);
  poses.open(dir + "/poses.csv");
  ScanFileStream scans(stats, extent.scans_bytes);
  if (Status st = scans.open(dir + "/scans.bin"); !st.ok()) return st;
  auto scan = std::make_unique<ScanPoints>();
  Receipt receipt;
  PoseObservation pose;
  bool have_pose = poses.next(pose), have_scan = scans.next(*scan, receipt);
  // Merged by receive time; a pose before a scan received in the same nanosecond (the loop takes poses
  // first, station.cpp).
  while (have_pose || have_scan) {
    if (have_pose && (!have_scan || pose.received.ns() <= receipt.recv_realtime_ns)) {
      if (valid_robot(pose.robot_id, stats)) {
        ++stats.poses;
        on_pose(pose);
      }
      have_pose = poses.next(pose);
    } else {
      if (receipt.rejected != 0) {
        ++stats.refused_scans;  // refused at the edge: stored raw, never fused (live or replayed)
      } else if (valid_robot(scan->robot_id, stats)) {
        ++stats.scans;
        on_scan(*scan, receipt, scans.offset(), scans.version());
      }
      have_scan = scans.next(*scan, receipt);
    }
  }
  return scans.error();
}

}  // namespace

Status replay_session_files(const std::string& dir, const std::function<void(const PoseObservation&)>& on_pose,
                            const std::function<void(const ScanPoints&, const Receipt&)>& on_scan,
                            SessionReadStats& stats, const SessionExtent& extent) {
  return replay_files(dir, on_pose, [&](const ScanPoints& s, const Receipt& r, std::uint64_t, std::uint32_t) { on_scan(s, r); },
                      stats, extent);
}

namespace {

// The session as a data set; with `offsets`, its points left out and each scan row's record offset
// there instead (and the file's version in `version`).
Result<Dataset> read_session(const std::string& dir, SessionReadStats& stats, const SessionExtent& extent,
                             std::vector<std::uint64_t>* offsets, std::uint32_t* version) {
  Dataset ds;
  ds.scenario = "session";
  std::set<std::pair<std::uint32_t, std::uint32_t>> seen;
  std::set<std::uint8_t> robots;
  fusion::ScanInput input;
  Status st = replay_files(
      dir,
      [&](const PoseObservation& p) {
        const fusion::PoseInput in = pose_input(p);
        ds.odom.push_back({in.robot, in.stamp_ns, in.odom, in.v_mps, in.w_radps});
        robots.insert(in.robot);
      },
      [&](const ScanPoints& s, const Receipt& receipt, std::uint64_t offset, std::uint32_t file_version) {
        if (!seen.emplace(s.robot_id, s.seq).second) return;  // a DDS history replay: stored twice
        const fusion::ScanInput& in = scan_input(s, receipt, input);
        ScanRecord r;
        r.robot = in.robot;
        r.scan = in.scan;
        r.stamp_ns = in.stamp_ns;
        r.beams = static_cast<std::uint16_t>(std::min<std::size_t>(s.count, kMaxBeams));
        r.points = static_cast<std::uint16_t>(in.points.size());
        r.origin = in.origin_m;
        ds.scans.push_back(r);
        robots.insert(in.robot);
        if (offsets != nullptr) {
          offsets->push_back(offset);
          *version = file_version;
          return;
        }
        for (std::size_t i = 0; i < in.points.size(); ++i) {
          LabelledPoint lp;
          lp.x = in.points[i].x;
          lp.y = in.points[i].y;
          lp.z = in.points[i].z;
          lp.tx = lp.x;
          lp.ty = lp.y;
          lp.tz = lp.z;
          lp.robot = in.robot;
          lp.scan = in.scan;
          lp.beam = in.beams[i];
          lp.flags = in.flags[i];
          ds.points.push_back(lp);
        }
      },
      stats, extent);
  if (!st.ok()) return st.error();
  // Each scan's pose as the core decides it (for exports and pictures; the core recomputes it).
  std::stable_sort(ds.odom.begin(), ds.odom.end(), [](const TrajectorySample& a, const TrajectorySample& b) {
    return a.robot != b.robot ? a.robot < b.robot : a.stamp_ns < b.stamp_ns;
  });
  fusion::PoseHistory history(fusion::PoseHistoryOptions{{}, 1e9});
  for (const TrajectorySample& s : ds.odom) history.add({s.robot, s.stamp_ns, s.stamp_ns, s.pose, s.v_mps, s.w_radps});
  for (ScanRecord& r : ds.scans) {
    const auto pose = history.scan_pose(r.robot, r.stamp_ns);
    r.pose = pose.found ? pose.map_from_robot : Pose2{r.origin.x, r.origin.y, 0.0};
    r.true_pose = r.pose;
  }
  ds.truth = ds.odom;  // no ground truth at the station: the odometry stands in
  for (std::uint8_t id : robots) {
    DatasetRobot r;
    r.id = id;
    r.name = "robot" + std::to_string(id);
    ds.robots.push_back(r);
  }
  return ds;
}

}  // namespace

Result<Dataset> read_session_dataset(const std::string& dir, SessionReadStats& stats, const SessionExtent& extent) {
  return read_session(dir, stats, extent, nullptr, nullptr);
}

SessionScanPoints::SessionScanPoints(int fd, std::uint32_t version, std::vector<std::uint64_t> offsets)
    : fd_{fd}, version_{version}, offsets_{std::move(offsets)}, buf_(kScanRecordMaxBytes), scan_{std::make_unique<ScanPoints>()} {}

SessionScanPoints::~SessionScanPoints() {
  if (fd_ >= 0) ::close(fd_);
}

bool SessionScanPoints::read(std::size_t row, fusion::ScanInput& in) {
  if (row < offsets_.size()) {
    ssize_t n = -1;
    do n = ::pread(fd_, buf_.data(), buf_.size(), static_cast<off_t>(offsets_[row]));
    while (n < 0 && errno == EINTR);
    Receipt receipt;
    if (n > 0 && decode_scan_record(std::span<const std::uint8_t>(buf_.data(), static_cast<std::size_t>(n)), *scan_, receipt,
                                    decode_, version_) > 0) {
      (void)scan_input(*scan_, receipt, in);
      return true;
    }
  }
  ++failures_;
  in.points.clear();
  in.flags.clear();
  in.beams.clear();
  return false;
}

Result<SessionIndex> read_session_index(const std::string& dir, SessionReadStats& stats, const SessionExtent& extent) {
  std::vector<std::uint64_t> offsets;
  std::uint32_t version = kScanFileVersion;
  Result<Dataset> ds = read_session(dir, stats, extent, &offsets, &version);
  if (!ds) return ds.error();
  int fd = -1;
  if (!offsets.empty()) {
    fd = ::open((dir + "/scans.bin").c_str(), O_RDONLY | O_CLOEXEC);
    if (fd < 0) return Error{"session: cannot open scans.bin again to read its points", errno};
  }
  return SessionIndex{std::move(ds.value()), std::make_unique<SessionScanPoints>(fd, version, std::move(offsets))};
}

}  // namespace teamscan::station
