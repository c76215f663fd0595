// The points a match may use (match_points.hpp).
#include "groundstation/fusion/match_points.hpp"

#include <vector>

#include "common/point_flags.hpp"

namespace teamscan::fusion {

bool match_usable_flags(std::uint16_t flags) { return (flags & (point_flags::kInvalid | point_flags::kDirectionFiltered)) == 0; }

std::size_t mask_teammates(const mapping::TeamState& team, std::uint8_t robot, const Vec3& sensor_m,
                           const mapping::TrackedOptions& tracked, std::span<const mapping::MapPoint> points,
                           std::span<std::uint8_t> usable) {
  std::vector<mapping::BodyBox> boxes;
  for (const mapping::RobotEstimate& e : team.robots) {
    if (!e.valid || e.robot == robot) continue;
    boxes.push_back(mapping::body_box(e, tracked));
    boxes.back().sensor_m = sensor_m;
  }
  if (boxes.empty()) return 0;
  mapping::PointBounds footprint;  // of the usable points, as box_contains sees them (floats)
  for (std::size_t i = 0; i < points.size() && i < usable.size(); ++i)
    if (usable[i] != 0) footprint.add(points[i]);
  std::erase_if(boxes, [&](const mapping::BodyBox& b) { return !mapping::box_may_reach(b, footprint, 0.0); });
  std::size_t cleared = 0;
  for (std::size_t i = 0; i < points.size() && i < usable.size() && !boxes.empty(); ++i) {
    if (usable[i] == 0) continue;
    for (const mapping::BodyBox& b : boxes) {
      if (mapping::box_contains(b, points[i], 0.0)) {
        usable[i] = 0;
        ++cleared;
        break;
      }
    }
  }
  return cleared;
}

}  // namespace teamscan::fusion
