// The PCD reader on real files recorded by others (tests/data/real, SOURCES.md): binary_compressed
// (room_scan1, office1, organised with NaN) and ascii (sac_plane_test). Counts and bounds come from
// SOURCES.md and from PCL's own ascii conversion of the same files.
#include <algorithm>
#include <cmath>
#include <filesystem>

#include <gtest/gtest.h>

#include "common/dataset/pcd.hpp"
#include "tests/support/real_data.hpp"
#include "tests/unit/dataset/test_util.hpp"

namespace teamscan {
namespace {

std::string real(const char* name) { return teamscan::test::real_data_path(name); }

struct Bounds {
  float lo[3] = {1e30f, 1e30f, 1e30f}, hi[3] = {-1e30f, -1e30f, -1e30f};
};
Bounds bounds_of(const PcdCloud& c) {
  Bounds b;
  for (std::size_t i = 0; i < c.size(); ++i)
    for (int k = 0; k < 3; ++k) {
      b.lo[k] = std::min(b.lo[k], c.xyz[3 * i + static_cast<std::size_t>(k)]);
      b.hi[k] = std::max(b.hi[k], c.xyz[3 * i + static_cast<std::size_t>(k)]);
    }
  return b;
}

TEST(PcdReal, RoomScan1BinaryCompressed) {
  const auto cloud = read_pcd(real("room_scan1.pcd"));
  ASSERT_TRUE(cloud.ok()) << cloud.error().what;
  EXPECT_EQ(cloud->size(), 112586u);
  EXPECT_EQ(cloud->fields, (std::vector<std::string>{"x", "y", "z"}));
  const Bounds b = bounds_of(*cloud);
  // SOURCES.md: a room of about 30 x 15 m, floor near z = -1.27 m, ceiling near +1.66 m. The exact
  // extremes (-13.79978..15.44711, -6.49282..7.979565, -1.351705..1.709093) are what PCL's
  // pcl_convert_pcd_ascii_binary prints for this file.
  EXPECT_NEAR(b.lo[0], -13.79978f, 1e-5f);
  EXPECT_NEAR(b.hi[0], 15.44711f, 1e-5f);
  EXPECT_NEAR(b.lo[1], -6.49282f, 1e-5f);
  EXPECT_NEAR(b.hi[1], 7.979565f, 1e-5f);
  EXPECT_NEAR(b.lo[2], -1.351705f, 1e-5f);
  EXPECT_NEAR(b.hi[2], 1.709093f, 1e-5f);
  // First point as PCL prints it: 0.1071819 0.05294582 1.685766.
  EXPECT_NEAR(cloud->xyz[0], 0.1071819f, 1e-7f);
  EXPECT_NEAR(cloud->xyz[1], 0.05294582f, 1e-7f);
  EXPECT_NEAR(cloud->xyz[2], 1.685766f, 1e-6f);
}

TEST(PcdReal, Office1OrganisedDropsNaN) {
  const auto cloud = read_pcd(real("office1.pcd"));
  ASSERT_TRUE(cloud.ok()) << cloud.error().what;
  EXPECT_EQ(cloud->width, 640u);
  EXPECT_EQ(cloud->height, 480u);
  EXPECT_EQ(cloud->size(), 254456u);  // SOURCES.md: finite points of 307200
  ASSERT_EQ(cloud->field("rgb"), 3);
  for (float v : cloud->xyz) ASSERT_TRUE(std::isfinite(v));
  // An RGB-D camera frame: depth z is positive and within a Kinect's few metres.
  const Bounds b = bounds_of(*cloud);
  EXPECT_GT(b.lo[2], 0.2f);
  EXPECT_LT(b.hi[2], 10.0f);
}

TEST(PcdReal, SacPlaneTestAscii) {
  const auto cloud = read_pcd(real("sac_plane_test.pcd"));
  ASSERT_TRUE(cloud.ok()) << cloud.error().what;
  EXPECT_EQ(cloud->size(), 3283u);
  EXPECT_EQ(cloud->fields.size(), 7u);
  // First data line of the file: 1.068 0.094720997 -0.016231 -0.33680952 -0.5904243 -0.73345655 0.021525998
  EXPECT_EQ(cloud->xyz[0], 1.068f);
  EXPECT_EQ(cloud->xyz[1], 0.094720997f);
  EXPECT_EQ(cloud->xyz[2], -0.016231f);
  // curvature is declared F 4: the value is the float nearest the text.
  EXPECT_EQ(cloud->columns[static_cast<std::size_t>(cloud->field("curvature"))][0], static_cast<double>(0.021525998f));
  // The normals are unit vectors where PCL could estimate one (NaN elsewhere): a property of the file
  // that a misaligned column read would break.
  const auto nx = static_cast<std::size_t>(cloud->field("normal_x"));
  std::size_t finite = 0;
  for (std::size_t i = 0; i < cloud->size(); ++i) {
    const double n = std::hypot(cloud->columns[nx][i], cloud->columns[nx + 1][i], cloud->columns[nx + 2][i]);
    if (std::isnan(n)) continue;
    ++finite;
    ASSERT_NEAR(n, 1.0, 1e-5) << "point " << i;
  }
  EXPECT_GT(finite, cloud->size() * 9 / 10);
}

}  // namespace
}  // namespace teamscan
