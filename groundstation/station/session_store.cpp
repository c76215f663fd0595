// SessionStore: append-only, one-write-per-record session files (see session_store.hpp).
#include "groundstation/station/session_store.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cinttypes>
#include <cstdio>
#include <cstring>
#include <ctime>
#include <filesystem>
#include <utility>

#include "common/error_message.hpp"
#include "teamscan.h"

namespace teamscan::station {
namespace {

int open_append(const std::string& path, bool& created) {
  struct stat st{};
  created = ::stat(path.c_str(), &st) != 0 || st.st_size == 0;
  int fd = -1;
  do {
    fd = ::open(path.c_str(), O_WRONLY | O_CREAT | O_APPEND | O_CLOEXEC, 0644);
  } while (fd < 0 && errno == EINTR);
  return fd;
}

std::string utc_stamp(Time realtime, bool compact) {
  const std::time_t secs = static_cast<std::time_t>(realtime.ns() / 1'000'000'000);
  std::tm tm{};
  ::gmtime_r(&secs, &tm);
  char buf[40];
  std::strftime(buf, sizeof buf, compact ? "%Y%m%dT%H%M%SZ" : "%Y-%m-%dT%H:%M:%S", &tm);
  if (compact) return buf;
  char out[64];
  std::snprintf(out, sizeof out, "%s.%03dZ", buf, static_cast<int>((realtime.ns() / 1'000'000) % 1000));
  return out;
}

Time realtime_now() {
  timespec ts{};
  ::clock_gettime(CLOCK_REALTIME, &ts);
  return Time::from_ns(static_cast<std::int64_t>(ts.tv_sec) * 1'000'000'000 + ts.tv_nsec);
}

}  // namespace

Result<SessionStore> SessionStore::create(const std::string& root) {
  std::error_code ec;
  std::filesystem::create_directories(root, ec);
  if (ec) return make_error("storage: cannot create the session root directory " + root, ec.value());
  const std::string dir = root + "/session-" + utc_stamp(realtime_now(), true) + "-" + std::to_string(::getpid());
  return open(dir);
}

Result<SessionStore> SessionStore::open(const std::string& dir) {
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  if (ec) return make_error("storage: cannot create the session directory " + dir, ec.value());
  SessionStore s;
  s.dir_ = dir;
  bool created_scans = false;
  bool created_poses = false;
  bool created_status = false;
  bool created_events = false;
  bool created_rejected = false;
  s.scans_fd_ = open_append(dir + "/scans.bin", created_scans);
  s.poses_fd_ = open_append(dir + "/poses.csv", created_poses);
  s.status_fd_ = open_append(dir + "/status.csv", created_status);
  s.events_fd_ = open_append(dir + "/events.log", created_events);
  s.rejected_fd_ = open_append(dir + "/rejected.csv", created_rejected);
  const int open_errno = errno;
  const std::pair<int, const char*> files[] = {{s.scans_fd_, "scans.bin"}, {s.poses_fd_, "poses.csv"}, {s.status_fd_, "status.csv"},
                                               {s.events_fd_, "events.log"}, {s.rejected_fd_, "rejected.csv"}};
  for (const auto& [fd, name] : files)
    if (fd < 0) return make_error("storage: cannot open " + dir + "/" + name, open_errno);
  if (created_scans) {
    std::uint8_t header[kScanFileHeaderBytes];
    encode_scan_file_header(header);
    s.write_all(s.scans_fd_, header, sizeof header);
  }
  if (created_poses) {
    static constexpr char kHeader[] =
        "recv_realtime_ns,recv_monotonic_ns,robot_id,seq,stamp_ns,x_mm,y_mm,yaw_urad,vx_mmps,vy_mmps,"
        "yaw_rate_mradps,rejected\n";
    s.write_all(s.poses_fd_, kHeader, sizeof kHeader - 1);
  }
  if (created_status) {
    static constexpr char kHeader[] =
        "recv_realtime_ns,recv_monotonic_ns,robot_id,seq,stamp_ns,arcos_state,lms_state,team_fresh,"
        "sip_rate_mhz,scan_rate_mhz,arcos_bad_packets,lms_bad_telegrams,lms_resyncs,scans_published,"
        "points_direction_filtered,dds_write_errors,uptime_s,arcos_reopens,lms_reopens,points_team_stale,"
        "points_no_pose,loop_max_us,clock_sync,teams_rejected,last_team_reject,corrections_applied,"
        "corrections_rejected,ring_unconfirmed,ring_dropped,shadow_ms,last_shadow_ms,backfill_total,"
        "backfill_remaining,rejected\n";
    s.write_all(s.status_fd_, kHeader, sizeof kHeader - 1);
  }
  if (created_rejected) {
    static constexpr char kHeader[] = "recv_realtime_ns,topic,robot_id,seq,stamp_ns,reason,value\n";
    s.write_all(s.rejected_fd_, kHeader, sizeof kHeader - 1);
  }
  return s;
}

SessionStore::SessionStore(SessionStore&& o) noexcept
    : dir_{std::move(o.dir_)},
      scans_fd_{std::exchange(o.scans_fd_, -1)},
      poses_fd_{std::exchange(o.poses_fd_, -1)},
      status_fd_{std::exchange(o.status_fd_, -1)},
      events_fd_{std::exchange(o.events_fd_, -1)},
      rejected_fd_{std::exchange(o.rejected_fd_, -1)},
      counters_{o.counters_} {}

SessionStore::~SessionStore() {
  sync();
  for (int fd : {scans_fd_, poses_fd_, status_fd_, events_fd_, rejected_fd_}) {
    if (fd >= 0) ::close(fd);
  }
}

void SessionStore::write_all(int fd, const void* data, std::size_t n) {
  // One write(2) per record: O_APPEND makes it land whole at the end of the file. A short write (disk
  // full) is retried for the rest, and a failure is counted, never fatal: the station keeps receiving.
  const auto* p = static_cast<const std::uint8_t*>(data);
  while (n > 0) {
    const ssize_t w = ::write(fd, p, n);
    if (w < 0) {
      if (errno == EINTR) continue;
      ++counters_.write_errors;
      return;
    }
    counters_.bytes += static_cast<std::uint64_t>(w);
    p += w;
    n -= static_cast<std::size_t>(w);
  }
}

namespace {
std::uint64_t file_bytes(int fd) {
  struct stat st{};
  return fd >= 0 && ::fstat(fd, &st) == 0 ? static_cast<std::uint64_t>(st.st_size) : 0;
}
}  // namespace

std::uint64_t SessionStore::scans_file_bytes() const { return file_bytes(scans_fd_); }
std::uint64_t SessionStore::poses_file_bytes() const { return file_bytes(poses_fd_); }

void SessionStore::append_scan(const ScanPoints& scan, const Receipt& receipt) {
  const std::size_t n = encode_scan_record(scan, receipt, std::span<std::uint8_t>(record_, sizeof record_));
  write_all(scans_fd_, record_, n);
  ++counters_.scans;
}

void SessionStore::append_pose(const teamscan_msg_RobotPose& p, const ReceiveTime& at, std::uint16_t rejected) {
  char line[256];
  const int n = std::snprintf(line, sizeof line,
                              "%" PRId64 ",%" PRId64 ",%" PRIu32 ",%" PRIu32 ",%" PRId64 ",%" PRId32 ",%" PRId32
                              ",%" PRId32 ",%" PRId32 ",%" PRId32 ",%" PRId32 ",%u\n",
                              at.realtime.ns(), at.monotonic.ns(), p.robot_id, p.seq, p.stamp_ns, p.x_mm, p.y_mm,
                              p.yaw_urad, p.vx_mmps, p.vy_mmps, p.yaw_rate_mradps, static_cast<unsigned>(rejected));
  write_all(poses_fd_, line, static_cast<std::size_t>(n));
  ++counters_.poses;
}

void SessionStore::append_status(const teamscan_msg_RobotStatus& s, const ReceiveTime& at, std::uint16_t rejected) {
  char line[512];
  const int n = std::snprintf(
      line, sizeof line,
      "%" PRId64 ",%" PRId64 ",%" PRIu32 ",%" PRIu32 ",%" PRId64 ",%u,%u,%u,%" PRIu32 ",%" PRIu32 ",%" PRIu32
      ",%" PRIu32 ",%" PRIu32 ",%" PRIu32 ",%" PRIu32 ",%" PRIu32 ",%" PRIu32 ",%" PRIu32 ",%" PRIu32 ",%" PRIu32
      ",%" PRIu32 ",%" PRIu32 ",%u,%" PRIu32 ",%" PRIu32 ",%" PRIu32 ",%" PRIu32 ",%" PRIu32 ",%" PRIu32 ",%" PRIu32
      ",%" PRIu32 ",%" PRIu32 ",%" PRIu32 ",%u\n",
      at.realtime.ns(), at.monotonic.ns(), s.robot_id, s.seq, s.stamp_ns, static_cast<unsigned>(s.arcos_state),
      static_cast<unsigned>(s.lms_state), static_cast<unsigned>(s.team_fresh), s.sip_rate_mhz, s.scan_rate_mhz,
      s.arcos_bad_packets, s.lms_bad_telegrams, s.lms_resyncs, s.scans_published, s.points_direction_filtered,
      s.dds_write_errors, s.uptime_s, s.arcos_reopens, s.lms_reopens, s.points_team_stale, s.points_no_pose,
      s.loop_max_us, static_cast<unsigned>(s.clock_sync), s.teams_rejected, s.last_team_reject,
      s.corrections_applied, s.corrections_rejected, s.ring_unconfirmed, s.ring_dropped, s.shadow_ms,
      s.last_shadow_ms, s.backfill_total, s.backfill_remaining, static_cast<unsigned>(rejected));
  write_all(status_fd_, line, static_cast<std::size_t>(n));
  ++counters_.statuses;
}

void SessionStore::append_rejected(const ReceiveTime& at, const char* topic, std::uint32_t robot_id, std::uint32_t seq,
                                   std::int64_t stamp_ns, const char* reason, std::int64_t value) {
  char line[192];
  const int n = std::snprintf(line, sizeof line, "%" PRId64 ",%s,%" PRIu32 ",%" PRIu32 ",%" PRId64 ",%s,%" PRId64 "\n",
                              at.realtime.ns(), topic, robot_id, seq, stamp_ns, reason, value);
  write_all(rejected_fd_, line, static_cast<std::size_t>(std::min<int>(n, static_cast<int>(sizeof line) - 1)));
}

bool SessionStore::write_file_atomically(const std::string& name, const std::string& text) const {
  const std::string path = dir_ + "/" + name;
  const std::string tmp = path + ".tmp";
  std::FILE* f = std::fopen(tmp.c_str(), "w");
  if (f == nullptr) return false;
  const bool ok = std::fwrite(text.data(), 1, text.size(), f) == text.size();
  if (std::fclose(f) != 0 || !ok) return false;
  return std::rename(tmp.c_str(), path.c_str()) == 0;
}

void SessionStore::log_event(Time realtime, const std::string& text) {
  const std::string line = std::to_string(realtime.ns()) + " " + utc_stamp(realtime, false) + " " + text + "\n";
  write_all(events_fd_, line.data(), line.size());
  ++counters_.events;
}

void SessionStore::sync() {
  for (int fd : {scans_fd_, poses_fd_, status_fd_, events_fd_, rejected_fd_}) {
    if (fd >= 0) (void)::fdatasync(fd);
  }
}

}  // namespace teamscan::station
