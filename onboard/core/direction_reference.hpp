// Double-precision reference of the direction filter (paper eq. 7, PAPER_NOTES.md 7), written the way
// the paper states it (distances with square roots, an angle's tangent). Used by the tests to check the
// fixed-point filter and by the ground station for offline evaluation. Not for the robot's data path.
#pragma once

#include <cmath>

#include "common/units.hpp"

namespace teamscan::onboard {

struct ConeReference {
  double apex_x_m = 0, apex_y_m = 0;     // R1
  double mate_x_m = 0, mate_y_m = 0;     // R2
  double half_angle_rad = 0;             // ha
  bool range_gate = false;
  double range_gate_m = 0;               // body radius + margin
  bool height_gate = false;
  double z_max_m = 0;                    // teammate height + margin
};

struct ConeDecision {
  bool inside = false;
  // Distance of the point (horizontal, or vertical for the height gate) to the nearest boundary of the
  // region that decided it: a fixed-point decision may differ from this one only near a boundary.
  double boundary_distance_m = 0;
};

// Paper eq. 7: p is filtered if it lies ahead of R1 along L (d_r(p_L) > 0) and
// d_p(p, L) < d_r(p_L) · tan(ha), with d_r(p_L)² = d_r(p)² − d_p(p, L)². Gates as in direction_filter.hpp.
[[nodiscard]] inline ConeDecision cone_reference(const ConeReference& c, double x_m, double y_m, double z_m) {
  const double ux = c.mate_x_m - c.apex_x_m, uy = c.mate_y_m - c.apex_y_m;
  const double ulen = std::hypot(ux, uy);
  const double vx = x_m - c.apex_x_m, vy = y_m - c.apex_y_m;
  const double d_r = std::hypot(vx, vy);                         // d_r(p): distance R1 -> p
  const double d_p = std::abs(ux * vy - uy * vx) / ulen;         // d_p(p, L)
  const double along_sign = ux * vx + uy * vy;
  const double d_rl = std::sqrt(std::max(0.0, d_r * d_r - d_p * d_p));  // d_r(p_L)
  const double ahead = along_sign > 0 ? d_rl : -d_rl;
  ConeDecision out;
  // Horizontal distance to the cone's edge rays (or to the apex behind R1).
  const double phi = std::atan2(d_p, ahead);                     // angle between L and R1->p, [0, pi]
  const double edge = phi <= c.half_angle_rad + kPi / 2 ? d_r * std::abs(std::sin(phi - c.half_angle_rad)) : d_r;
  out.boundary_distance_m = edge;
  out.inside = ahead > 0 && d_p < ahead * std::tan(c.half_angle_rad);
  if (c.range_gate) {
    const double lo = ulen - c.range_gate_m, hi = ulen + c.range_gate_m;
    const double gate_edge = std::min(std::abs(ahead - lo), std::abs(ahead - hi));
    out.boundary_distance_m = std::min(out.boundary_distance_m, gate_edge);
    out.inside = out.inside && ahead >= lo && ahead <= hi;
  }
  if (c.height_gate) {
    out.boundary_distance_m = std::min(out.boundary_distance_m, std::abs(z_m - c.z_max_m));
    out.inside = out.inside && z_m <= c.z_max_m;
  }
  return out;
}

}  // namespace teamscan::onboard
