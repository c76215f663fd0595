// TUM trajectory text: exact stamps to the microsecond, the heading as a unit quaternion about z, one
// file per robot with its scans in processing order.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>

#include <unistd.h>

#include "groundstation/trajectory/tum.hpp"

namespace teamscan::trajectory {
namespace {

TEST(Tum, LineHasExactStampAndQuaternion) {
  EXPECT_EQ(tum_line({976052857337284, {1.5, -2.0, 0.0}}), "976052857.337284 1.5 -2 0 0 0 0 1\n");
  EXPECT_EQ(tum_line({1000005, {0, 0, 0}}), "1.000005 0 0 0 0 0 0 1\n");
  // Heading π/2: q = (0, 0, sin π/4, cos π/4).
  std::istringstream in(tum_line({0, {0, 0, kPi / 2}}));
  std::string t;
  double x, y, z, qx, qy, qz, qw;
  in >> t >> x >> y >> z >> qx >> qy >> qz >> qw;
  EXPECT_EQ(t, "0.000000");
  EXPECT_DOUBLE_EQ(qz, std::sqrt(0.5));
  EXPECT_DOUBLE_EQ(qw, std::sqrt(0.5));
}

TEST(Tum, ScanStampIsTheSourceStampElseTheProcessingStamp) {
  ScanRecord s;
  s.stamp_ns = 1'234'567'890;
  EXPECT_EQ(scan_stamp_us(s), 1'234'568);  // rounded to the microsecond
  s.source_stamp_us = 976052857337284;
  EXPECT_EQ(scan_stamp_us(s), 976052857337284);
}

TEST(Tum, OneFilePerRobotInProcessingOrder) {
  Dataset d;
  d.robots.resize(2);
  d.robots[0].id = 1;
  d.robots[1].id = 3;
  for (int i = 0; i < 4; ++i) {
    ScanRecord s;
    s.robot = i % 2 == 0 ? 1 : 3;
    s.scan = static_cast<std::uint32_t>(i);
    s.source_stamp_us = 2'000'000 - i * 100;  // stamps that step back stay in the given order
    d.scans.push_back(s);
  }
  const std::vector<Pose2> poses = {{0, 0, 0}, {1, 0, 0}, {2, 0, 0}, {3, 0, 0}};
  const auto dir = std::filesystem::temp_directory_path() / ("tum_test_" + std::to_string(::getpid()));
  ASSERT_TRUE(write_tum_per_robot(dir.string(), d, poses, {1, 1, 1, 0}));
  std::ifstream r1(dir / "robot1.tum"), r3(dir / "robot3.tum");
  std::stringstream a, b;
  a << r1.rdbuf();
  b << r3.rdbuf();
  EXPECT_EQ(a.str(), "2.000000 0 0 0 0 0 0 1\n1.999800 2 0 0 0 0 0 1\n");
  EXPECT_EQ(b.str(), "1.999900 1 0 0 0 0 0 1\n");  // the undecided scan is left out
  EXPECT_FALSE(write_tum_per_robot(dir.string(), d, {{0, 0, 0}}));  // one pose per scan
  std::filesystem::remove_all(dir);
}

TEST(Tum, AppenderAddsLinesPerRobotAndKeepsAnEarlierRun) {
  const auto dir = std::filesystem::temp_directory_path() / ("tum_append_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  {
    TumAppender a(dir.string());
    EXPECT_TRUE(a.add(2, {1000000, {1, 0, 0}}));
    EXPECT_TRUE(a.add(5, {1000001, {2, 0, 0}}));
  }
  {
    TumAppender b(dir.string());  // a restarted station: appends
    EXPECT_TRUE(b.add(2, {1000002, {3, 0, 0}}));
    b.flush();
    std::ifstream r2(dir / "robot2.tum");
    std::stringstream t;
    t << r2.rdbuf();
    EXPECT_EQ(t.str(), "1.000000 1 0 0 0 0 0 1\n1.000002 3 0 0 0 0 0 1\n");
  }
  TumAppender bad((dir / "missing" / "folder").string());
  EXPECT_FALSE(bad.add(1, {0, {}}));
  EXPECT_EQ(bad.failures(), 1u);
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace teamscan::trajectory
