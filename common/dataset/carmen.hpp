// CARMEN log reader (`teamscan import carmen`): a robot's horizontal laser (FLASER lines: ranges
// spanning 180° from right to left, the pose fields = the robot's odometry at the scan; ROBOTLASER1
// lines: their own angles and the laser's pose beside the robot's) and ODOM lines, turned into a data
// set without truth that `teamscan eval` and registration accept. Every stamp is kept exactly (integer
// microseconds from the text) and file order is the scans' order, even where a stamp steps back.
// Pure parser: text in, records and counters out; a malformed line is counted with its reason.
#pragma once

#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "common/dataset/dataset.hpp"
#include "common/result.hpp"

namespace teamscan {

// A CARMEN stamp (`ipc_timestamp`, seconds with up to six decimals) as exact integer microseconds;
// false for a field that is not such a number. More than six decimals round to the microsecond.
[[nodiscard]] bool parse_carmen_stamp_us(std::string_view text, std::int64_t& stamp_us);

// A line's fields, split at spaces, tabs and carriage returns (CARMEN logs and relation files alike).
[[nodiscard]] std::vector<std::string_view> split_carmen_fields(std::string_view line);

struct CarmenLaser {
  std::vector<float> ranges_m;
  Pose2 pose;                  // the robot's odometry at the scan (FLASER: the odometry fields)
  Pose2 robot_from_laser;      // ROBOTLASER1: its laser pose relative to its robot pose; FLASER: identity
  double start_angle_rad = 0;  // beam 0's angle in the laser frame (right = negative)
  double angle_step_rad = 0;   // between beams (left-turning)
  double max_range_m = 0;      // ROBOTLASER1: the laser's own maximum range, a reading at or beyond it no
                               // return (0: not given, FLASER)
  double stamp_s = 0;          // the line's timestamp (the ipc_timestamp, third-from-last field)
  std::int64_t stamp_us = 0;   // the same, exactly
  std::size_t file_order = 0;  // index among all laser and ODOM lines, in file order
};

struct CarmenOdom {
  Pose2 pose;
  double v_mps = 0, w_radps = 0;
  double stamp_s = 0;
  std::int64_t stamp_us = 0;
  std::size_t file_order = 0;
};

struct CarmenLog {
  std::vector<CarmenLaser> lasers;  // FLASER and ROBOTLASER1 lines, in file order
  std::vector<CarmenOdom> odom;     // ODOM lines, in file order
  std::uint64_t lines = 0, comments = 0, other_messages = 0, malformed = 0;
  std::string first_error;  // "line N: reason" of the first malformed line
};

[[nodiscard]] CarmenLog parse_carmen(std::string_view text);

struct CarmenImportOptions {
  double mount_height_m = 0.3;     // the laser's height: every point sits at it (the floor is z = 0)
  double max_range_m = 50.0;       // beams at or beyond this are "no return" (81.83 m in the Intel log),
                                   // or beyond a ROBOTLASER1 line's own maximum if that is shorter
  double min_range_m = 0.05;
  // FLASER beam spacing: false (the default) = the n beams span the 180° field end to end (180°/(n−1)
  // apart); true = 180°/n apart from −90° (the last beam one step short of +90°).
  bool flaser_step_is_fov_over_n = false;
  std::string name = "carmen";
};

// The processing clock: every laser and ODOM line in file order at its source stamp unless that steps
// back, then 1 µs after the line before (file order is the true order). Per laser line and per ODOM
// line (their indices in the log), in µs.
struct CarmenProcessingClock {
  std::vector<std::int64_t> laser_us, odom_us;
  std::int64_t first_us = 0, last_us = 0;
};
[[nodiscard]] CarmenProcessingClock carmen_processing_clock(const CarmenLog& log);

// A data set without truth: one robot, its scans and points (map frame = the odometry frame), its
// odometry samples (ODOM lines if any, else the scans' poses). Scans and odometry keep file order:
// their processing stamps (`stamp_ns`, from the first line) never step back (a line stamped before an
// earlier one is processed 1 µs after it), and each scan keeps its exact source stamp
// (ScanRecord::source_stamp_us) for trajectories and relations. The laser's offset of ROBOTLASER1
// lines is the robot's mount (its first line's; the points use each line's own).
[[nodiscard]] Result<Dataset> carmen_to_dataset(const CarmenLog& log, const CarmenImportOptions& options);

}  // namespace teamscan
