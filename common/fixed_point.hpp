// Fixed-point helpers with the scale in the type (STYLE.md 7). Rounding is explicit; overflow bounds
// are stated where the arithmetic is used.
#pragma once

#include <cstdint>
#include <limits>

namespace teamscan {

// Q(F): a signed 32-bit value with F fractional bits, raw = value * 2^F.
template <int F>
struct Q {
  static_assert(F >= 0 && F < 31);
  static constexpr std::int32_t kOne = std::int32_t{1} << F;
  std::int32_t raw = 0;

  // Round to nearest (ties away from zero). Caller guarantees |v| * 2^F < 2^31.
  static constexpr Q from_double(double v) {
    const double scaled = v * static_cast<double>(kOne);
    return Q{static_cast<std::int32_t>(scaled >= 0 ? scaled + 0.5 : scaled - 0.5)};
  }
  [[nodiscard]] constexpr double to_double() const { return static_cast<double>(raw) / static_cast<double>(kOne); }
  friend constexpr auto operator<=>(Q, Q) = default;
};

using Q16 = Q<16>;
using Q14 = Q<14>;

// (a * b) >> shift with round-to-nearest, computed in 64 bits: exact as long as |a*b| < 2^63.
[[nodiscard]] constexpr std::int64_t mul_shift_round(std::int64_t a, std::int64_t b, int shift) {
  const std::int64_t p = a * b;
  if (shift == 0) return p;
  const std::int64_t half = std::int64_t{1} << (shift - 1);
  return p >= 0 ? (p + half) >> shift : -((-p + half) >> shift);
}

// Saturate a 64-bit intermediate to int32.
[[nodiscard]] constexpr std::int32_t saturate_i32(std::int64_t v) {
  if (v > std::numeric_limits<std::int32_t>::max()) return std::numeric_limits<std::int32_t>::max();
  if (v < std::numeric_limits<std::int32_t>::min()) return std::numeric_limits<std::int32_t>::min();
  return static_cast<std::int32_t>(v);
}

}  // namespace teamscan
