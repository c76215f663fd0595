// The direction filter's cone in fixed point; the domain and overflow bounds are in direction_cone.hpp.
#include "onboard/cone/direction_cone.hpp"

#include <algorithm>
#include <cmath>

#include "common/result.hpp"
#include "common/units.hpp"

namespace teamscan::cone {

std::int32_t tan_q16(double angle_rad) {
  return static_cast<std::int32_t>(std::lround(std::tan(angle_rad) * static_cast<double>(std::int32_t{1} << kTanFractionBits)));
}

std::int64_t isqrt64(std::int64_t v) {
  TEAMSCAN_EXPECTS(v >= 0);
  auto r = static_cast<std::int64_t>(std::sqrt(static_cast<double>(v)));
  // The double square root may be off by one near large v: correct it exactly in integers.
  while (r > 0 && r * r > v) --r;
  while ((r + 1) * (r + 1) <= v) ++r;
  return r;
}

bool prepare_cone(std::int32_t apex_x_mm, std::int32_t apex_y_mm, const Teammate& mate, double half_angle_rad,
                  const DirectionFilterParams& params, ConeFixed& out) {
  if (!in_cone_extent(apex_x_mm) || !in_cone_extent(apex_y_mm) || !in_cone_extent(mate.x_mm) || !in_cone_extent(mate.y_mm)) return false;
  out.apex_x_mm = apex_x_mm;
  out.apex_y_mm = apex_y_mm;
  out.ux_mm = std::int64_t{mate.x_mm} - apex_x_mm;
  out.uy_mm = std::int64_t{mate.y_mm} - apex_y_mm;
  if (out.ux_mm == 0 && out.uy_mm == 0) return false;  // L undefined
  const double ha = std::clamp(half_angle_rad, 0.0, deg_to_rad(kMaxHalfAngleDeg));
  out.tan_q16 = tan_q16(ha);
  out.range_gate = params.range_gate;
  if (out.range_gate) {
    // along = |u|·d_along; the gate |u| − g <= d_along <= |u| + g becomes, scaled by 2^16 so that |u| can be
    // carried to 1/256 mm (ulen_q8 = floor(256·|u|)):
    //   ulen_q8·(ulen_q8 − 256·g) <= along·2^16 <= ulen_q8·(ulen_q8 + 256·g)
    // which moves the gate's edges by less than (2 + g/|u|)/256 mm. Bounds: ulen_q8 < 2^30.5, 256·g <= 2^25,
    // so both products < 2^62; along·2^16 < 2^61.
    const std::int64_t ulen_q8 = isqrt64((out.ux_mm * out.ux_mm + out.uy_mm * out.uy_mm) << 16);
    const std::int64_t gate_q8 =
        std::min<std::int64_t>(std::int64_t{mate.body_radius_mm} + to_mm(params.range_gate_margin_m), kMaxGateMm) << 8;
    out.along_lo_q16 = ulen_q8 * (ulen_q8 - gate_q8);
    out.along_hi_q16 = ulen_q8 * (ulen_q8 + gate_q8);
  }
  out.height_gate = params.height_gate;
  out.z_max_mm = mate.height_mm + to_mm(params.height_gate_margin_m);
  return true;
}

}  // namespace teamscan::cone
