// ARCOS odometry: PROTOCOLS.md §3.1 wrap vectors, subclass parameters (§1.11), pose integration (§1.10).
#include <gtest/gtest.h>

#include <cmath>

#include "drivers/arcos/emulator.hpp"
#include "drivers/arcos/odometry.hpp"

namespace teamscan::arcos {
namespace {

TEST(ArcosUnwrap, AriaFifteenBitVectors) {
  EXPECT_EQ(unwrap15(0x7FF0, 0x0010), 32);
  EXPECT_EQ(unwrap15(0x0010, 0x7FF0), -32);
  EXPECT_EQ(unwrap15(100, 160), 60);
  // Bit 15 is not part of the counter.
  EXPECT_EQ(unwrap15(0x8000 | 100, 160), 60);
  EXPECT_EQ(unwrap15(0xFFF0, 0x0010), 32);
}

TEST(ArcosUnwrap, NoTwelveBitReduction) {
  // The p2os vector 4090 -> 6 is +12 only under p2os' 12-bit reduction (§1.10, §1.12 item 4);
  // on the 15-bit counter it is a legitimate backwards step of 4084 counts.
  EXPECT_EQ(unwrap15(4090, 6), -4084);
  // A 150-count step (150 mm at p3at-sh per 100 ms = 1.5 m/s) is not discarded as "tainted".
  EXPECT_EQ(unwrap15(1000, 1150), 150);
}

TEST(ArcosParams, SubclassSelectsDistConv) {
  auto old = params_for_subclass("p3at");
  ASSERT_TRUE(old.ok());
  EXPECT_DOUBLE_EQ(old->dist_conv_mm, 0.465);
  auto sh = params_for_subclass("p3at-sh");
  ASSERT_TRUE(sh.ok());
  EXPECT_DOUBLE_EQ(sh->dist_conv_mm, 1.0);
  EXPECT_DOUBLE_EQ(sh->angle_conv_rad, 0.001534);
  EXPECT_EQ(sh->vel2_divisor_mm_s, 20);
  EXPECT_FALSE(params_for_subclass("box").ok());
  EXPECT_FALSE(params_for_subclass("").ok());
  const RobotParams fb = fallback_params("p3dx-sh");
  EXPECT_DOUBLE_EQ(fb.dist_conv_mm, 1.0);
  EXPECT_EQ(fb.subclass, "p3dx-sh");
}

SipPacket sip_at(std::uint16_t x, std::uint16_t y, std::int16_t th) {
  SipPacket s;
  s.x_raw = x;
  s.y_raw = y;
  s.th_raw = th;
  return s;
}

TEST(ArcosOdometry, FirstSipInitialisesThenDeltasIntegrate) {
  Odometry odo{params_for_subclass("p3at").value()};
  odo.update(sip_at(1000, 0x7FF0, 1024), Time::from_ns(1));
  EXPECT_NEAR(odo.state().pose.x_m, 1000 * 0.465e-3, 1e-12);
  EXPECT_NEAR(odo.state().pose.y_m, 0x7FF0 * 0.465e-3, 1e-12);
  EXPECT_NEAR(odo.state().pose.theta_rad, 1024 * 0.001534, 1e-12);
  // Y wraps 0x7FF0 -> 0x0010: +32 counts, not -32736.
  odo.update(sip_at(1000, 0x0010, 1024), Time::from_ns(2));
  EXPECT_NEAR(odo.state().pose.y_m, (0x7FF0 + 32) * 0.465e-3, 1e-12);
  EXPECT_EQ(odo.state().stamp, Time::from_ns(2));
  EXPECT_EQ(odo.state().sips, 2U);
}

TEST(ArcosOdometry, RebaseKeepsThePose) {
  Odometry odo;
  odo.update(sip_at(500, 0, 0), Time{});
  odo.update(sip_at(600, 0, 0), Time{});
  odo.rebase();
  odo.update(sip_at(0, 0, 0), Time{});  // counters restarted after a power cycle
  EXPECT_NEAR(odo.state().pose.x_m, 0.6, 1e-12);
  odo.update(sip_at(50, 0, 0), Time{});
  EXPECT_NEAR(odo.state().pose.x_m, 0.65, 1e-12);
  odo.reset();
  odo.update(sip_at(7, 0, 0), Time{});
  EXPECT_NEAR(odo.state().pose.x_m, 0.007, 1e-12);
}

TEST(ArcosOdometry, VelocitiesFromWheelsOrRotVel) {
  Odometry odo;
  SipPacket s;
  s.left_vel = 100;
  s.right_vel = 300;
  odo.update(s, Time{});
  EXPECT_DOUBLE_EQ(odo.state().trans_vel_mm_s, 200.0);
  EXPECT_NEAR(odo.state().rot_vel_rad_s, 100.0 * 0.0034, 1e-12);  // (R - L)/2 × DiffConv
  s.tail_fields = static_cast<std::uint8_t>(SipField::kRotVel) + 1;
  s.rot_vel = -150;  // -15.0 deg/s
  odo.update(s, Time{});
  EXPECT_NEAR(odo.state().rot_vel_rad_s, -15.0 * kPi / 180.0, 1e-12);
}

// Property: a robot driving a long way at full speed, its counters wrapping many times (p3at:
// 32768 × 0.465 mm = 15.2 m per wrap), integrates to the emulator's own pose within one count.
TEST(ArcosOdometry, LongDriveAcrossManyWrapsMatchesTheTruePose) {
  for (const char* subclass : {"p3at", "p3at-sh"}) {
    SCOPED_TRACE(subclass);
    const RobotParams p = params_for_subclass(subclass).value();
    Odometry odo{p};
    double x = 3.0, y = 2.0, th = 0.3;  // non-negative start: no wrap in the first SIP
    const double v_mm_s = 1200.0, w_rad_s = 0.05, dt = 0.1;
    for (int i = 0; i < 3000; ++i) {  // 300 s, 360 m
      SipPacket s;
      fill_sip_motion(s, p, x, y, th, v_mm_s, v_mm_s);
      odo.update(s, Time{});
      x += v_mm_s * std::cos(th) * dt;
      y += v_mm_s * std::sin(th) * dt;
      th = normalize_angle(th + w_rad_s * dt);
    }
    // The last update saw the pose before the final step.
    x -= v_mm_s * std::cos(normalize_angle(th - w_rad_s * dt)) * dt;
    y -= v_mm_s * std::sin(normalize_angle(th - w_rad_s * dt)) * dt;
    th = normalize_angle(th - w_rad_s * dt);
    EXPECT_NEAR(odo.state().pose.x_m * 1000.0, x, p.dist_conv_mm);
    EXPECT_NEAR(odo.state().pose.y_m * 1000.0, y, p.dist_conv_mm);
    EXPECT_NEAR(normalize_angle(odo.state().pose.theta_rad - th), 0.0, p.angle_conv_rad);
  }
}

}  // namespace
}  // namespace teamscan::arcos
