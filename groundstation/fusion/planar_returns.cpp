// Which of a released scan's returns go into the pose graph (planar_returns.hpp).
#include "groundstation/fusion/planar_returns.hpp"

#include <cmath>

#include "groundstation/fusion/match_points.hpp"

namespace teamscan::fusion {

bool level_laser(const DatasetRobot& robot) { return robot.mount_rpy_rad[0] == 0.0 && robot.mount_rpy_rad[1] == 0.0; }

bool level_scan(const mapping::ScanView& scan) {
  constexpr double kPlaneTolerance_m = 0.01;
  for (const mapping::MapPoint& p : scan.points)
    if (std::abs(static_cast<double>(p.z) - scan.origin_m.z) > kPlaneTolerance_m) return false;
  return true;
}

void take_planar_returns(const mapping::ScanView& scan, bool tilted, const PlanarReturnOptions& options, std::vector<std::uint8_t>& taken,
                         PlanarReturnCounts& counts) {
  taken.assign(scan.points.size(), 1);
  for (std::size_t j = 0; j < scan.points.size(); ++j) {
    taken[j] = match_usable_flags(j < scan.flags.size() ? scan.flags[j] : 0) ? 1 : 0;
    if (taken[j] == 0) ++counts.flagged;
  }
  if (scan.team != nullptr) counts.teammates += mask_teammates(*scan.team, scan.robot, scan.origin_m, options.tracked, scan.points, taken);
  for (std::size_t j = 0; j < scan.points.size(); ++j) {
    if (taken[j] == 0) continue;
    const double z = scan.points[j].z;
    if (tilted && (z < options.min_height_m || z > options.max_height_m)) {
      taken[j] = 0;
      ++counts.out_of_band;
      continue;
    }
    ++counts.kept;
  }
}

}  // namespace teamscan::fusion
