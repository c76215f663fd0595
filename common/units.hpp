// Units and conversions. Names carry their unit (STYLE.md): range_mm, angle_rad, stamp_ns.
#pragma once

#include <cmath>
#include <cstdint>
#include <limits>
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

// Metres to whole millimetres, the unit of the wire (int32, DESIGN.md "Frames, units, time") and of the
// robot's fixed-point filter: rounded to nearest, a half millimetre away from zero, saturated to the
// int32 range (far beyond any site, where the direction filter leaves a point or a teammate alone). Not
// a number gives the largest value, so it never reads as a place. The one conversion every layer uses.
[[nodiscard]] inline std::int32_t to_mm(double m) {
  const double mm = m * 1000.0;
  // llround is undefined outside the long long range; the int32 saturation bounds it long before that.
  if (!(mm < 2147483647.0)) return std::numeric_limits<std::int32_t>::max();  // also NaN
  if (mm < -2147483648.0) return std::numeric_limits<std::int32_t>::min();
  return static_cast<std::int32_t>(std::llround(mm));  // within [INT32_MIN, INT32_MAX] by the bounds above
}

// Integer millimetres, the unit of the wire (int32, map frame) and of the LMS in mm mode.
struct Millimetres {
  std::int32_t value = 0;
  friend constexpr auto operator<=>(Millimetres, Millimetres) = default;
};

}  // namespace teamscan
