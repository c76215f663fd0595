// A session folder (scans.bin + poses.csv, the complete raw record) read back as what the station
// received: every pose and scan in arrival order (merged by receive time), streamed in bounded memory,
// bad records skipped and counted. Used by the station after a restart (rebuilding the fusion core)
// and by `teamscan eval SESSION` (the session as a data set in time order, decided by the same core).
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "common/dataset/dataset.hpp"
#include "common/result.hpp"
#include "groundstation/fusion/time_line.hpp"
#include "groundstation/station/scan_record.hpp"
#include "groundstation/station/team_source.hpp"

namespace teamscan::station {

struct SessionReadStats {
  std::uint64_t poses = 0;
  std::uint64_t scans = 0;
  std::uint64_t bad_pose_lines = 0;
  std::uint64_t refused_poses = 0;     // marked refused at receipt (sample_validation.hpp): not replayed
  std::uint64_t refused_scans = 0;
  std::uint64_t bad_scan_records = 0;  // CRC / length failures (the decoder resyncs past them)
  std::uint64_t bad_robot_ids = 0;     // accepted samples with a robot id out of 1..kMaxRobots: skipped
  bool scans_torn_tail = false;        // scans.bin ends inside a record (a crash mid-write)
};

// How much of the files to read: the first `scans_bytes` of scans.bin and `poses_bytes` of poses.csv
// (whole records: the station appends each with one write(2)). The station's catch-up reads the folder as
// it was at one loop turn (its files' sizes then) while the loop appends to it.
struct SessionExtent {
  std::uint64_t scans_bytes = UINT64_MAX;
  std::uint64_t poses_bytes = UINT64_MAX;
};
// The files' sizes now (a missing file: 0).
[[nodiscard]] SessionExtent session_extent_now(const std::string& dir);

// One poses.csv line (session_store.cpp append_pose) as the station's PoseObservation; false: malformed.
// `rejected` (optional): the line's refusal code (sample_validation.hpp; 0 = accepted or an older file).
[[nodiscard]] bool parse_pose_line(const char* line, PoseObservation& out, std::uint16_t* rejected = nullptr);

// Streams `dir`/poses.csv and `dir`/scans.bin in receive order (recv_realtime_ns; a missing file is
// empty). Fails only when a file exists but cannot be read or scans.bin has no teamscan header. Only
// accepted samples with a robot id in 1..kMaxRobots are handed on (the rest counted): the consumers
// need not check either again.
[[nodiscard]] Status replay_session_files(const std::string& dir, const std::function<void(const PoseObservation&)>& on_pose,
                                          const std::function<void(const ScanPoints&, const Receipt&)>& on_scan,
                                          SessionReadStats& stats, const SessionExtent& extent = {});

// The session as a data set (no labels): odometry from poses.csv, every scan's placed points from
// scans.bin (a (robot, seq) stored twice, a DDS history replay, kept once), stamps as received, each
// scan's pose the fusion core's scan pose. `teamscan eval SESSION` runs on this.
[[nodiscard]] Result<Dataset> read_session_dataset(const std::string& dir, SessionReadStats& stats,
                                                   const SessionExtent& extent = {});

// A session's scans' points read back from scans.bin one scan at a time, by the offsets of their
// records (read_session_index): a time line over a long session holds its rows, not its points.
class SessionScanPoints final : public fusion::ScanPointsSource {
 public:
  // `fd` (owned, -1 with no offsets): scans.bin; offsets[row]: scan row `row`'s record.
  SessionScanPoints(int fd, std::uint32_t version, std::vector<std::uint64_t> offsets);
  ~SessionScanPoints() override;
  SessionScanPoints(const SessionScanPoints&) = delete;
  SessionScanPoints& operator=(const SessionScanPoints&) = delete;
  // The scan's points as read_session_dataset gives them; false (counted) if its record no longer reads.
  bool read(std::size_t row, fusion::ScanInput& in) override;
  [[nodiscard]] std::uint64_t failures() const { return failures_; }

 private:
  int fd_;
  std::uint32_t version_;
  std::vector<std::uint64_t> offsets_;
  std::vector<std::uint8_t> buf_;
  std::unique_ptr<ScanPoints> scan_;
  ScanDecodeStats decode_;
  std::uint64_t failures_ = 0;
};

// The session as read_session_dataset's data set without its points (Dataset::points empty), and where
// to read each scan row's points when they are fed (TimeLine's ScanPointsSource): the station's final
// model on the graph's poses reads a session of any length in memory for its rows alone.
struct SessionIndex {
  Dataset dataset;
  std::unique_ptr<SessionScanPoints> points;
};
[[nodiscard]] Result<SessionIndex> read_session_index(const std::string& dir, SessionReadStats& stats,
                                                      const SessionExtent& extent = {});

}  // namespace teamscan::station
