// Ray casting against hand-computed configurations: slab boxes, the room, a tilted beam to the floor,
// another robot's side, furniture, and a robot's own rays passing through its own body.
#include <gtest/gtest.h>

#include <cmath>

#include "sim/world.hpp"

namespace teamscan::sim {
namespace {

constexpr double kTol = 1e-9;

TEST(Intersect, AxisAlignedBoxFromOutside) {
  const OrientedBox box = OrientedBox::axis_aligned({1, -1, -1}, {2, 1, 1});
  const Ray ray{{0, 0, 0}, {1, 0, 0}};
  const auto t = intersect(ray, box, 100);
  ASSERT_TRUE(t.has_value());
  EXPECT_NEAR(*t, 1.0, kTol);
}

TEST(Intersect, MissesBesideBehindAndBeyondRange) {
  const OrientedBox box = OrientedBox::axis_aligned({1, -1, -1}, {2, 1, 1});
  EXPECT_FALSE(intersect({{0, 1.5, 0}, {1, 0, 0}}, box, 100).has_value());  // passes beside
  EXPECT_FALSE(intersect({{0, 0, 0}, {-1, 0, 0}}, box, 100).has_value());   // points away
  EXPECT_FALSE(intersect({{0, 0, 0}, {1, 0, 0}}, box, 0.99).has_value());   // beyond max range
  EXPECT_FALSE(intersect({{1.5, 0, 0}, {1, 0, 0}}, box, 100).has_value());  // starts inside
}

TEST(Intersect, YawedBoxCorner) {
  // A unit cube yawed 45° about its centre (3, 0): its corner points at the origin along −x, at
  // distance 3 − √2/2 from the origin.
  const OrientedBox box = OrientedBox::yawed({3, 0}, kPi / 4, {1, 1, 1}, -0.5);
  const auto t = intersect({{0, 0, 0}, {1, 0, 0}}, box, 100);
  ASSERT_TRUE(t.has_value());
  EXPECT_NEAR(*t, 3.0 - std::sqrt(0.5), 1e-9);
}

TEST(Intersect, DiagonalRayEntersAtTheLaterSlab) {
  const OrientedBox box = OrientedBox::axis_aligned({1, 2, -1}, {3, 4, 1});
  const double s = 1.0 / std::sqrt(2.0);
  const auto t = intersect({{0, 0, 0}, {s, s, 0}}, box, 100);
  ASSERT_TRUE(t.has_value());
  EXPECT_NEAR(*t, 2.0 * std::sqrt(2.0), kTol);  // enters through y = 2 at (2, 2)
}

TEST(Room, LevelBeamHitsTheWallAndVerticalBeamsFloorAndCeiling) {
  const World world{Room{{10, 8, 3}}};
  Hit h = world.cast({{1, 0, 0.5}, {1, 0, 0}}, {}, 0);
  ASSERT_TRUE(h.hit);
  EXPECT_EQ(h.label, PointClass::wall);
  EXPECT_NEAR(h.range_m, 4.0, kTol);
  h = world.cast({{1, 0, 0.5}, {0, 0, -1}}, {}, 0);
  EXPECT_EQ(h.label, PointClass::floor);
  EXPECT_NEAR(h.range_m, 0.5, kTol);
  EXPECT_NEAR(h.point_m.z, 0.0, kTol);
  h = world.cast({{1, 0, 0.5}, {0, 0, 1}}, {}, 0);
  EXPECT_EQ(h.label, PointClass::ceiling);
  EXPECT_NEAR(h.range_m, 2.5, kTol);
  h = world.cast({{20, 0, 0.5}, {-1, 0, 0}}, {}, 0);
  EXPECT_FALSE(h.hit);  // origin outside the room
}

TEST(Room, TiltedBeamHitsTheFloorWhereTrigonometrySays) {
  // A laser 0.462 m above the floor pitched down by 15°: its centre beam reaches the floor at
  // h / sin(15°) along the beam, h / tan(15°) ahead.
  const World world{Room{{10, 8, 3}}};
  const double h = 0.462, pitch = deg_to_rad(15.0);
  const Pose3 laser = Pose3::from_xyz_rpy(0, 0, h, 0, pitch, 0);
  const Vec3 dir = laser.rotation.apply({1, 0, 0});
  const Hit hit = world.cast({laser.translation, dir}, {}, 0);
  EXPECT_EQ(hit.label, PointClass::floor);
  EXPECT_NEAR(hit.range_m, h / std::sin(pitch), 1e-9);
  EXPECT_NEAR(hit.point_m.x, h / std::tan(pitch), 1e-9);
  // A beam 30° off centre in the tilted plane: direction (cos a cos p, sin a, −cos a sin p).
  const double a = deg_to_rad(30.0);
  const Vec3 d2 = laser.rotation.apply({std::cos(a), std::sin(a), 0});
  EXPECT_NEAR(d2.z, -std::cos(a) * std::sin(pitch), 1e-12);
  const Hit hit2 = world.cast({laser.translation, d2}, {}, 0);
  EXPECT_EQ(hit2.label, PointClass::floor);
  EXPECT_NEAR(hit2.range_m, h / (std::cos(a) * std::sin(pitch)), 1e-9);
}

TEST(Furniture, TableTopIsASuspendedSurface) {
  World world{Room{{10, 8, 3}}};
  world.add_table({2, 0}, 0, {1.6, 0.8, 0.75}, 0.03, 0.05);
  // Straight down onto the middle of the top: hits the top at 0.75 m.
  Hit h = world.cast({{2, 0, 2}, {0, 0, -1}}, {}, 0);
  EXPECT_EQ(h.label, PointClass::furniture);
  EXPECT_NEAR(h.point_m.z, 0.75, kTol);
  // A level beam at 0.3 m under the top, between the legs: passes through to the far wall.
  h = world.cast({{0, 0, 0.3}, {1, 0, 0}}, {}, 0);
  EXPECT_EQ(h.label, PointClass::wall);
  EXPECT_NEAR(h.range_m, 5.0, kTol);
  // The same beam at y = 0.36 meets a leg (legs centred 0.025 + 0.02 inside the corners).
  h = world.cast({{0, 0.36, 0.3}, {1, 0, 0}}, {}, 0);
  EXPECT_EQ(h.label, PointClass::furniture);
  EXPECT_NEAR(h.range_m, 2.0 - 0.8 + 0.02, kTol);
}

TEST(RobotBodyModel, FootprintAndHeightOfAPioneer3AT) {
  const RobotBody body = make_pioneer3at_body(Pose3::from_xyz_rpy(0.125, 0, 0.462, 0, deg_to_rad(15), 0));
  EXPECT_NEAR(body.bound_min_m.x, -0.313, 1e-12);
  EXPECT_NEAR(body.bound_max_m.y - body.bound_min_m.y, 0.505, 1e-12);
  EXPECT_NEAR(body.bound_min_m.z, 0.0, 1e-12);
  // The housing rises above the top plate (277 mm).
  EXPECT_GT(body.height_m, 0.277 + 0.1);
  EXPECT_LT(body.height_m, 0.277 + 0.3);
}

TEST(RobotBodyModel, BeamHitsAnotherRobotsSideAtTheExpectedDistance) {
  // Robot 2 at (3, 0) facing +y: its right side (robot −y) faces... its body's x axis is map +y, so
  // its side (wheel outer face at 0.2525 m from its centre) faces the map −x direction.
  const World world{Room{{10, 8, 3}}};
  const RobotBody body = make_pioneer3at_body(Pose3::from_xyz_rpy(0.125, 0, 0.462, 0, 0, 0));
  const PlacedRobot robots[] = {{1, {0, 0, 0}, &body}, {2, {3, 0, kPi / 2}, &body}};
  // A level beam at 0.15 m (wheel height) from robot 1 along +x: hits robot 2's wheel outer face at
  // x = 3 − 0.2525 only where a wheel is: wheels span robot-x ±(0.134 ± 0.1075), i.e. map y.
  Hit h = world.cast({{0, 0.134, 0.15}, {1, 0, 0}}, robots, 1);
  EXPECT_EQ(h.label, PointClass::robot);
  EXPECT_EQ(h.hit_robot, 2);
  EXPECT_NEAR(h.range_m, 3.0 - 0.2525, 1e-9);
  // Between the wheels at the same height: the chassis side, 0.1425 m from the centre.
  h = world.cast({{0, 0.0, 0.15}, {1, 0, 0}}, robots, 1);
  EXPECT_EQ(h.label, PointClass::robot);
  EXPECT_NEAR(h.range_m, 3.0 - 0.1425, 1e-9);
  // Over the robot (z = 1.0): the far wall at x = 5.
  h = world.cast({{0, 0.0, 1.0}, {1, 0, 0}}, robots, 1);
  EXPECT_EQ(h.label, PointClass::wall);
  EXPECT_NEAR(h.range_m, 5.0, 1e-9);
}

TEST(RobotBodyModel, OwnRaysPassThroughOwnBody) {
  const World world{Room{{10, 8, 3}}};
  const RobotBody body = make_pioneer3at_body(Pose3::from_xyz_rpy(0.125, 0, 0.462, 0, 0, 0));
  const PlacedRobot robots[] = {{1, {0, 0, 0}, &body}};
  // From inside robot 1's housing straight down: through its own body to the floor.
  const Hit h = world.cast({{0.125, 0, 0.462}, {0, 0, -1}}, robots, 1);
  EXPECT_EQ(h.label, PointClass::floor);
  EXPECT_NEAR(h.range_m, 0.462, kTol);
  // The same ray cast by another robot's id sees robot 1's body.
  const Hit h2 = world.cast({{0.125, 0, 2.0}, {0, 0, -1}}, robots, 2);
  EXPECT_EQ(h2.label, PointClass::robot);
  EXPECT_EQ(h2.hit_robot, 1);
}

}  // namespace
}  // namespace teamscan::sim
