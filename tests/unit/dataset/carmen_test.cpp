// CARMEN log reader: FLASER and ODOM lines, counted malformed lines, the data set it makes.
#include <gtest/gtest.h>

#include <cmath>

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

}  // namespace
}  // namespace teamscan
