// CARMEN log reader: FLASER and ODOM lines, counted malformed lines, the data set it makes.
#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "common/dataset/carmen.hpp"

namespace teamscan {
namespace {

TEST(Carmen, ParsesFlaserAndOdomAndCountsTheRest) {
  const CarmenLog log = parse_carmen(
      "# comment\n"
      "FLASER 3 1.0 2.0 81.83 9 9 9 0.1 0.2 0.3 12.5 host 12.5\n"
      "ODOM 0.1 0.2 0.3 0.4 0.05 0 12.5 host 12.5\n"
      "PARAM robot_width 0.5\n"
      "FLASER 3 1.0 x 2.0 0 0 0 0 0 0 13 h 13\n"
      "FLASER 5 1 2\n");
  EXPECT_EQ(log.lines, 6u);
  ASSERT_EQ(log.lasers.size(), 1u);
  EXPECT_EQ(log.lasers[0].ranges_m.size(), 3u);
  EXPECT_DOUBLE_EQ(log.lasers[0].pose.x_m, 0.1);  // the odometry fields, not the first pose
  EXPECT_DOUBLE_EQ(log.lasers[0].stamp_s, 12.5);
  ASSERT_EQ(log.odom.size(), 1u);
  EXPECT_DOUBLE_EQ(log.odom[0].v_mps, 0.4);
  EXPECT_EQ(log.other_messages, 1u);
  EXPECT_EQ(log.malformed, 2u);
  EXPECT_NE(log.first_error.find("line 5"), std::string::npos) << log.first_error;
}

TEST(Carmen, DatasetPutsBeamsRightToLeftAtTheMountHeight) {
  const CarmenLog log = parse_carmen("FLASER 3 1.0 2.0 81.83 0 0 0 1.0 0.0 1.5707963267948966 0 h 0\n"
                                     "FLASER 3 1.0 1.0 1.0 0 0 0 1.0 0.0 1.5707963267948966 0.1 h 0.1\n");
  CarmenImportOptions o;
  o.mount_height_m = 0.4;
  const Result<Dataset> d = carmen_to_dataset(log, o);
  ASSERT_TRUE(d);
  ASSERT_EQ(d->scans.size(), 2u);
  ASSERT_EQ(d->points.size(), 5u);  // 81.83 m = no return
  // Facing +y: beam 0 points right (+x), beam 1 ahead (+y).
  EXPECT_NEAR(d->points[0].x, 2.0, 1e-6);
  EXPECT_NEAR(d->points[0].y, 0.0, 1e-6);
  EXPECT_NEAR(d->points[1].x, 1.0, 1e-6);
  EXPECT_NEAR(d->points[1].y, 2.0, 1e-6);
  EXPECT_FLOAT_EQ(d->points[1].z, 0.4f);
  EXPECT_EQ(d->scans[1].stamp_ns, 100'000'000);
  EXPECT_TRUE(d->truth.empty());
  EXPECT_EQ(d->odom.size(), 2u);
  EXPECT_FALSE(carmen_to_dataset(parse_carmen("ODOM 0 0 0 0 0 0 1 h 1\n"), o));
}

TEST(Carmen, StampsAreExactMicroseconds) {
  std::int64_t us = 0;
  ASSERT_TRUE(parse_carmen_stamp_us("976052857.337284", us));
  EXPECT_EQ(us, 976052857337284);
  ASSERT_TRUE(parse_carmen_stamp_us("12.5", us));
  EXPECT_EQ(us, 12500000);
  ASSERT_TRUE(parse_carmen_stamp_us("7", us));
  EXPECT_EQ(us, 7000000);
  ASSERT_TRUE(parse_carmen_stamp_us("1.0000005", us));  // the seventh decimal rounds
  EXPECT_EQ(us, 1000001);
  EXPECT_FALSE(parse_carmen_stamp_us("1.2e3", us));
  EXPECT_FALSE(parse_carmen_stamp_us("", us));
  EXPECT_FALSE(parse_carmen_stamp_us(".", us));
  EXPECT_FALSE(parse_carmen_stamp_us("abc", us));
}

// File order is the true order: a stamp that steps back keeps its exact value as the source stamp,
// and the processing stamps (scans and ODOM lines on one clock) never step back.
TEST(Carmen, StampsThatStepBackKeepFileOrder) {
  const CarmenLog log = parse_carmen(
      "ODOM 0 0 0 0 0 0 976052857.337284 h 976052857.337284\n"
      "FLASER 2 1 1 0 0 0 0.0 0 0 976052857.500000 h 0\n"
      "ODOM 0.1 0 0 0 0 0 976052857.600001 h 0\n"
      "FLASER 2 1 1 0 0 0 0.1 0 0 976052857.300123 h 0\n"   // steps back 0.3 s
      "ODOM 0.2 0 0 0 0 0 976052857.300200 h 0\n"
      "FLASER 2 1 1 0 0 0 0.2 0 0 976052857.900000 h 0\n");
  ASSERT_EQ(log.lasers.size(), 3u);
  ASSERT_EQ(log.odom.size(), 3u);
  EXPECT_EQ(log.lasers[1].stamp_us, 976052857300123);
  const Result<Dataset> d = carmen_to_dataset(log, CarmenImportOptions{});
  ASSERT_TRUE(d);
  ASSERT_EQ(d->scans.size(), 3u);
  EXPECT_EQ(d->scans[0].source_stamp_us, 976052857500000);
  EXPECT_EQ(d->scans[1].source_stamp_us, 976052857300123);
  EXPECT_EQ(d->scans[2].source_stamp_us, 976052857900000);
  // Processing stamps from the first line (the first ODOM): 162 716 µs, then 1 µs after the ODOM line
  // stamped 600 001 (the scan stamped before it), then its source stamp again.
  EXPECT_EQ(d->scans[0].stamp_ns, 162'716'000);
  EXPECT_EQ(d->scans[1].stamp_ns, (600'001 - 337'284 + 1) * 1000);
  EXPECT_EQ(d->scans[2].stamp_ns, (900'000 - 337'284) * 1000);
  ASSERT_EQ(d->odom.size(), 3u);  // the ODOM lines, not the scans' poses
  EXPECT_EQ(d->odom[0].stamp_ns, 0);
  EXPECT_EQ(d->odom[2].stamp_ns, (600'001 - 337'284 + 2) * 1000);
  for (std::size_t i = 1; i < d->odom.size(); ++i) EXPECT_GT(d->odom[i].stamp_ns, d->odom[i - 1].stamp_ns);
  EXPECT_DOUBLE_EQ(d->scans[1].pose.x_m, 0.1);
}

// Stamps a log can hold (twelve digits of seconds) but no robot's run spans: refused with a message,
// never an overflow of the nanosecond stamps.
TEST(Carmen, StampsSpanningCenturiesAreRefused) {
  const CarmenLog log = parse_carmen(
      "FLASER 2 1 1 0 0 0 0.0 0 0 -99999999999.5 h 0\n"
      "FLASER 2 1 1 0 0 0 0.1 0 0 399999999999.0 h 0\n");
  ASSERT_EQ(log.lasers.size(), 2u);
  const Result<Dataset> d = carmen_to_dataset(log, CarmenImportOptions{});
  ASSERT_FALSE(d);
  EXPECT_NE(std::string(d.error().what).find("292 years"), std::string::npos) << d.error().what;
  // A span that fits still converts.
  const CarmenLog near = parse_carmen(
      "FLASER 2 1 1 0 0 0 0.0 0 0 -1000.5 h 0\n"
      "FLASER 2 1 1 0 0 0 0.1 0 0 1000.0 h 0\n");
  const Result<Dataset> ok = carmen_to_dataset(near, CarmenImportOptions{});
  ASSERT_TRUE(ok);
  EXPECT_EQ(ok->scans[1].stamp_ns, 2'000'500'000'000);
}

// ROBOTLASER1: its own start angle and step, the laser's pose beside the robot's (the mount).
TEST(Carmen, RobotLaser1UsesItsAnglesAndLaserOffset) {
  // Robot at (1, 0) facing +y; its laser 0.2 m ahead of it: at (1, 0.2). Two beams: −90° and 0°.
  const CarmenLog log = parse_carmen(
      "ROBOTLASER1 0 -1.5707963267948966 1.5707963267948966 1.5707963267948966 80 0.01 0 2 1.0 2.0 0 "
      "1.0 0.2 1.5707963267948966 1.0 0.0 1.5707963267948966 0 0 0 0 0 100.000001 h 100.000001\n"
      "ROBOTLASER1 0 -1.5 1.5 1.5 80 0.01 0 2 1.0 2.0 1 5 1 1 0 1 1 0\n");  // too few fields
  ASSERT_EQ(log.lasers.size(), 1u) << log.first_error;
  EXPECT_EQ(log.malformed, 1u);
  EXPECT_EQ(log.lasers[0].stamp_us, 100000001);
  const Result<Dataset> d = carmen_to_dataset(log, CarmenImportOptions{});
  ASSERT_TRUE(d);
  EXPECT_NEAR(d->robots[0].mount_xyz_m[0], 0.2, 1e-12);
  EXPECT_NEAR(d->robots[0].mount_xyz_m[1], 0.0, 1e-12);
  EXPECT_NEAR(d->robots[0].mount_rpy_rad[2], 0.0, 1e-12);
  EXPECT_DOUBLE_EQ(d->scans[0].pose.x_m, 1.0);  // the robot's odometry, not the laser's
  EXPECT_NEAR(d->scans[0].origin.y, 0.2, 1e-12);
  ASSERT_EQ(d->points.size(), 2u);
  EXPECT_NEAR(d->points[0].x, 2.0, 1e-6);  // beam 0: to the right of +y = +x, 1 m from the laser
  EXPECT_NEAR(d->points[0].y, 0.2, 1e-6);
  EXPECT_NEAR(d->points[1].x, 1.0, 1e-6);  // beam 1: straight ahead, 2 m
  EXPECT_NEAR(d->points[1].y, 2.2, 1e-6);
}

// A ROBOTLASER1 line's own maximum range: a reading at it is no return (a laser that reports 8 m when
// nothing came back), one short of it a point; the import's --max-range still applies when shorter.
TEST(Carmen, RobotLaser1ReadingsAtTheLasersMaximumAreNoReturn) {
  const std::string line =
      "ROBOTLASER1 0 -1.5707963267948966 3.141592653589793 1.5707963267948966 8.0 0.01 0 3 7.9 8.0 9.5 0 "
      "0 0 0 0 0 0 0 0 0 0 0 100.0 h 100.0\n";
  const CarmenLog log = parse_carmen(line);
  ASSERT_EQ(log.lasers.size(), 1u) << log.first_error;
  EXPECT_DOUBLE_EQ(log.lasers[0].max_range_m, 8.0);
  const Result<Dataset> d = carmen_to_dataset(log, CarmenImportOptions{});
  ASSERT_TRUE(d);
  ASSERT_EQ(d->points.size(), 1u) << "8.0 and 9.5 m are no return";
  EXPECT_EQ(d->points[0].beam, 0u);
  EXPECT_EQ(d->scans[0].points, 1u);
  CarmenImportOptions shorter;
  shorter.max_range_m = 5.0;
  const Result<Dataset> none = carmen_to_dataset(log, shorter);
  ASSERT_TRUE(none);
  EXPECT_TRUE(none->points.empty());
}

TEST(Carmen, FlaserStepConvention) {
  const CarmenLog log = parse_carmen("FLASER 4 1 1 1 1 0 0 0 0 0 0 1 h 1\n");
  CarmenImportOptions o;
  o.flaser_step_is_fov_over_n = true;  // 45° apart: −90, −45, 0, 45
  const Result<Dataset> d = carmen_to_dataset(log, o);
  ASSERT_TRUE(d);
  ASSERT_EQ(d->points.size(), 4u);
  EXPECT_NEAR(d->points[3].x, std::sqrt(0.5), 1e-6);
  EXPECT_NEAR(d->points[3].y, std::sqrt(0.5), 1e-6);
}

}  // namespace
}  // namespace teamscan
