// The ground station's session folder: everything received, with its receive time, in append-only
// files written with one write(2) per record (DESIGN.md "Files": the station stores everything it receives).
//   session-<UTC time>-<pid>/scans.bin   every scan (format in scan_record.hpp)
//   session-.../poses.csv                every pose
//   session-.../status.csv               every status sample
//   session-.../events.log               robots seen / lost / back, gaps, start and stop
//   session-.../rejected.csv             every sample refused at the edge: topic, raw header, reason, value
//                                        (the sample itself is in scans.bin / poses.csv / status.csv, marked)
// A write(2) hands the bytes to the kernel, so a crash or kill of this process (or of a fusion stage in
// it) loses nothing already received; sync() (on stop; DiskSync periodically, off the receive loop)
// makes them durable on disk.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "common/result.hpp"
#include "common/time.hpp"
#include "groundstation/station/scan_record.hpp"

struct teamscan_msg_RobotPose;
struct teamscan_msg_RobotStatus;

namespace teamscan::station {

struct ReceiveTime {
  Time realtime;   // CLOCK_REALTIME at take: comparable with the robots' stamps
  Time monotonic;  // CLOCK_MONOTONIC at take: for latencies
};

struct SessionCounters {
  std::uint64_t scans = 0;
  std::uint64_t poses = 0;
  std::uint64_t statuses = 0;
  std::uint64_t events = 0;
  std::uint64_t write_errors = 0;  // a failed or short write (disk full...): counted and logged
  std::uint64_t bytes = 0;
};

class SessionStore {
 public:
  // Creates <root>/session-<UTC yyyymmddThhmmssZ>-<pid>/ (root is created if missing) and the files.
  [[nodiscard]] static Result<SessionStore> create(const std::string& root);
  // Opens an exact folder (created if missing); files are appended to if they exist.
  [[nodiscard]] static Result<SessionStore> open(const std::string& dir);

  SessionStore(SessionStore&& o) noexcept;
  SessionStore& operator=(SessionStore&&) = delete;
  SessionStore(const SessionStore&) = delete;
  SessionStore& operator=(const SessionStore&) = delete;
  ~SessionStore();  // syncs and closes

  // One scans.bin record: the scan and its receipt.
  void append_scan(const ScanPoints& scan, const Receipt& receipt);
  // `rejected`: the Reject code of sample_validation.hpp (0 = accepted), the last column of the line.
  void append_pose(const teamscan_msg_RobotPose& pose, const ReceiveTime& at, std::uint16_t rejected = 0);
  void append_status(const teamscan_msg_RobotStatus& status, const ReceiveTime& at, std::uint16_t rejected = 0);
  // One line of rejected.csv: recv_realtime_ns,topic,robot_id,seq,stamp_ns,reason,value.
  void append_rejected(const ReceiveTime& at, const char* topic, std::uint32_t robot_id, std::uint32_t seq,
                       std::int64_t stamp_ns, const char* reason, std::int64_t value);
  // Replaces NAME in the session folder with `text` (NAME.tmp, then rename(2)).
  [[nodiscard]] bool write_file_atomically(const std::string& name, const std::string& text) const;
  // One line "<recv realtime ns> <UTC time> <text>".
  void log_event(Time realtime, const std::string& text);
  // fdatasync every file.
  void sync();
  // The open files' descriptors (for DiskSync, which flushes them off the receive loop).
  [[nodiscard]] std::vector<int> file_descriptors() const {
    return {scans_fd_, poses_fd_, status_fd_, events_fd_, rejected_fd_};
  }
  // Current sizes of scans.bin and poses.csv (fstat): after sync(), a prefix that is on disk, which a
  // separate reader (ModelWriter) can read back while the loop goes on appending.
  [[nodiscard]] std::uint64_t scans_file_bytes() const;
  [[nodiscard]] std::uint64_t poses_file_bytes() const;

  [[nodiscard]] const std::string& dir() const { return dir_; }
  [[nodiscard]] const SessionCounters& counters() const { return counters_; }

 private:
  SessionStore() = default;
  void write_all(int fd, const void* data, std::size_t n);

  std::string dir_;
  int scans_fd_ = -1;
  int poses_fd_ = -1;
  int status_fd_ = -1;
  int events_fd_ = -1;
  int rejected_fd_ = -1;
  SessionCounters counters_{};
  std::uint8_t record_[kScanRecordMaxBytes] = {};
};

}  // namespace teamscan::station
