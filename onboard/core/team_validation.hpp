// The robot's check of every team state (teamscan/team) before the direction filter uses it
// (docs/validation.md): count ≤ 32, known robot ids (each once), finite non-negative covariances,
// plausible positions, velocities, sizes, stamps and odometry corrections. Pure, no allocation, no exceptions (firmware rules):
// the pipeline keeps the last good state and counts the refused ones in the robot's status.
#pragma once

#include <array>
#include <cstdint>

#include "common/time.hpp"
#include "onboard/core/messages.hpp"

namespace teamscan::onboard {

// Why a team state was refused (RobotStatus.last_team_reject on the wire). Append only.
enum class TeamReject : std::uint8_t {
  kNone = 0,
  kCount = 1,        // count above MAX_ROBOTS
  kRobotId = 2,      // a member's robot id outside 1..MAX_ROBOTS
  kDuplicateId = 3,  // a robot id listed twice
  kCovariance = 4,   // a covariance not finite, a negative variance, or |cov_xy| above sqrt(xx·yy)
  kPosition = 5,     // a member outside the plausible extent
  kVelocity = 6,     // a member faster than plausible
  kSize = 7,         // a footprint or height beyond plausible
  kStamp = 8,        // a member's valid_ns not within the window of this robot's clock
  kCorrection = 9,   // a member's odometry correction: yaw outside (−π, π], a shift beyond the plausible
                     // extent, or values with corr_seq 0 (none)
};
inline constexpr std::size_t kTeamRejectReasons = 10;
[[nodiscard]] const char* team_reject_name(TeamReject r);

struct TeamCheckLimits {
  std::int64_t max_abs_position_mm = 10'000'000;  // ±10 km, the ground station's default site bounds
  std::int64_t max_speed_mmps = 10'000;           // 10 m/s
  std::uint16_t max_length_mm = 5'000;            // footprint and height
  std::uint16_t max_height_mm = 5'000;
  float max_variance_mm2 = 1.0e12f;               // σ = 1 km
  // A member that is not lost must be valid within [now − max_age, now + max_ahead]; a lost one (its
  // last known position) only not in the future and after 2020 (a clock that was set).
  Duration max_age = std::chrono::seconds(30);
  Duration max_ahead = std::chrono::seconds(2);
  std::int64_t clock_set_after_ns = 1'577'836'800'000'000'000;  // 2020-01-01
  // This robot's own odometry correction may move from the one it applies by at most this much per
  // new correction (correction_step_ok). The station's registration steps by at most max(12 cm, 3σ)
  // and max(2°, 3σ) per match (docs/registration.md); a step beyond these bounds is absurd.
  std::int64_t max_correction_step_mm = 2'000;   // 2 m
  std::int64_t max_correction_step_urad = 523'599;  // 30°
};

struct TeamCheck {
  TeamReject reason = TeamReject::kNone;
  std::uint32_t member = 0;  // index of the offending member
  [[nodiscard]] bool ok() const { return reason == TeamReject::kNone; }
};

// Checks one team state against `now` (this robot's CLOCK_REALTIME).
[[nodiscard]] TeamCheck check_team(const TeamSnapshot& team, Time now, const TeamCheckLimits& limits) noexcept;

// Whether `next` (this robot's correction in a team state that passed check_team) is a plausible step
// from `applied` (the one in use; none = the identity): a shift of at most max_correction_step_mm and
// a turn of at most max_correction_step_urad (the shortest way round). Integer arithmetic only.
[[nodiscard]] bool correction_step_ok(const OdomCorrection& applied, const OdomCorrection& next,
                                      const TeamCheckLimits& limits) noexcept;

struct TeamCheckCounters {
  std::uint64_t accepted = 0;
  std::uint64_t rejected = 0;
  std::array<std::uint64_t, kTeamRejectReasons> by_reason{};
  TeamReject last_reject = TeamReject::kNone;
};

}  // namespace teamscan::onboard
