// The fixed-point direction filter (paper eq. 7) and its stale-team policy; the cone and its arithmetic's
// domain and overflow bounds are onboard/cone/direction_cone.hpp.
#include "onboard/core/direction_filter.hpp"

#include <algorithm>
#include <cmath>

#include "common/fixed_point.hpp"
#include "common/units.hpp"

namespace teamscan::onboard {

namespace {

// a / b rounded to nearest, ties away from zero (b > 0).
std::int64_t div_round(std::int64_t a, std::int64_t b) { return a >= 0 ? (a + b / 2) / b : -((-a + b / 2) / b); }

}  // namespace

Result<DirectionFilter> DirectionFilter::create(const cone::DirectionFilterParams& params, std::uint32_t own_robot_id) {
  if (!(params.half_angle_deg > 0.0 && params.half_angle_deg <= cone::kMaxHalfAngleDeg))
    return Error{"filter.half_angle_deg must be in (0, 60]"};
  if (!(params.range_gate_margin_m >= 0.0 && params.range_gate_margin_m * 1000.0 <= cone::kMaxGateMm))
    return Error{"filter.range_gate_margin_m must be in [0, 131]"};
  if (!(params.height_gate_margin_m >= -10.0 && params.height_gate_margin_m <= 10.0))
    return Error{"filter.height_gate_margin_m must be in [-10, 10]"};
  if (!(params.default_body_radius_m > 0.0 && params.default_body_radius_m <= 10.0))
    return Error{"filter.body_radius_m must be in (0, 10]"};
  if (!(params.default_height_m > 0.0 && params.default_height_m <= 10.0))
    return Error{"filter.height_m must be in (0, 10]"};
  if (params.max_team_age <= Duration::zero() || params.max_team_age > 60s)
    return Error{"filter.max_team_age_s must be in (0, 60]"};
  if (!(params.stale_growth_deg_per_s >= 0.0 && params.stale_growth_deg_per_s <= 3600.0))
    return Error{"filter.stale_growth_deg_per_s must be in [0, 3600]"};
  if (own_robot_id == 0 || own_robot_id > kMaxRobots) return Error{"robot_id must be in 1..32"};
  DirectionFilter f;
  f.params_ = params;
  f.own_robot_id_ = own_robot_id;
  return f;
}

void DirectionFilter::set_team(const TeamSnapshot& team) {
  have_team_ = true;
  mate_count_ = 0;
  const std::uint32_t n = std::min<std::uint32_t>(team.count, static_cast<std::uint32_t>(kMaxRobots));
  for (std::uint32_t i = 0; i < n; ++i) {
    const TeamMemberState& m = team.members[i];
    if (m.robot_id == own_robot_id_) continue;
    Mate& out = mates_[mate_count_++];
    out.mate.robot_id = m.robot_id;
    out.mate.x_mm = m.x_mm;
    out.mate.y_mm = m.y_mm;
    // Body radius: half the footprint's diagonal (the farthest a hit on the body lies from its centre).
    if (m.length_mm > 0 && m.width_mm > 0) {
      const std::int64_t l = m.length_mm, w = m.width_mm;
      std::int64_t diagonal_mm = cone::isqrt64(l * l + w * w);
      if (diagonal_mm * diagonal_mm < l * l + w * w) ++diagonal_mm;  // ceil: never smaller than the body
      out.mate.body_radius_mm = static_cast<std::int32_t>((diagonal_mm + 1) / 2);
    } else {
      out.mate.body_radius_mm = to_mm(params_.default_body_radius_m);
    }
    out.mate.height_mm = m.height_mm > 0 ? std::int32_t{m.height_mm} : to_mm(params_.default_height_m);
    out.vx_mmps = m.vx_mmps;
    out.vy_mmps = m.vy_mmps;
    out.valid = Time::from_ns(m.valid_ns);
    out.lost = m.lost;
  }
}

double DirectionFilter::effective_half_angle_rad(Time valid, Time stamp) const {
  const double ha = deg_to_rad(params_.half_angle_deg);
  const Duration excess = (stamp - valid) - params_.max_team_age;
  if (excess <= Duration::zero()) return ha;
  const double widened = ha + deg_to_rad(params_.stale_growth_deg_per_s * to_seconds(excess));
  return std::min(widened, deg_to_rad(cone::kMaxHalfAngleDeg));
}

DirectionFilterStats DirectionFilter::apply(std::int32_t apex_x_mm, std::int32_t apex_y_mm, Time stamp,
                                            ScanPoint* points, std::uint16_t count) const {
  DirectionFilterStats stats;
  std::array<cone::ConeFixed, kMaxRobots> cones;
  std::uint16_t n_cones = 0;
  bool stale = !have_team_;
  for (std::uint16_t i = 0; i < mate_count_; ++i) {
    const Mate& m = mates_[i];
    const bool is_fresh = !m.lost && fresh(m.valid, stamp);
    if (!is_fresh) {
      stale = true;
      ++stats.stale_mates;
      if (params_.stale_policy == cone::StalePolicy::disable) {
        ++stats.skipped_mates;
        continue;
      }
    }
    cone::Teammate mate = m.mate;
    if (params_.extrapolate_team) {
      // Move the teammate to the scan's time along its reported velocity, over at most max_team_age.
      const std::int64_t dt_us = std::clamp<std::int64_t>((stamp - m.valid).count() / 1000, 0,
                                                          params_.max_team_age.count() / 1000);
      mate.x_mm = saturate_i32(std::int64_t{mate.x_mm} + div_round(std::int64_t{m.vx_mmps} * dt_us, 1'000'000));
      mate.y_mm = saturate_i32(std::int64_t{mate.y_mm} + div_round(std::int64_t{m.vy_mmps} * dt_us, 1'000'000));
    }
    if (!cone::prepare_cone(apex_x_mm, apex_y_mm, mate, effective_half_angle_rad(m.valid, stamp), params_, cones[n_cones])) {
      ++stats.skipped_mates;
      continue;
    }
    ++n_cones;
  }
  stats.cones = n_cones;

  for (std::uint16_t k = 0; k < count; ++k) {
    ScanPoint& p = points[k];
    if ((p.flags & kPointUnplaced) != 0) continue;
    if (stale) {
      p.flags |= kPointTeamStale;
      ++stats.stale_points;
    }
    if (!cone::in_cone_extent(p.x_mm) || !cone::in_cone_extent(p.y_mm)) {
      ++stats.out_of_extent;
      continue;
    }
    for (std::uint16_t c = 0; c < n_cones; ++c) {
      if (cone::cone_contains(cones[c], p.x_mm, p.y_mm, p.z_mm)) {
        p.flags |= kPointDirectionFiltered;
        ++stats.filtered;
        break;
      }
    }
  }
  return stats;
}

}  // namespace teamscan::onboard
