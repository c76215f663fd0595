// The one metres -> wire millimetres conversion (common/units.hpp): rounding at the half-millimetre
// boundaries, saturation to int32, not-a-number.
#include "common/units.hpp"

#include <gtest/gtest.h>

#include <cstdint>
#include <limits>

namespace teamscan {
namespace {

TEST(ToMm, WholeMillimetresAreExact) {
  EXPECT_EQ(to_mm(0.0), 0);
  EXPECT_EQ(to_mm(1.0), 1000);
  EXPECT_EQ(to_mm(-2.5), -2500);
}

TEST(ToMm, RoundsToNearestAtTheHalfMillimetreBoundary) {
  // 0.0005 m and 0.0025 m are not exact in binary: test the products that are (x.5 mm exactly).
  EXPECT_EQ(to_mm(0.5 / 1000.0), 1);  // 0.5 mm: half away from zero
  EXPECT_EQ(to_mm(-0.5 / 1000.0), -1);
  EXPECT_EQ(to_mm(2.5 / 1000.0), 3);  // not to even: 2.5 mm -> 3 mm
  EXPECT_EQ(to_mm(-2.5 / 1000.0), -3);
  EXPECT_EQ(to_mm(0.0014999), 1);  // just under the boundary
  EXPECT_EQ(to_mm(0.0015001), 2);  // just over
  EXPECT_EQ(to_mm(-0.0014999), -1);
  EXPECT_EQ(to_mm(-0.0015001), -2);
}

TEST(ToMm, SaturatesToTheInt32Range) {
  constexpr std::int32_t kMax = std::numeric_limits<std::int32_t>::max();
  constexpr std::int32_t kMin = std::numeric_limits<std::int32_t>::min();
  EXPECT_EQ(to_mm(1.2346), 1235);
  EXPECT_EQ(to_mm(-1.2346), -1235);
  EXPECT_EQ(to_mm(-0.0004), 0);
  EXPECT_EQ(to_mm(2147483.6466), kMax);  // rounds up to the largest value, not past it
  EXPECT_EQ(to_mm(2147483.6471), kMax);
  EXPECT_EQ(to_mm(1e9), kMax);
  EXPECT_EQ(to_mm(-1e9), kMin);
  EXPECT_EQ(to_mm(1.0e300), kMax);
  EXPECT_EQ(to_mm(-1.0e300), kMin);
  EXPECT_EQ(to_mm(std::numeric_limits<double>::infinity()), kMax);
  EXPECT_EQ(to_mm(-std::numeric_limits<double>::infinity()), kMin);
}

TEST(ToMm, NotANumberIsTheLargestValue) {
  EXPECT_EQ(to_mm(std::numeric_limits<double>::quiet_NaN()), std::numeric_limits<std::int32_t>::max());
}

TEST(ToMm, OtherWidthsRoundTheSameWayAndSaturateToTheirRange) {
  EXPECT_EQ(to_mm_as<std::uint16_t>(2.5 / 1000.0), 3);
  EXPECT_EQ(to_mm_as<std::uint16_t>(-1.0), 0);
  EXPECT_EQ(to_mm_as<std::uint16_t>(65.5349), 65535);  // rounds up to the largest value
  EXPECT_EQ(to_mm_as<std::uint16_t>(70.0), 65535);
  EXPECT_EQ(to_mm_as<std::uint32_t>(-0.0004), 0u);
  EXPECT_EQ(to_mm_as<std::uint32_t>(4294967.2951), 4294967295u);
  EXPECT_EQ(to_mm_as<std::uint32_t>(1e300), 4294967295u);
  EXPECT_EQ(to_mm_as<std::int64_t>(-2.5 / 1000.0), -3);
  EXPECT_EQ(to_mm_as<std::int64_t>(1e9), 1'000'000'000'000);  // beyond the int32 range, exact
  EXPECT_EQ(to_mm_as<std::int64_t>(1e300), std::numeric_limits<std::int64_t>::max());
  EXPECT_EQ(to_mm_as<std::int64_t>(-1e300), std::numeric_limits<std::int64_t>::min());
  EXPECT_EQ(to_mm_as<std::uint32_t>(std::numeric_limits<double>::quiet_NaN()), 4294967295u);
}

TEST(RoundSaturated, MilliUnitsOfARate) {
  EXPECT_EQ(round_saturated<std::int32_t>(0.0125 * 1e3), 13);   // 12.5 mrad/s: half away from zero
  EXPECT_EQ(round_saturated<std::int32_t>(-0.0125 * 1e3), -13);
  EXPECT_EQ(round_saturated<std::int32_t>(1e20), std::numeric_limits<std::int32_t>::max());
}

}  // namespace
}  // namespace teamscan
