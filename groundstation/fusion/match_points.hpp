// Which of a scan's points may pull a match: the registration's (FusionCore) and the pose graph's
// (planar_returns.hpp). One rule for both, so both leave out the same points.
#pragma once

#include <cstdint>
#include <span>

#include "common/pose.hpp"
#include "groundstation/mapping/tracked_filter.hpp"
#include "groundstation/mapping/tracker.hpp"

namespace teamscan::fusion {

// Not flagged by the robot: neither invalid nor taken for a teammate by its onboard direction filter.
[[nodiscard]] bool match_usable_flags(std::uint16_t flags);

// Clears usable[i] for every point inside a teammate's tracked body (`team`: the team state at the
// scan's stamp; `robot`: the scanning robot, whose own body is not tested; `sensor_m`: its sensor
// origin). Points, team and sensor in one frame. Only the teammates whose box can reach the usable
// points' footprint are tested point by point (the tracked filter's cull). Returns the points cleared.
std::size_t mask_teammates(const mapping::TeamState& team, std::uint8_t robot, const Vec3& sensor_m,
                           const mapping::TrackedOptions& tracked, std::span<const mapping::MapPoint> points,
                           std::span<std::uint8_t> usable);

}  // namespace teamscan::fusion
