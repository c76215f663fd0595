// Tracks: arc length, closure, heading along the tangent, start offset, pauses and the finish time.
#include <gtest/gtest.h>

#include <cmath>

#include "sim/track.hpp"

namespace teamscan::sim {
namespace {

TEST(Track, CircleHasTheRightLengthAndTangentHeading) {
  const Track t = Track::oval({1, 2}, 2.0, 2.0, 0, true);
  EXPECT_NEAR(t.length_m(), 2 * kPi * 2.0, 1e-3);
  const Pose2 p0 = t.pose_at(0);
  EXPECT_NEAR(p0.x_m, 3.0, 1e-9);
  EXPECT_NEAR(p0.y_m, 2.0, 1e-9);
  EXPECT_NEAR(p0.theta_rad, kPi / 2, 1e-9);  // counter-clockwise: heading +y at the rightmost point
  const Pose2 q = t.pose_at(t.length_m() / 4);
  EXPECT_NEAR(q.x_m, 1.0, 1e-3);
  EXPECT_NEAR(q.y_m, 4.0, 1e-3);
  EXPECT_NEAR(std::abs(q.theta_rad), kPi, 1e-3);
  const Pose2 wrapped = t.pose_at(t.length_m() * 2 + 0.5);
  const Pose2 direct = t.pose_at(0.5);
  EXPECT_NEAR(wrapped.x_m, direct.x_m, 1e-6);
  EXPECT_NEAR(wrapped.y_m, direct.y_m, 1e-6);
}

TEST(Track, ClockwiseOvalRunsTheOtherWay) {
  const Track t = Track::oval({0, 0}, 3.0, 1.6, 0, false);
  EXPECT_NEAR(t.pose_at(0).theta_rad, -kPi / 2, 1e-9);
  EXPECT_LT(t.pose_at(0.5).y_m, 0.0);
}

TEST(Track, ArcLengthIsUniform) {
  // Equal steps of s are equal chord lengths along an ellipse (to the table's resolution).
  const Track t = Track::oval({0, 0}, 3.0, 1.6, 0, true);
  const double step = 0.05;
  for (double s = 0; s < t.length_m() - step; s += 0.7) {
    const Pose2 a = t.pose_at(s), b = t.pose_at(s + step);
    EXPECT_NEAR(std::hypot(b.x_m - a.x_m, b.y_m - a.y_m), step, 2e-4) << "at s = " << s;
  }
}

TEST(Track, FigureEightCrossesItselfAtTheCentre) {
  const Track t = Track::figure8({0, 0}, 3.2, 4.0, 0, true);
  const Pose2 start = t.pose_at(0), half = t.pose_at(t.length_m() / 2);
  EXPECT_NEAR(start.x_m, 0, 1e-9);
  EXPECT_NEAR(half.x_m, 0, 1e-6);
  EXPECT_NEAR(half.y_m, 0, 1e-6);
  // Crossing: the two headings at the centre differ (the lobes cross at an angle).
  EXPECT_GT(std::abs(normalize_angle(start.theta_rad - half.theta_rad)), 0.5);
  const Pose2 tip = t.pose_at(t.length_m() / 4);
  EXPECT_NEAR(tip.x_m, 3.2, 1e-3);
}

TEST(Track, WaypointsPassThroughTheirPoints) {
  const Track t = Track::waypoints({{0, 0}, {2, 0}, {2, 2}, {0, 2}}, true);
  EXPECT_NEAR(t.pose_at(0).x_m, 0, 1e-9);
  bool near_corner = false;
  for (double s = 0; s < t.length_m(); s += 0.001) {
    const Pose2 p = t.pose_at(s);
    if (std::hypot(p.x_m - 2, p.y_m - 2) < 2e-3) near_corner = true;
  }
  EXPECT_TRUE(near_corner);
  const Track open = Track::waypoints({{0, 0}, {1, 0}}, false);
  EXPECT_NEAR(open.length_m(), 1.0, 1e-6);
  EXPECT_NEAR(open.pose_at(5.0).x_m, 1.0, 1e-9);  // clamps at the end
}

TEST(Motion, StartOffsetSpeedPausesAndFinish) {
  const Track t = Track::oval({0, 0}, 2.0, 2.0, 0, true);
  const double len = t.length_m();
  Motion m{t, 0.5, len / 2, len, 1.0, {{3.0, 2.0}}};
  EXPECT_DOUBLE_EQ(m.distance_at(0.5), 0.0);   // not started
  EXPECT_NEAR(m.distance_at(3.0), 1.0, 1e-12);  // 2 s driving
  EXPECT_NEAR(m.distance_at(5.0), 1.0, 1e-12);  // paused 3..5 s
  EXPECT_NEAR(m.distance_at(6.0), 1.5, 1e-12);
  EXPECT_FALSE(m.moving_at(4.0));
  EXPECT_TRUE(m.moving_at(5.5));
  EXPECT_NEAR(m.finish_s(), 1.0 + len / 0.5 + 2.0, 1e-9);
  EXPECT_NEAR(m.distance_at(m.finish_s() + 10), len, 1e-9);
  const Pose2 start = m.pose_at(0);
  EXPECT_NEAR(start.x_m, -2.0, 1e-6);  // half a circle ahead of the track's start
  // Yaw rate on a circle of radius 2 m at 0.5 m/s: 0.25 rad/s.
  EXPECT_NEAR(m.yaw_rate_at(2.0), 0.25, 1e-3);
  EXPECT_NEAR(m.yaw_rate_at(4.0), 0.0, 1e-9);
}

TEST(Motion, SpeedRampsAtStartsAndStops) {
  // 0.3 m/s with 0.3 m/s²: 1 s ramps, 0.15 m driven on each ramp.
  const Track t = Track::oval({0, 0}, 2.0, 2.0, 0, true);
  const double len = t.length_m();
  const Motion m{t, 0.3, 0.0, len, 0.0, {{20.0, 5.0}}, 0.3};
  EXPECT_NEAR(m.speed_at(0.5), 0.15, 1e-12);
  EXPECT_NEAR(m.distance_at(1.0), 0.15, 1e-12);
  EXPECT_NEAR(m.speed_at(10.0), 0.3, 1e-12);
  EXPECT_NEAR(m.speed_at(19.5), 0.15, 1e-12);  // braking for the pause at 20 s
  EXPECT_EQ(m.speed_at(22.0), 0.0);
  EXPECT_NEAR(m.distance_at(22.0), 0.3 * (20.0 - 1.0), 1e-9);
  // The whole distance is driven: after the pause, len − 5.7 m remain, plus a 1 s ramp.
  EXPECT_NEAR(m.finish_s(), 25.0 + (len - 5.7) / 0.3 + 1.0, 1e-9);
  EXPECT_NEAR(m.distance_at(m.finish_s()), len, 1e-9);
  EXPECT_NEAR(m.distance_at(m.finish_s() + 100.0), len, 1e-9);
  // Speed never jumps: between samples 1 ms apart it changes by at most a·dt.
  double previous = m.speed_at(0.0);
  for (double time = 0.001; time < m.finish_s() + 1.0; time += 0.001) {
    const double v = m.speed_at(time);
    EXPECT_LE(std::abs(v - previous), 0.3 * 0.001 + 1e-9) << "at t = " << time;
    previous = v;
  }
}

TEST(Motion, ShortDriveBetweenPausesIsATriangle) {
  // 1 s of driving before a pause at 1 s: peak a·0.5 = 0.15 m/s, distance a·L²/4 = 0.075 m.
  const Track t = Track::oval({0, 0}, 2.0, 2.0, 0, true);
  const Motion m{t, 0.3, 0.0, t.length_m(), 0.0, {{1.0, 2.0}}, 0.3};
  EXPECT_NEAR(m.speed_at(0.5), 0.15, 1e-12);
  EXPECT_NEAR(m.distance_at(1.0), 0.075, 1e-12);
  EXPECT_NEAR(m.distance_at(2.5), 0.075, 1e-12);
}

}  // namespace
}  // namespace teamscan::sim
