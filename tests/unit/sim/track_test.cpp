// Tracks: arc length, closure, heading along the tangent, start offset, pauses and the finish time.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <vector>

#include "common/units.hpp"
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

// corridor2's closed loop: 3.8 m straights joined by end turns through three points 0.3–0.5 m apart.
std::vector<Vec2> corridor_loop() {
  return {{-3.8, -0.4}, {0.0, -0.4}, {3.8, -0.4}, {4.1, 0.0}, {3.8, 0.4}, {0.0, 0.4}, {-3.8, 0.4}, {-4.1, 0.0}};
}

// The largest heading change per metre along the track, and how far the heading turns clockwise in
// all (the loop itself turns counter-clockwise: clockwise turns are the spline swinging back).
struct Bends {
  double max_curvature_per_m = 0;
  double clockwise_rad = 0;
};
Bends bends(const Track& t) {
  Bends b;
  constexpr double kDs = 0.005;
  for (double s = 0; s + kDs < t.length_m(); s += kDs) {
    const double turn = normalize_angle(t.pose_at(s + kDs).theta_rad - t.pose_at(s).theta_rad);
    b.max_curvature_per_m = std::max(b.max_curvature_per_m, std::abs(turn) / kDs);
    if (turn < 0) b.clockwise_rad -= turn;
  }
  return b;
}

TEST(Track, ACentripetalSplineTurnsATightEndWithoutLooping) {
  const Track uniform = Track::waypoints(corridor_loop(), true);
  const Track centripetal = Track::waypoints(corridor_loop(), true, Track::Spline::centripetal);
  // The uniform spline overshoots into the end turns and loops there: its heading swings back by
  // more than 2 rad in all, at over 10 rad/m.
  const Bends u = bends(uniform), c = bends(centripetal);
  EXPECT_GT(u.clockwise_rad, 2.0);
  EXPECT_GT(u.max_curvature_per_m, 10.0);
  // The centripetal one only bows its straights a little, turns no tighter than a 0.25 m radius, and
  // passes through every waypoint.
  EXPECT_LT(c.clockwise_rad, 0.3);
  EXPECT_LT(c.max_curvature_per_m, 4.0);
  for (const Vec2 w : corridor_loop()) {
    double nearest = 1e9;
    for (double s = 0; s < centripetal.length_m(); s += 0.001) {
      const Pose2 p = centripetal.pose_at(s);
      nearest = std::min(nearest, std::hypot(p.x_m - w.x, p.y_m - w.y));
    }
    EXPECT_LT(nearest, 2e-3) << w.x << ", " << w.y;
  }
  // Evenly spaced points give the same curve either way.
  const std::vector<Vec2> square{{0, 0}, {2, 0}, {2, 2}, {0, 2}};
  const Track a = Track::waypoints(square, true), b = Track::waypoints(square, true, Track::Spline::centripetal);
  for (double s = 0; s < a.length_m(); s += 0.1) {
    EXPECT_NEAR(a.pose_at(s).x_m, b.pose_at(s).x_m, 1e-9);
    EXPECT_NEAR(a.pose_at(s).y_m, b.pose_at(s).y_m, 1e-9);
  }
}

TEST(Motion, AMotionWithinTheTurnRateLimitIsUntouched) {
  const Track t = Track::oval({0, 0}, 2.0, 1.2, 0, true);
  const Motion free{t, 0.4, 0.0, 2 * t.length_m(), 1.0, {{10.0, 3.0}}, 0.3};
  const Motion limited{t, 0.4, 0.0, 2 * t.length_m(), 1.0, {{10.0, 3.0}}, 0.3, deg_to_rad(140.0)};
  EXPECT_EQ(limited.finish_s(), free.finish_s());
  for (double time = 0; time < free.finish_s() + 1.0; time += 0.0137) {
    EXPECT_EQ(limited.distance_at(time), free.distance_at(time)) << time;
    EXPECT_EQ(limited.speed_at(time), free.speed_at(time)) << time;
  }
}

TEST(Motion, ATurnTooTightForTheLimitIsDrivenMoreSlowlyThroughTheSamePoses) {
  const Track t = Track::waypoints(corridor_loop(), true);
  const double limit = deg_to_rad(140.0);
  const Motion free{t, 0.35, 0.0, 2 * t.length_m(), 0.0, {{30.0, 2.0}}, 0.3};
  const Motion limited{t, 0.35, 0.0, 2 * t.length_m(), 0.0, {{30.0, 2.0}}, 0.3, limit};
  double free_max = 0, limited_max = 0, previous = 0;
  for (double time = 0; time < limited.finish_s() + 1.0; time += 0.002) {
    free_max = std::max(free_max, std::abs(free.yaw_rate_at(time)));
    limited_max = std::max(limited_max, std::abs(limited.yaw_rate_at(time)));
    // Never ahead of the unlimited robot and never backwards: the same poses, reached later.
    const double d = limited.distance_at(time);
    EXPECT_LE(d, free.distance_at(time) + 1e-12) << time;
    EXPECT_GE(d, previous) << time;
    previous = d;
  }
  EXPECT_GT(free_max, 2.0 * limit);
  EXPECT_LT(limited_max, limit * 1.01);
  EXPECT_GT(limited.finish_s(), free.finish_s() + 0.5);
  EXPECT_NEAR(limited.distance_at(limited.finish_s()), 2 * t.length_m(), 1e-9);
  // On the straights it drives at its speed; the pause comes later by the time lost before it.
  EXPECT_NEAR(limited.speed_at(5.0), 0.35, 1e-9);
  double pause_starts = 0;
  for (double time = 25.0; time < 40.0 && pause_starts == 0; time += 0.001) {
    if (!limited.moving_at(time)) pause_starts = time;
  }
  EXPECT_GT(pause_starts, 30.0);
  EXPECT_LT(pause_starts, 30.0 + (limited.finish_s() - free.finish_s()));
}

}  // namespace
}  // namespace teamscan::sim
