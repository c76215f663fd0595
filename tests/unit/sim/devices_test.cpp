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
