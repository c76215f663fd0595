// Units and conversions. Names carry their unit (STYLE.md): range_mm, angle_rad, stamp_ns.
#pragma once

#include <cmath>
#include <cstdint>
#include <numbers>

namespace teamscan {

inline constexpr double kPi = std::numbers::pi;
inline constexpr double kDegToRad = kPi / 180.0;
inline constexpr double kRadToDeg = 180.0 / kPi;

[[nodiscard]] constexpr double deg_to_rad(double deg) { return deg * kDegToRad; }
[[nodiscard]] constexpr double rad_to_deg(double rad) { return rad * kRadToDeg; }
[[nodiscard]] constexpr double mm_to_m(double mm) { return mm * 1e-3; }
[[nodiscard]] constexpr double m_to_mm(double m) { return m * 1e3; }

// Wrap an angle to (-pi, pi]. Not finite: returned as it is (not an angle; inputs are validated at the
// edge). Far outside (a corrupt file's 1e300): one std::remainder instead of ~1e299 turns of the loop.
[[nodiscard]] inline double normalize_angle(double a) {
  if (!std::isfinite(a)) return a;
  if (std::fabs(a) > 1e3) a = std::remainder(a, 2.0 * kPi);
  while (a > kPi) a -= 2.0 * kPi;
  while (a <= -kPi) a += 2.0 * kPi;
  return a;
}

// Integer millimetres, the unit of the wire (int32, map frame) and of the LMS in mm mode.
struct Millimetres {
  std::int32_t value = 0;
  friend constexpr auto operator<=>(Millimetres, Millimetres) = default;
};

}  // namespace teamscan
