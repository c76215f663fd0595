// Trajectories in the TUM RGB-D benchmark's text format (`t x y z qx qy qz qw`, one pose a line), the
// format SLAM evaluation tools (evo, the TUM scripts) read: a robot's poses, one line per scan in
// processing order, `t` the scan's own stamp to the microsecond.
#pragma once

#include <array>
#include <cstdint>
#include <cstdio>
#include <map>
#include <string>
#include <vector>

#include "common/dataset/dataset.hpp"
#include "common/pose.hpp"
#include "common/result.hpp"

namespace teamscan::trajectory {

struct StampedPose {
  std::int64_t stamp_us = 0;  // µs since the epoch of the source (the Unix epoch for a CARMEN log)
  Pose2 pose;                 // map_from_robot
};

// A scan's stamp for trajectories and relations: its source stamp (an imported log's ipc_timestamp),
// else its processing stamp rounded to the microsecond.
[[nodiscard]] std::int64_t scan_stamp_us(const ScanRecord& scan);

// One TUM line: the stamp with exactly six decimals, the planar pose at z = 0 as a unit quaternion
// about z, numbers that read back to the same doubles.
[[nodiscard]] std::string tum_line(const StampedPose& p);

// Every pose in the given order, one line each.
[[nodiscard]] std::string tum_text(const std::vector<StampedPose>& poses);

// Per robot of the data set, `robot<N>.tum` in `dir` (created if missing): the poses of its scans in
// the data set's order, `poses[i]` being the pose of `dataset.scans[i]`; rows with `decided[i] == 0`
// (a scan the fusion core never released) are left out when `decided` is not empty.
[[nodiscard]] Status write_tum_per_robot(const std::string& dir, const Dataset& dataset, const std::vector<Pose2>& poses,
                                         const std::vector<std::uint8_t>& decided = {});

// Per robot, `robot<N><suffix>.tum` in `dir` (created if missing) with its poses in the given order,
// each file written whole (NAME.tmp, then renamed over the old one).
[[nodiscard]] Status write_tum_files(const std::string& dir, const std::map<std::uint8_t, std::vector<StampedPose>>& by_robot,
                                     const std::string& suffix = "");

// The live station's trajectories: `robot<N>.tum` in a session folder, one line appended per decided
// scan (opened on a robot's first scan, appending to what an earlier run of the session wrote).
// Buffered stdio: flush() at model writes and at the end.
class TumAppender {
 public:
  explicit TumAppender(std::string dir) : dir_(std::move(dir)) {}
  ~TumAppender();
  TumAppender(const TumAppender&) = delete;
  TumAppender& operator=(const TumAppender&) = delete;
  // False when the robot's file cannot be opened (counted: failures()).
  bool add(std::uint8_t robot, const StampedPose& pose);
  void flush();
  [[nodiscard]] std::uint64_t failures() const { return failures_; }

 private:
  std::string dir_;
  std::array<std::FILE*, 256> files_{};
  std::uint64_t failures_ = 0;
};

}  // namespace teamscan::trajectory
