// Fixed point: rounding is to nearest, ties away from zero; saturation at the int32 bounds.
#include <gtest/gtest.h>

#include "common/fixed_point.hpp"

namespace teamscan {
namespace {

TEST(FixedPoint, RoundsToNearest) {
  EXPECT_EQ(Q16::from_double(1.0).raw, 65536);
  EXPECT_EQ(Q16::from_double(-1.0).raw, -65536);
  EXPECT_EQ(Q16::from_double(0.5 / 65536.0).raw, 1);
  EXPECT_EQ(Q16::from_double(-0.5 / 65536.0).raw, -1);
  EXPECT_NEAR(Q16::from_double(3.14159).to_double(), 3.14159, 1.0 / 65536.0);
}

TEST(FixedPoint, MulShiftRoundAndSaturate) {
  EXPECT_EQ(mul_shift_round(3, 1, 1), 2);    // 1.5 -> 2
  EXPECT_EQ(mul_shift_round(-3, 1, 1), -2);  // -1.5 -> -2
  EXPECT_EQ(mul_shift_round(65536, 65536, 16), 65536);
  EXPECT_EQ(saturate_i32(std::int64_t{1} << 40), 2147483647);
  EXPECT_EQ(saturate_i32(-(std::int64_t{1} << 40)), -2147483647 - 1);
  EXPECT_EQ(saturate_i32(-5), -5);
}

}  // namespace
}  // namespace teamscan
