// Device fields: SIP odometry counters (15-bit wrap, DistConvFactor, THPOS) and their ARIA-style
// decoding; LMS-200 value words and reserved codes (PROTOCOLS.md §1.8, §1.10, §2.7).
#include <gtest/gtest.h>

#include <cmath>

#include "common/dataset/dataset.hpp"
#include "sim/devices.hpp"

namespace teamscan::sim {
namespace {

TEST(PioneerParams, DistConvFactorPerSubclass) {
  EXPECT_DOUBLE_EQ(pioneer_params("p3at").dist_conv_mm, 0.465);
  EXPECT_DOUBLE_EQ(pioneer_params("p3at-sh").dist_conv_mm, 1.0);
}

TEST(PioneerOdometry, CountersOfAStraightDriveWithoutNoise) {
  PioneerOdometry fw{pioneer_params("p3at"), {}, Rng{1, 1, RngStream::odometry}, {5, 5, 0}};
  const SipOdometry s0 = fw.step({5, 5, 0}, 0.0);
  EXPECT_EQ(s0.xpos, 0);
  const SipOdometry s1 = fw.step({5.093, 5, 0}, 0.1);  // 93 mm forward = 200 counts at 0.465 mm
  EXPECT_EQ(s1.xpos, 200);
  EXPECT_EQ(s1.ypos, 0);
  EXPECT_EQ(s1.thpos, 0);
  EXPECT_EQ(s1.left_vel_mmps, 930);
  EXPECT_EQ(s1.right_vel_mmps, 930);
}

TEST(PioneerOdometry, NegativePositionsWrapIn15Bits) {
  PioneerOdometry fw{pioneer_params("p3at-sh"), {}, Rng{1, 1, RngStream::odometry}, {0, 0, 0}};
  (void)fw.step({0, 0, 0}, 0);
  const SipOdometry s = fw.step({-0.001, 0, 0}, 0.1);  // 1 mm backwards
  EXPECT_EQ(s.xpos, 0x7FFF);
}

TEST(PioneerOdometry, ThposIs4096CountsPerTurn) {
  PioneerOdometry fw{pioneer_params("p3at-sh"), {}, Rng{1, 1, RngStream::odometry}, {0, 0, 0}};
  (void)fw.step({0, 0, 0}, 0);
  EXPECT_EQ(fw.step({0, 0, kPi / 2}, 0.1).thpos, 1024);
  EXPECT_EQ(fw.step({0, 0, kPi}, 0.1).thpos, -2048);
  EXPECT_EQ(fw.step({0, 0, -kPi / 2}, 0.1).thpos, -1024);
}

TEST(OdometryDecoder, AccumulatesAcrossTheWrap) {
  OdometryDecoder dec{pioneer_params("p3at-sh")};
  Pose2 p = dec.decode({0x7F00, 0x0010, 0, 0, 0});
  EXPECT_NEAR(p.x_m, -0.256, 1e-12);  // 0x7F00 as signed 15-bit = −256
  p = dec.decode({0x0100, 0x0010, 0, 0, 0});  // +512 counts across the wrap
  EXPECT_NEAR(p.x_m, 0.256, 1e-12);
  p = dec.decode({0x7000, 0x0010, 0, 0, 0});  // 0x7000 − 0x0100 > 0x1000: a −0x1100 step backwards
  EXPECT_NEAR(p.x_m, (256.0 - 0x1100) * 1e-3, 1e-12);
  EXPECT_NEAR(p.y_m, 0.016, 1e-12);
}

TEST(OdometryDecoder, RoundTripOfALongDriveMatchesTheFirmwareToTheCount) {
  // Drive 40 m on a circle of radius 10 m at 1 m/s (the counters wrap more than once at 0.465 mm):
  // the decoded pose equals the firmware's internal pose to the quantisation of one count.
  const PioneerParams params = pioneer_params("p3at");
  PioneerOdometry fw{params, {}, Rng{7, 1, RngStream::odometry}, {0, 0, 0}};
  OdometryDecoder dec{params};
  Pose2 truth{0, 0, 0};
  Pose2 decoded = dec.decode(fw.step(truth, 0));
  for (int k = 1; k <= 400; ++k) {
    const double phi = 0.01 * k;
    truth = {10.0 * std::sin(phi), 10.0 * (1.0 - std::cos(phi)), normalize_angle(phi)};
    decoded = dec.decode(fw.step(truth, 0.1));
  }
  EXPECT_NEAR(decoded.x_m, fw.internal_pose().x_m, 0.465e-3);
  EXPECT_NEAR(decoded.y_m, fw.internal_pose().y_m, 0.465e-3);
  EXPECT_NEAR(normalize_angle(decoded.theta_rad - fw.internal_pose().theta_rad), 0.0, 2e-3);
  // Without noise the firmware's pose follows the truth: a chord along the mean heading is exact on an arc.
  EXPECT_NEAR(fw.internal_pose().x_m, truth.x_m, 1e-9);
  EXPECT_NEAR(fw.internal_pose().y_m, truth.y_m, 1e-9);
}

TEST(PioneerOdometry, NoiseIsSeededAndChangesThePose) {
  auto run = [](std::uint64_t seed) {
    PioneerOdometry fw{pioneer_params("p3at-sh"), {0.05, 0.05, 0.0}, Rng{seed, 1, RngStream::odometry}, {0, 0, 0}};
    (void)fw.step({0, 0, 0}, 0);
    for (int k = 1; k <= 100; ++k) (void)fw.step({0.1 * k, 0, 0}, 0.1);
    return fw.internal_pose();
  };
  EXPECT_EQ(run(3).x_m, run(3).x_m);
  EXPECT_NE(run(3).x_m, run(4).x_m);
  EXPECT_NEAR(run(3).x_m, 10.0, 0.5);
}

// Drives `metres` straight along x (or turns on the spot when `turn_rad` is set) in 3 cm SIP steps and
// returns the firmware's odometry pose.
Pose2 drive(const OdometryNoise& noise, std::uint64_t seed, double metres, double turn_rad = 0.0) {
  PioneerOdometry fw{pioneer_params("p3at-sh"), noise, Rng{seed, 1, RngStream::odometry}, {0, 0, 0}};
  (void)fw.step({0, 0, 0}, 0);
  const int steps = 1000;
  for (int k = 1; k <= steps; ++k) (void)fw.step({metres * k / steps, 0, normalize_angle(turn_rad * k / steps)}, 0.1);
  return fw.internal_pose();
}

TEST(SkidSteerDrift, SystematicSlipScalesTheReportedDistance) {
  OdometryNoise n;
  n.slip = 0.02;
  const Pose2 p = drive(n, 1, 30.0);
  EXPECT_NEAR(p.x_m, 30.6, 1e-9);  // 2 % more than travelled
  EXPECT_NEAR(p.y_m, 0.0, 1e-9);
}

TEST(SkidSteerDrift, HeadingDriftPerMetreAccumulatesLinearly) {
  OdometryNoise n;
  n.drift_rad_per_m = deg_to_rad(0.25);
  const Pose2 p = drive(n, 1, 20.0);
  EXPECT_NEAR(rad_to_deg(p.theta_rad), 5.0, 1e-9);  // 0.25°/m × 20 m
  // The path bends with the heading: a constant curvature κ = drift gives y = (1 − cos(κs))/κ.
  const double k = n.drift_rad_per_m;
  EXPECT_NEAR(p.y_m, (1.0 - std::cos(k * 20.0)) / k, 1e-3);
}

TEST(SkidSteerDrift, TurnSlipOverstatesTheRotationOnlyWhenTurning) {
  OdometryNoise n;
  n.turn_slip = 0.03;
  EXPECT_NEAR(drive(n, 1, 10.0).theta_rad, 0.0, 1e-12);  // straight: no effect
  // A quarter turn on the spot (in steps): reported 3 % more.
  EXPECT_NEAR(drive(n, 1, 0.0, kPi / 2).theta_rad, 1.03 * kPi / 2, 1e-9);
  EXPECT_NEAR(drive(n, 1, 0.0, -kPi / 2).theta_rad, -1.03 * kPi / 2, 1e-9);
}

TEST(SkidSteerDrift, HeadingRandomWalkHasTheConfiguredSpread) {
  // σ of the heading error after d metres = walk · √d, over many seeds; the mean stays at zero.
  OdometryNoise n;
  n.heading_walk_rad_per_sqrt_m = deg_to_rad(0.5);
  const double d = 16.0;
  const int runs = 400;
  double sum = 0, sum2 = 0;
  for (int seed = 1; seed <= runs; ++seed) {
    const double e = drive(n, static_cast<std::uint64_t>(seed), d).theta_rad;
    sum += e;
    sum2 += e * e;
  }
  const double mean = sum / runs, sd = std::sqrt(sum2 / runs - mean * mean);
  const double expected = n.heading_walk_rad_per_sqrt_m * std::sqrt(d);
  EXPECT_NEAR(sd, expected, 0.1 * expected);                     // 400 runs: σ of the estimate ≈ 3.5 %
  EXPECT_NEAR(mean, 0.0, 4.0 * expected / std::sqrt(runs));
}

TEST(SkidSteerDrift, SlipSigmaIsZeroMeanJitterOfTheDistance) {
  OdometryNoise n;
  n.slip_sigma = 0.2;  // per 3 cm cycle; 1000 cycles → σ of the total ≈ 0.2 · 30 m / √1000
  const int runs = 200;
  double sum = 0, sum2 = 0;
  for (int seed = 1; seed <= runs; ++seed) {
    const double e = drive(n, static_cast<std::uint64_t>(seed), 30.0).x_m - 30.0;
    sum += e;
    sum2 += e * e;
  }
  const double mean = sum / runs, sd = std::sqrt(sum2 / runs - mean * mean);
  const double expected = 0.2 * 0.03 * std::sqrt(1000.0);
  EXPECT_NEAR(sd, expected, 0.15 * expected);
  EXPECT_NEAR(mean, 0.0, 4.0 * expected / std::sqrt(runs));
}

TEST(SkidSteerDrift, DeterministicBySeedAndStreamsDoNotShift) {
  OdometryNoise n;
  n.slip = 0.02;
  n.drift_rad_per_m = deg_to_rad(0.25);
  n.slip_sigma = 0.01;
  n.heading_sigma = 0.01;
  n.heading_walk_rad_per_sqrt_m = deg_to_rad(0.05);
  const Pose2 a = drive(n, 5, 12.0, 2.0), b = drive(n, 5, 12.0, 2.0), c = drive(n, 6, 12.0, 2.0);
  EXPECT_EQ(a.x_m, b.x_m);  // bit for bit
  EXPECT_EQ(a.y_m, b.y_m);
  EXPECT_EQ(a.theta_rad, b.theta_rad);
  EXPECT_NE(a.theta_rad, c.theta_rad);
  // Systematic terms draw nothing: with only them on, the pose is the same for every seed.
  OdometryNoise sys;
  sys.slip = 0.02;
  sys.turn_slip = 0.01;
  sys.drift_rad_per_m = deg_to_rad(0.25);
  EXPECT_EQ(drive(sys, 5, 12.0, 2.0).x_m, drive(sys, 6, 12.0, 2.0).x_m);
}

TEST(LmsValue, RoundsToMillimetresAndUsesReservedCodes) {
  Rng rng{1, 1, RngStream::range_noise};
  EXPECT_EQ(lms_value_word(true, 1.2344, 0.0, rng), 1234);
  EXPECT_EQ(lms_value_word(true, 1.2346, 0.0, rng), 1235);
  EXPECT_EQ(lms_value_word(true, 8.182, 0.0, rng), 8182);
  EXPECT_EQ(lms_value_word(true, 8.1826, 0.0, rng), 0x1FF7);  // beyond the 8.182 m maximum
  EXPECT_EQ(lms_value_word(false, 0.0, 0.0, rng), 0x1FFF);     // no return
}

TEST(LmsValue, NoiseHasTheConfiguredSpread) {
  Rng rng{9, 1, RngStream::range_noise};
  double sum = 0, sum2 = 0;
  const int n = 20000;
  for (int i = 0; i < n; ++i) {
    const double e = lms_value_word(true, 4.0, 5.0, rng) - 4000.0;
    sum += e;
    sum2 += e * e;
  }
  const double mean = sum / n, sd = std::sqrt(sum2 / n - mean * mean);
  EXPECT_NEAR(mean, 0.0, 0.2);
  EXPECT_NEAR(sd, std::sqrt(25.0 + 1.0 / 12.0), 0.2);  // σ ≈ 5 mm plus the rounding to 1 mm
}

TEST(LmsValue, ClientDecodesDistancesAndFlagsReservedCodes) {
  EXPECT_TRUE(decode_lms_value(1234).valid);
  EXPECT_EQ(decode_lms_value(1234).range_mm, 1234);
  EXPECT_EQ(decode_lms_value(0xE000 | 1234).range_mm, 1234);  // flag bits 13..15 ignored
  const DecodedRange far = decode_lms_value(0x1FF7);
  EXPECT_FALSE(far.valid);
  EXPECT_TRUE(far.flags & point_flags::kOutOfRange);
  EXPECT_TRUE(decode_lms_value(0x1FFE).flags & point_flags::kDazzled);
  EXPECT_FALSE(decode_lms_value(0x1FFF).valid);
  EXPECT_FALSE(decode_lms_value(0x1FFB).valid);
}

}  // namespace
}  // namespace teamscan::sim
