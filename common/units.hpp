// Units and conversions. Names carry their unit (STYLE.md): range_mm, angle_rad, stamp_ns.
#pragma once

#include <cmath>
#include <concepts>
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

// A value rounded to the nearest integer of type Int, a half away from zero, saturated to Int's range.
// Not a number gives Int's largest value, so it never reads as a place. The one rounding every layer's
// unit conversions use (to_mm, the team message's sigmas, rates in milli-units).
template <std::integral Int>
[[nodiscard]] inline Int round_saturated(double v) {
  constexpr double kHi = static_cast<double>(std::numeric_limits<Int>::max());
  constexpr double kLo = static_cast<double>(std::numeric_limits<Int>::min());
  // llround is undefined outside the long long range; the bounds below hold it well inside.
  if (!(v < kHi)) return std::numeric_limits<Int>::max();  // also NaN
  if (v <= kLo) return std::numeric_limits<Int>::min();
  return static_cast<Int>(std::llround(v));  // within [min, max] by the bounds above
}

// Metres to whole millimetres in an integer of type Int (rounded and saturated as round_saturated).
template <std::integral Int>
[[nodiscard]] inline Int to_mm_as(double m) { return round_saturated<Int>(m * 1000.0); }

// Metres to whole millimetres, the unit of the wire (int32, DESIGN.md "Frames, units, time") and of the
// robot's fixed-point filter: saturated to the int32 range (far beyond any site, where the direction
// filter leaves a point or a teammate alone). The one conversion every layer uses.
[[nodiscard]] inline std::int32_t to_mm(double m) { return to_mm_as<std::int32_t>(m); }

// Integer millimetres, the unit of the wire (int32, map frame) and of the LMS in mm mode.
struct Millimetres {
  std::int32_t value = 0;
  friend constexpr auto operator<=>(Millimetres, Millimetres) = default;
};

}  // namespace teamscan
