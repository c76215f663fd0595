// CARMEN log reader (`teamscan import carmen`): a robot's horizontal laser (FLASER lines: ranges
// spanning 180° from right to left, the pose fields = the robot's odometry at the scan) and ODOM lines,
// turned into a data set without truth that `teamscan eval` and registration accept. Pure parser:
// text in, records and counters out; a malformed line is counted with its reason, never fatal.
#pragma once

#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "common/dataset/dataset.hpp"
#include "common/result.hpp"

namespace teamscan {

struct CarmenLaser {
  std::vector<float> ranges_m;
  Pose2 pose;          // the line's x y theta (odometry in these logs)
  double stamp_s = 0;  // the line's timestamp (third-from-last field)
};

struct CarmenOdom {
  Pose2 pose;
  double v_mps = 0, w_radps = 0;
  double stamp_s = 0;
};

struct CarmenLog {
  std::vector<CarmenLaser> lasers;
  std::vector<CarmenOdom> odom;
  std::uint64_t lines = 0, comments = 0, other_messages = 0, malformed = 0;
  std::string first_error;  // "line N: reason" of the first malformed line
};

[[nodiscard]] CarmenLog parse_carmen(std::string_view text);

struct CarmenImportOptions {
  double mount_height_m = 0.3;     // the laser's height: every point sits at it (the floor is z = 0)
  double max_range_m = 50.0;       // beams at or beyond this are "no return" (81.83 m in the Intel log)
  double min_range_m = 0.05;
  std::string name = "carmen";
};

// A data set without truth: one robot, its scans and points (map frame = the odometry frame), its
// odometry samples (ODOM lines if any, else the FLASER poses).
[[nodiscard]] Result<Dataset> carmen_to_dataset(const CarmenLog& log, const CarmenImportOptions& options);

}  // namespace teamscan
