// The direction filter's cone (paper eq. 7, PAPER_NOTES.md 7) in fixed-point integer arithmetic: a point
// is a ghost of teammate R2 if it lies ahead of this robot R1 along the horizontal line L from R1 to R2
// and inside the cone of half-angle ha about L, with the project's optional range and height gates.
// One library for both sides: the robot's DirectionFilter (onboard/core) and the ground station's
// offline and live `direction` method (groundstation/mapping) decide with the same integers.
#pragma once

#include <cstdint>

#include "common/time.hpp"

namespace teamscan::cone {

// ---- Fixed-point domain and overflow bounds -------------------------------------------------------
// Inputs are int32 mm in the map frame. The filter evaluates only coordinates with |c| <= 2^21 mm
// (±2097 m: the map extent, far beyond the LMS's 80 m cm-mode range around any robot); a point or a
// robot outside it is left alone and counted. Hence every horizontal difference |dx|, |dy| <= 2^22, and
//   along = ux·vx + uy·vy, cross = ux·vy − uy·vx:  |along|, |cross| <= 2·2^44 = 2^45
//   tan(ha) in Q16 with ha <= 60°: 0 <= tan_q16 < 1.7321·2^16 < 2^17
//   |cross| << 16 < 2^61,  along · tan_q16 < 2^62          -> int64 is exact, no overflow
//   range gate: |u| carried as ulen_q8 = floor(256·|u|) < 2^30.5, gate <= 2^17 mm (131 m) -> 256·gate <= 2^25:
//   ulen_q8·(ulen_q8 ± 256·gate) < 2^62 and along·2^16 < 2^61
// tests/unit/onboard/direction_filter_test.cpp checks these at the extremes of the domain.
inline constexpr std::int32_t kDirectionFilterExtentMm = std::int32_t{1} << 21;
inline constexpr double kMaxHalfAngleDeg = 60.0;
inline constexpr std::int32_t kMaxGateMm = std::int32_t{1} << 17;
inline constexpr int kTanFractionBits = 16;  // tan(ha) in Q16

// Whether a coordinate lies in the fixed-point domain the cone is evaluated in.
[[nodiscard]] constexpr bool in_cone_extent(std::int32_t v) {
  return v <= kDirectionFilterExtentMm && v >= -kDirectionFilterExtentMm;
}

// What to do with a teammate whose state is older than max_team_age at the scan's time.
enum class StalePolicy : std::uint8_t {
  widen,    // grow the half-angle by stale_growth_deg_per_s per second of excess age (up to 60°)
  disable,  // do not filter against that teammate
};

struct DirectionFilterParams {
  double half_angle_deg = 7.0;          // ha; the paper uses 5° and 7°
  // Range gate (improved variant): only points whose distance along L lies within
  // body radius + range_gate_margin_m of the teammate's distance |R1R2|.
  bool range_gate = false;
  double range_gate_margin_m = 0.3;
  // Height gate (improved variant): only points no higher than the teammate's height + margin.
  bool height_gate = false;
  double height_gate_margin_m = 0.1;
  // Body radius when the team state gives no footprint (Pioneer 3-AT: 0.508 x 0.497 m, half-diagonal).
  double default_body_radius_m = 0.36;
  // Height when the team state gives none (Pioneer 3-AT with a laser on top).
  double default_height_m = 0.5;
  Duration max_team_age = 500ms;
  StalePolicy stale_policy = StalePolicy::widen;
  double stale_growth_deg_per_s = 10.0;
  // Move each teammate by its reported velocity from valid_ns to the scan's time (at most max_team_age).
  bool extrapolate_team = true;
};

// A teammate, as the filter needs it. The ground station's offline evaluation fills it from its own
// tracks; the daemon from teamscan/team (TeamSnapshot).
struct Teammate {
  std::uint32_t robot_id = 0;
  std::int32_t x_mm = 0;
  std::int32_t y_mm = 0;
  std::int32_t body_radius_mm = 0;
  std::int32_t height_mm = 0;
};

// One teammate's cone in fixed point, prepared once per scan: everything the per-point test needs.
struct ConeFixed {
  std::int32_t apex_x_mm = 0, apex_y_mm = 0;
  std::int64_t ux_mm = 0, uy_mm = 0;     // L = R2 − R1
  std::int32_t tan_q16 = 0;              // tan(ha), Q16, round to nearest
  bool range_gate = false;
  std::int64_t along_lo_q16 = 0, along_hi_q16 = 0;  // range gate on along·2^16 (along = |u|·d_along, mm²)
  bool height_gate = false;
  std::int32_t z_max_mm = 0;
};

// Builds the cone of `mate` seen from `apex` (R1). Returns false if it is degenerate (R2 on R1) or
// outside the fixed-point domain; then nothing is filtered against it. `half_angle_rad` <= 60°.
[[nodiscard]] bool prepare_cone(std::int32_t apex_x_mm, std::int32_t apex_y_mm, const Teammate& mate,
                                double half_angle_rad, const DirectionFilterParams& params, ConeFixed& out);

// The integer hot path: eq. 7 (ahead along L and d_p < d_r·tan(ha), multiplied through by |u| so that
// neither a square root nor a division is needed: |cross| < along·tan(ha)), then the gates.
[[nodiscard]] inline bool cone_contains(const ConeFixed& c, std::int32_t x_mm, std::int32_t y_mm, std::int32_t z_mm) {
  if (!in_cone_extent(x_mm) || !in_cone_extent(y_mm)) return false;
  const std::int64_t vx = std::int64_t{x_mm} - c.apex_x_mm;
  const std::int64_t vy = std::int64_t{y_mm} - c.apex_y_mm;
  const std::int64_t along = c.ux_mm * vx + c.uy_mm * vy;  // |u| · d_r(p_L)
  if (along <= 0) return false;                            // not ahead of R1 along L
  std::int64_t cross = c.ux_mm * vy - c.uy_mm * vx;        // |u| · d_p(p, L)
  if (cross < 0) cross = -cross;
  if ((cross << kTanFractionBits) >= along * c.tan_q16) return false;
  if (c.range_gate && ((along << 16) < c.along_lo_q16 || (along << 16) > c.along_hi_q16)) return false;
  if (c.height_gate && z_mm > c.z_max_mm) return false;
  return true;
}

// tan(angle) in Q16, round to nearest; angle in [0, 60°].
[[nodiscard]] std::int32_t tan_q16(double angle_rad);
// floor(sqrt(v)) for v >= 0, exact over int64.
[[nodiscard]] std::int64_t isqrt64(std::int64_t v);

}  // namespace teamscan::cone
