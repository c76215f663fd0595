// Tests of common/odometry_history.hpp: ring behaviour, interpolation (the heading through a turn), bounded extrapolation.
#include "common/odometry_history.hpp"

#include <gtest/gtest.h>

namespace teamscan {
namespace {

Time ms(std::int64_t v) { return Time::from_ns(v * 1'000'000); }

TEST(OdometryHistory, EmptyIsAnError) {
  OdometryHistory<4> h;
  const auto r = h.interpolate(ms(0));
  ASSERT_FALSE(r.ok());
  EXPECT_STREQ(r.error().what, "odometry: no samples");
}

TEST(OdometryHistory, SingleSampleHeldWithinLimit) {
  OdometryHistory<4> h;
  ASSERT_TRUE(h.push(ms(1000), {1.0, 2.0, 0.5}));
  auto r = h.interpolate(ms(1050));
  ASSERT_TRUE(r.ok());
  EXPECT_DOUBLE_EQ(r->x_m, 1.0);
  EXPECT_DOUBLE_EQ(r->theta_rad, 0.5);
  EXPECT_FALSE(h.interpolate(ms(1000) + kDefaultMaxExtrapolation + 1ms).ok());
  EXPECT_TRUE(h.interpolate(ms(1000) + kDefaultMaxExtrapolation).ok());  // the limit is inclusive
  EXPECT_FALSE(h.interpolate(ms(1000) - kDefaultMaxExtrapolation - 1ms).ok());
  EXPECT_FALSE(h.interpolate(ms(1101), 100ms).ok());  // an explicit limit
  EXPECT_TRUE(h.interpolate(ms(1100), 100ms).ok());
}

TEST(OdometryHistory, InterpolatesLinearlyInside) {
  OdometryHistory<4> h;
  ASSERT_TRUE(h.push(ms(0), {0.0, 0.0, 0.0}));
  ASSERT_TRUE(h.push(ms(100), {1.0, -2.0, 0.2}));
  ASSERT_TRUE(h.push(ms(200), {1.0, -2.0, 0.4}));
  auto r = h.interpolate(ms(25));
  ASSERT_TRUE(r.ok());
  EXPECT_NEAR(r->x_m, 0.25, 1e-12);
  EXPECT_NEAR(r->y_m, -0.5, 1e-12);
  EXPECT_NEAR(r->theta_rad, 0.05, 1e-12);
  r = h.interpolate(ms(150));
  ASSERT_TRUE(r.ok());
  EXPECT_NEAR(r->x_m, 1.0, 1e-12);
  EXPECT_NEAR(r->theta_rad, 0.3, 1e-12);
  r = h.interpolate(ms(100));  // exactly on a sample
  ASSERT_TRUE(r.ok());
  EXPECT_DOUBLE_EQ(r->y_m, -2.0);
}

// A robot swinging through a corner: its turn rate grows steadily (heading = α t² / 2). Between two
// SIPs the heading follows the parabola through them and the SIP before, not their chord.
TEST(OdometryHistory, HeadingFollowsASteadilyChangingTurn) {
  const double alpha = 40.0;  // rad/s²: 0 to 4 rad/s within 100 ms
  const auto heading = [&](double t_s) { return 0.5 * alpha * t_s * t_s; };
  OdometryHistory<8> h;
  for (int i = 0; i < 4; ++i) ASSERT_TRUE(h.push(ms(i * 100), {0.1 * i, 0.0, normalize_angle(heading(0.1 * i))}));
  for (int at_ms = 105; at_ms < 300; at_ms += 10) {
    const auto r = h.interpolate(ms(at_ms));
    ASSERT_TRUE(r.ok());
    EXPECT_NEAR(r->theta_rad, normalize_angle(heading(at_ms * 1e-3)), 1e-9) << at_ms << " ms";
    EXPECT_NEAR(r->x_m, at_ms * 1e-3, 1e-12);  // the position stays on the chord
  }
  // The chord alone would be off by up to α Δt² / 8 = 2.9° mid-cycle. The first cycle, with no SIP
  // before it, stays on the chord, and past the newest SIP the heading is extrapolated at the last
  // cycle's constant rate, not along the parabola.
  const auto first = h.interpolate(ms(50));
  ASSERT_TRUE(first.ok());
  EXPECT_NEAR(first->theta_rad, 0.5 * heading(0.1), 1e-12);
  const auto ahead = h.interpolate(ms(350));
  ASSERT_TRUE(ahead.ok());
  EXPECT_NEAR(ahead->theta_rad, normalize_angle(heading(0.3) + 0.5 * (heading(0.3) - heading(0.2))), 1e-9);
}

TEST(OdometryHistory, TurnAcrossPlusMinusPi) {
  OdometryHistory<4> h;
  const auto heading = [](double t_s) { return normalize_angle(kPi - 0.35 + 10.0 * t_s * t_s); };  // through ±π at 0.19 s
  for (int i = 0; i < 3; ++i) ASSERT_TRUE(h.push(ms(i * 100), {0, 0, heading(0.1 * i)}));
  for (int at_ms = 110; at_ms < 200; at_ms += 10) {
    const auto r = h.interpolate(ms(at_ms));
    ASSERT_TRUE(r.ok());
    EXPECT_NEAR(r->theta_rad, heading(at_ms * 1e-3), 1e-9) << at_ms << " ms";
  }
}

// After a pause in the odometry stream the SIP before says nothing about the turn now: linear.
TEST(OdometryHistory, AfterAPauseTheHeadingIsLinear) {
  OdometryHistory<4> h;
  ASSERT_TRUE(h.push(ms(0), {0, 0, 1.0}));
  ASSERT_TRUE(h.push(ms(1000), {0, 0, 0.0}));
  ASSERT_TRUE(h.push(ms(1100), {0, 0, 0.2}));
  const auto r = h.interpolate(ms(1050));
  ASSERT_TRUE(r.ok());
  EXPECT_NEAR(r->theta_rad, 0.1, 1e-12);
}

TEST(OdometryHistory, HeadingTakesTheShorterArc) {
  OdometryHistory<4> h;
  ASSERT_TRUE(h.push(ms(0), {0, 0, kPi - 0.1}));
  ASSERT_TRUE(h.push(ms(100), {0, 0, -kPi + 0.1}));
  const auto r = h.interpolate(ms(50));
  ASSERT_TRUE(r.ok());
  EXPECT_NEAR(std::abs(r->theta_rad), kPi, 1e-12);
}

TEST(OdometryHistory, ExtrapolatesAtConstantVelocityBothEnds) {
  OdometryHistory<4> h;
  ASSERT_TRUE(h.push(ms(0), {0.0, 0.0, 0.0}));
  ASSERT_TRUE(h.push(ms(100), {0.1, 0.0, 0.0}));
  auto r = h.interpolate(ms(150));
  ASSERT_TRUE(r.ok());
  EXPECT_NEAR(r->x_m, 0.15, 1e-12);
  r = h.interpolate(ms(-50));
  ASSERT_TRUE(r.ok());
  EXPECT_NEAR(r->x_m, -0.05, 1e-12);
  const auto late = h.interpolate(ms(201), 100ms);
  ASSERT_FALSE(late.ok());
  EXPECT_STREQ(late.error().what, "odometry: time after history");
  EXPECT_EQ(late.error().detail, 101000);  // µs past the newest sample
  const auto early = h.interpolate(ms(-101), 100ms);
  ASSERT_FALSE(early.ok());
  EXPECT_STREQ(early.error().what, "odometry: time before history");
  EXPECT_TRUE(h.interpolate(ms(400), 300ms).ok());  // the limit is the caller's
}

TEST(OdometryHistory, RefusesOutOfOrderAndDuplicateStamps) {
  OdometryHistory<4> h;
  EXPECT_TRUE(h.push(ms(100), {}));
  EXPECT_FALSE(h.push(ms(100), {}));
  EXPECT_FALSE(h.push(ms(50), {}));
  EXPECT_EQ(h.size(), 1u);
  EXPECT_EQ(h.rejected(), 2u);
}

TEST(OdometryHistory, FullRingOverwritesOldest) {
  OdometryHistory<3> h;
  for (int i = 0; i < 5; ++i) EXPECT_TRUE(h.push(ms(i * 100), {static_cast<double>(i), 0, 0}));
  EXPECT_EQ(h.size(), 3u);
  EXPECT_EQ(h.overwritten(), 2u);
  EXPECT_EQ(h.at(0).stamp, ms(200));
  EXPECT_EQ(h.newest().stamp, ms(400));
  // Samples 0 and 1 are gone: 99 ms lies 101 ms before the oldest kept sample, beyond a 100 ms limit.
  EXPECT_FALSE(h.interpolate(ms(99), 100ms).ok());
  const auto r = h.interpolate(ms(350));
  ASSERT_TRUE(r.ok());
  EXPECT_NEAR(r->x_m, 3.5, 1e-12);
}

TEST(OdometryHistory, ManySamplesBinarySearch) {
  OdometryHistory<64> h;
  for (int i = 0; i < 200; ++i) ASSERT_TRUE(h.push(ms(i * 100), {static_cast<double>(i), 2.0 * i, 0}));
  for (int i = 136; i < 199; ++i) {
    const auto r = h.interpolate(ms(i * 100 + 30));
    ASSERT_TRUE(r.ok()) << i;
    EXPECT_NEAR(r->x_m, i + 0.3, 1e-9);
    EXPECT_NEAR(r->y_m, 2.0 * (i + 0.3), 1e-9);
  }
}

}  // namespace
}  // namespace teamscan
