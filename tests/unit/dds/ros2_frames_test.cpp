// The REP-105 frame tree (dds/ros2/frames.hpp) and ROS 2 samples as bytes outside DDS (dds/ros2/cdr.hpp):
// the team's transforms form a tree rooted at `map` with one parent per frame, and map -> odom -> base_link
// composes to the tracked pose whatever the correction; frame_tree_fault finds each kind of fault; the
// ros2msg definitions name every nested type once (cdr_bytes: ros2_cdr_test.cpp).
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <string>
#include <vector>

#include "dds/ros2/cdr.hpp"
#include "dds/ros2/frames.hpp"
#include "dds/ros2/wire.hpp"

namespace teamscan::dds::ros2 {
namespace {

std::vector<FrameTransform> team_tree() {
  std::vector<RobotFrames> robots = {
      {1, 1000, 1.5, -2.0, 0.3, 0.0, 0.0, 0.0},        // no correction yet
      {2, 1000, -3.25, 0.5, 3.0, 0.4, -0.2, 0.05},     // a correction
      {7, 1000, 10.0, 20.0, -2.5, -1.0, 2.0, -3.1}};  // a large one, yaw across the +-pi seam
  std::vector<FrameTransform> t;
  append_dynamic_transforms(robots, t);
  for (std::uint32_t id : {1u, 2u, 7u}) t.push_back(laser_transform(id, {0.1, 0.0, 0.6, 0.0, -0.35, 0.0}, 1000));
  return t;
}

TEST(Ros2Frames, TheTeamIsATreeRootedAtMap) {
  const std::vector<FrameTransform> t = team_tree();
  ASSERT_EQ(t.size(), 9u);
  EXPECT_EQ(frame_tree_fault(t), "");
  EXPECT_EQ(t[0].parent, "map");
  EXPECT_EQ(t[0].child, "robot1/odom");
  EXPECT_EQ(t[1].parent, "robot1/odom");
  EXPECT_EQ(t[1].child, "robot1/base_link");
  EXPECT_EQ(t[6].parent, "robot1/base_link");
  EXPECT_EQ(t[6].child, "robot1/laser");
}

TEST(Ros2Frames, OdomThenBaseLinkComposesToTheTrackedPose) {
  for (const RobotFrames& r : {RobotFrames{2, 0, -3.25, 0.5, 3.0, 0.4, -0.2, 0.05},
                               RobotFrames{7, 0, 10.0, 20.0, -2.5, -1.0, 2.0, -3.1}}) {
    std::vector<FrameTransform> t;
    append_dynamic_transforms(std::span<const RobotFrames>(&r, 1), t);
    ASSERT_EQ(t.size(), 2u);
    const double a = 2.0 * std::atan2(t[0].rotation.z, t[0].rotation.w);
    const double b = 2.0 * std::atan2(t[1].rotation.z, t[1].rotation.w);
    const double x = t[0].x_m + std::cos(a) * t[1].x_m - std::sin(a) * t[1].y_m;
    const double y = t[0].y_m + std::sin(a) * t[1].x_m + std::cos(a) * t[1].y_m;
    EXPECT_NEAR(x, r.x_m, 1e-9);
    EXPECT_NEAR(y, r.y_m, 1e-9);
    EXPECT_NEAR(std::remainder(a + b - r.yaw_rad, 2 * std::numbers::pi), 0.0, 1e-9);
    EXPECT_NEAR(t[0].x_m, r.map_from_odom_x_m, 1e-12);  // map -> odom is the correction itself
    EXPECT_NEAR(a, r.map_from_odom_yaw_rad, 1e-12);
  }
}

TEST(Ros2Frames, EachFaultIsNamed) {
  std::vector<FrameTransform> t = team_tree();
  t.push_back({"map", "robot1/base_link", 0, 0, 0, 0, {}});  // a second parent (map -> base_link as well)
  EXPECT_NE(frame_tree_fault(t).find("robot1/base_link has two parents"), std::string::npos) << frame_tree_fault(t);
  t = team_tree();
  t.push_back({"robot1/laser", "map", 0, 0, 0, 0, {}});
  EXPECT_NE(frame_tree_fault(t).find("root map has a parent"), std::string::npos);
  t = team_tree();
  t.push_back({"world", "robot9/odom", 0, 0, 0, 0, {}});
  EXPECT_NE(frame_tree_fault(t).find("robot9/odom does not reach map"), std::string::npos);
  t = team_tree();
  t.push_back({"a", "b", 0, 0, 0, 0, {}});
  t.push_back({"b", "a", 0, 0, 0, 0, {}});
  EXPECT_NE(frame_tree_fault(t).find("cycle"), std::string::npos) << frame_tree_fault(t);
  t = team_tree();
  t[3].child = "/robot2/base_link";
  EXPECT_NE(frame_tree_fault(t).find("starts with /"), std::string::npos);
  t = team_tree();
  t[0].parent = "";
  EXPECT_NE(frame_tree_fault(t).find("empty"), std::string::npos);
  t = team_tree();
  t[2].rotation = {0, 0, 0, 0.9};
  EXPECT_NE(frame_tree_fault(t).find("no unit rotation"), std::string::npos);
  t = team_tree();
  t[2].parent = t[2].child;
  EXPECT_NE(frame_tree_fault(t).find("its own parent"), std::string::npos);
  EXPECT_EQ(frame_tree_fault({}), "");  // no transforms: nothing but the root
}

TEST(Ros2Frames, LaserMountRotationIsPitchAboutY) {
  const FrameTransform t = laser_transform(3, {0.1, 0.0, 0.6, 0.0, -0.35, 0.0}, 5);
  EXPECT_EQ(t.parent, "robot3/base_link");
  EXPECT_EQ(t.child, "robot3/laser");
  EXPECT_NEAR(t.rotation.y, std::sin(-0.35 / 2), 1e-12);
  EXPECT_NEAR(t.rotation.w, std::cos(-0.35 / 2), 1e-12);
  EXPECT_NEAR(t.rotation.x, 0.0, 1e-12);
  EXPECT_NEAR(t.rotation.z, 0.0, 1e-12);
  EXPECT_DOUBLE_EQ(t.z_m, 0.6);
}

TEST(Ros2Cdr, Ros2msgDefinitionsNameEachNestedTypeOnce) {
  const std::string tf(ros2msg_definition(kTfMessageType));
  EXPECT_EQ(tf.rfind("geometry_msgs/TransformStamped[] transforms\n", 0), 0u);
  for (const char* nested : {"MSG: geometry_msgs/TransformStamped\n", "MSG: std_msgs/Header\n",
                             "MSG: builtin_interfaces/Time\n", "MSG: geometry_msgs/Transform\n",
                             "MSG: geometry_msgs/Vector3\n", "MSG: geometry_msgs/Quaternion\n"}) {
    const std::size_t at = tf.find(nested);
    ASSERT_NE(at, std::string::npos) << nested;
    EXPECT_EQ(tf.find(nested, at + 1), std::string::npos) << nested;
    EXPECT_EQ(tf.substr(at - 81, 81), std::string(80, '=') + "\n") << nested;
  }
  for (const char* type : {kPointCloud2Type, kOdometryType, kPoseStampedType})
    EXPECT_NE(std::string(ros2msg_definition(type)).find("MSG: std_msgs/Header\n"), std::string::npos) << type;
  EXPECT_NE(std::string(ros2msg_definition(kOdometryType)).find("float64[36] covariance\n"), std::string::npos);
  EXPECT_TRUE(ros2msg_definition("std_msgs/msg/String").empty());
}

}  // namespace
}  // namespace teamscan::dds::ros2
