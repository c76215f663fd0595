// The robot-based direction filter (paper eq. 7, PAPER_NOTES.md 7) as the daemon runs it: the newest team
// state kept, each teammate's cone (onboard/cone/direction_cone.hpp, fixed point) prepared per scan, every
// scan's points flagged in place, and a stale-team policy that never filters with old team data
// silently. The double-precision reference is direction_reference.hpp.
#pragma once

#include <array>
#include <cstdint>

#include "common/capacities.hpp"
#include "common/result.hpp"
#include "common/scan_points.hpp"
#include "common/time.hpp"
#include "onboard/cone/direction_cone.hpp"
#include "onboard/core/messages.hpp"

namespace teamscan::onboard {

struct DirectionFilterStats {
  std::uint32_t filtered = 0;        // points flagged kPointDirectionFiltered in this scan
  std::uint32_t stale_points = 0;    // points flagged kPointTeamStale
  std::uint16_t cones = 0;           // teammates filtered against
  std::uint16_t stale_mates = 0;     // teammates whose state was stale
  std::uint16_t skipped_mates = 0;   // degenerate / outside the domain / disabled by the stale policy
  std::uint32_t out_of_extent = 0;   // points outside ±2^21 mm, left alone
};

// The filter as the daemon runs it: parameters checked once, the newest team state kept (fixed
// capacity), and every scan's points flagged in place.
class DirectionFilter {
 public:
  // Checks the parameters; the error names the offending one.
  [[nodiscard]] static Result<DirectionFilter> create(const cone::DirectionFilterParams& params, std::uint32_t own_robot_id);

  // Replaces the team state (from teamscan/team). This robot's own entry and members beyond kMaxRobots
  // are left out. A member the ground station marks lost keeps its last known position and counts as
  // stale (the stale policy applies), since it may still stand there.
  void set_team(const TeamSnapshot& team);
  void clear_team() { mate_count_ = 0; have_team_ = false; }
  [[nodiscard]] bool have_team() const { return have_team_; }

  // Flags the placed points (not invalid, dazzled or without pose) of one scan taken at `stamp` by
  // this robot standing at (apex_x_mm, apex_y_mm): kPointDirectionFiltered inside a teammate's cone;
  // kPointTeamStale on every placed point if any teammate's state was stale (widened or skipped) or no
  // team state has arrived yet (then nothing is filtered).
  DirectionFilterStats apply(std::int32_t apex_x_mm, std::int32_t apex_y_mm, Time stamp, ScanPoint* points,
                             std::uint16_t count) const;

  // Whether the state of a member valid at `valid` is fresh at `stamp`, and the half-angle to use.
  [[nodiscard]] bool fresh(Time valid, Time stamp) const { return stamp - valid <= params_.max_team_age; }
  [[nodiscard]] double effective_half_angle_rad(Time valid, Time stamp) const;
  [[nodiscard]] const cone::DirectionFilterParams& params() const { return params_; }

 private:
  struct Mate {
    cone::Teammate mate;
    std::int32_t vx_mmps = 0, vy_mmps = 0;
    Time valid;
    bool lost = false;
  };

  cone::DirectionFilterParams params_;
  std::uint32_t own_robot_id_ = 0;
  bool have_team_ = false;
  std::uint16_t mate_count_ = 0;
  std::array<Mate, kMaxRobots> mates_{};
};

}  // namespace teamscan::onboard
