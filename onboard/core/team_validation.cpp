// check_team: the robot's check of a received team state (team_validation.hpp).
#include "onboard/core/team_validation.hpp"

#include <cmath>

namespace teamscan::onboard {

namespace {
constexpr const char* kNames[kTeamRejectReasons] = {"accepted", "count",    "robot_id", "duplicate_id", "covariance",
                                                    "position", "velocity", "size",     "stamp",
                                                    "correction"};
}  // namespace

const char* team_reject_name(TeamReject r) {
  const auto i = static_cast<std::size_t>(r);
  return i < kTeamRejectReasons ? kNames[i] : "unknown";
}

TeamCheck check_team(const TeamSnapshot& team, Time now, const TeamCheckLimits& limits) noexcept {
  if (team.count > kMaxRobots) return {TeamReject::kCount, 0};
  std::uint64_t ids_seen = 0;  // bit (id − 1)
  const std::int64_t now_ns = now.ns();
  for (std::uint32_t i = 0; i < team.count; ++i) {
    const TeamMemberState& m = team.members[i];
    if (m.robot_id == 0 || m.robot_id > kMaxRobots) return {TeamReject::kRobotId, i};
    const std::uint64_t bit = std::uint64_t{1} << (m.robot_id - 1u);
    if ((ids_seen & bit) != 0) return {TeamReject::kDuplicateId, i};
    ids_seen |= bit;
    // Covariance: finite, non-negative variances, bounded, and positive semi-definite (|xy| ≤ √(xx·yy)).
    if (!std::isfinite(m.cov_xx) || !std::isfinite(m.cov_xy) || !std::isfinite(m.cov_yy) || m.cov_xx < 0.0f ||
        m.cov_yy < 0.0f || m.cov_xx > limits.max_variance_mm2 || m.cov_yy > limits.max_variance_mm2 ||
        static_cast<double>(m.cov_xy) * static_cast<double>(m.cov_xy) >
            static_cast<double>(m.cov_xx) * static_cast<double>(m.cov_yy) * (1.0 + 1e-6) + 1e-6) {
      return {TeamReject::kCovariance, i};
    }
    const std::int64_t x = m.x_mm, y = m.y_mm;
    if (x > limits.max_abs_position_mm || x < -limits.max_abs_position_mm || y > limits.max_abs_position_mm ||
        y < -limits.max_abs_position_mm) {
      return {TeamReject::kPosition, i};
    }
    // Each component first: the sum of two squared int32 could overflow an int64.
    const std::int64_t vx = m.vx_mmps, vy = m.vy_mmps, vmax = limits.max_speed_mmps;
    if (vx > vmax || vx < -vmax || vy > vmax || vy < -vmax || vx * vx + vy * vy > vmax * vmax) {
      return {TeamReject::kVelocity, i};
    }
    if (m.length_mm > limits.max_length_mm || m.width_mm > limits.max_length_mm || m.height_mm > limits.max_height_mm) {
      return {TeamReject::kSize, i};
    }
    // Stamps: compared as differences from now (both after 2020 here, so no overflow).
    if (m.valid_ns < limits.clock_set_after_ns || now_ns < limits.clock_set_after_ns) return {TeamReject::kStamp, i};
    if (m.valid_ns > now_ns && m.valid_ns - now_ns > limits.max_ahead.count()) return {TeamReject::kStamp, i};
    if (!m.lost && now_ns - m.valid_ns > limits.max_age.count()) return {TeamReject::kStamp, i};
    // The odometry correction: none is all zeros; a correction shifts by less than the plausible
    // extent (twice the position bound: from one edge to the other) and turns within (−π, π].
    const OdomCorrection& c = m.correction;
    const std::int64_t cx = c.x_mm, cy = c.y_mm, cmax = 2 * limits.max_abs_position_mm;
    if (c.none() ? (c.x_mm != 0 || c.y_mm != 0 || c.yaw_urad != 0)
                 : (!c.yaw_in_range() || cx > cmax || cx < -cmax || cy > cmax || cy < -cmax)) {
      return {TeamReject::kCorrection, i};
    }
  }
  return {};
}

bool correction_step_ok(const OdomCorrection& applied, const OdomCorrection& next, const TeamCheckLimits& limits) noexcept {
  // int32 operands: the differences fit an int64 (< 2^32), and each is bounded by the step limit before
  // it is squared, so the sum of squares stays below 2·(limit)² (no overflow for limits below 2^31).
  const std::int64_t dx = std::int64_t{next.x_mm} - applied.x_mm, dy = std::int64_t{next.y_mm} - applied.y_mm;
  const std::int64_t m = limits.max_correction_step_mm;
  if (dx > m || dx < -m || dy > m || dy < -m || dx * dx + dy * dy > m * m) return false;
  constexpr std::int64_t kTwoPiUrad = 6'283'185;
  std::int64_t dyaw = std::int64_t{next.yaw_urad} - applied.yaw_urad;
  if (dyaw > kTwoPiUrad / 2) dyaw -= kTwoPiUrad;
  if (dyaw < -kTwoPiUrad / 2) dyaw += kTwoPiUrad;
  return dyaw <= limits.max_correction_step_urad && dyaw >= -limits.max_correction_step_urad;
}

}  // namespace teamscan::onboard
