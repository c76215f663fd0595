// Constant-velocity Kalman tracker: convergence on known trajectories, prediction, covariance.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include <Eigen/Dense>

#include "groundstation/mapping/tracker.hpp"

namespace teamscan::mapping {
namespace {

constexpr std::int64_t kPosePeriodNs = 100'000'000;  // SIP rate 10 Hz

TEST(Tracker, ConvergesOnAStraightLineWithNoisyPositionsAndPredictsAhead) {
  TrackerOptions o;
  o.use_velocity = false;  // velocity must come from the positions alone
  o.position_noise_m = 0.02;
  o.accel_noise_mps2 = 0.05;  // the trajectory has no acceleration: a tuned model averages more
  TeamTracker tracker(o);
  std::mt19937_64 rng(42);
  std::normal_distribution<double> noise(0.0, 0.02);
  const double vx = 0.4, vy = -0.3;  // m/s
  for (int i = 0; i <= 100; ++i) {
    const double t = i * 0.1;
    tracker.add_pose(2, i * kPosePeriodNs, {1.0 + vx * t + noise(rng), 2.0 + vy * t + noise(rng), 0.0}, 0.0);
  }
  // 50 ms after the last pose (t = 10.05 s).
  const TeamState team = tracker.predict(100 * kPosePeriodNs + 50'000'000);
  const RobotEstimate* e = team.find(2);
  ASSERT_NE(e, nullptr);
  EXPECT_TRUE(e->valid);
  EXPECT_NEAR(e->position_m.x, 1.0 + vx * 10.05, 0.03);  // within ~1.5 σ of a single measurement
  EXPECT_NEAR(e->position_m.y, 2.0 + vy * 10.05, 0.03);
  EXPECT_NEAR(e->velocity_mps.x, vx, 0.05);
  EXPECT_NEAR(e->velocity_mps.y, vy, 0.05);
  // The filter averages: its position σ is below the measurement σ.
  EXPECT_LT(std::sqrt(e->position_cov_m2(0, 0)), 0.02);
}

TEST(Tracker, FollowsACircleUsingOdometrySpeedAndHeading) {
  TeamTracker tracker;  // defaults: velocity measured from (v, θ)
  const double radius = 2.0, omega = 0.25, v = radius * omega;
  double worst = 0.0;
  for (int i = 0; i <= 400; ++i) {
    const double t = i * 0.1, a = omega * t;
    tracker.add_pose(1, i * kPosePeriodNs, {radius * std::cos(a), radius * std::sin(a), a + kPi / 2}, v);
    if (i < 20) continue;
    // Halfway to the next pose, where a scan typically falls.
    const double tm = t + 0.05, am = omega * tm;
    const RobotEstimate e = tracker.predict(i * kPosePeriodNs + 50'000'000).robots.at(0);
    worst = std::max(worst, std::hypot(e.position_m.x - radius * std::cos(am), e.position_m.y - radius * std::sin(am)));
  }
  EXPECT_LT(worst, 0.01);  // 1 cm: far below the filters' 0.35 m robot size
}

TEST(Tracker, UncertaintyGrowsWithPredictionTimeAndASilentRobotStopsWhereItCoasted) {
  TrackerOptions o;
  o.lost_after_s = 1.0;
  o.coast_s = 2.0;
  TeamTracker tracker(o);
  for (int i = 0; i < 10; ++i) tracker.add_pose(3, i * kPosePeriodNs, {0.1 * i, 0.0, 0.0}, 1.0);
  const std::int64_t last = 9 * kPosePeriodNs;
  const RobotEstimate near = tracker.predict(last + 10'000'000).robots.at(0);
  const RobotEstimate far = tracker.predict(last + 900'000'000).robots.at(0);
  const RobotEstimate lost = tracker.predict(last + 1'500'000'000).robots.at(0);
  const RobotEstimate stopped = tracker.predict(last + 2'500'000'000).robots.at(0);
  const RobotEstimate much_later = tracker.predict(last + 60'000'000'000).robots.at(0);
  EXPECT_LT(near.position_cov_m2(0, 0), far.position_cov_m2(0, 0));
  EXPECT_TRUE(far.valid);
  EXPECT_FALSE(far.lost);
  // Silent for more than lost_after_s: lost for teamscan/team, still tracked for the filters.
  EXPECT_TRUE(lost.lost);
  EXPECT_TRUE(lost.valid);
  EXPECT_NEAR(far.position_m.x, 0.9 + 0.9, 0.02);  // 1 m/s for 0.9 s
  // Past coast_s (the firmware watchdog) the robot has stopped: held where it coasted to, speed 0,
  // with the uncertainty it reached (no further growth: it no longer moves).
  EXPECT_NEAR(stopped.position_m.x, 0.9 + 2.0, 0.02);
  EXPECT_NEAR(much_later.position_m.x, 0.9 + 2.0, 0.02);
  EXPECT_EQ(much_later.velocity_mps.x, 0.0);
  EXPECT_TRUE(much_later.valid);
  EXPECT_GT(stopped.position_cov_m2(0, 0), far.position_cov_m2(0, 0));
  EXPECT_DOUBLE_EQ(much_later.position_cov_m2(0, 0), stopped.position_cov_m2(0, 0));
  // Before its first pose a robot is not predicted backwards beyond lost_after_s.
  EXPECT_FALSE(tracker.predict(-2'000'000'000).robots.at(0).valid);
}

TEST(Tracker, ASilentRobotCoastsOnItsLastCommandsArcAndGainsNoProcessNoiseOnceItsPoseIsOverdue) {
  // A Pioneer turning at 0.35 rad/s (lap2's oval ends) goes silent: its firmware executes the last
  // command (speed and yaw rate) until the watchdog stops it coast_s later (PROTOCOLS.md §1.6).
  TrackerOptions o;
  o.coast_s = 2.0;
  TeamTracker tracker(o);
  const double v = 0.3, w = 0.35, r = v / w;
  auto on_circle = [&](double t) { return Vec2{r * std::sin(w * t), r - r * std::cos(w * t)}; };
  for (int i = 0; i <= 50; ++i) {
    const double t = 0.1 * i;
    tracker.add_pose(2, i * kPosePeriodNs, {on_circle(t).x, on_circle(t).y, w * t}, v);
  }
  EXPECT_NEAR(tracker.track(2)->yaw_rate_radps(), w, 1e-9);
  EXPECT_NEAR(tracker.track(2)->command_horizon_s(), 2 * 0.1, 1e-9);  // the next pose due, plus one interval
  {
    // With a decision lag, a robot that reports on time is predicted lag + one interval ahead.
    TrackerOptions lagged = o;
    lagged.team_lag_s = 0.15;
    TeamTracker t(lagged);
    for (int i = 0; i <= 2; ++i) t.add_pose(2, i * kPosePeriodNs, {0.1 * i, 0.0, 0.0}, 1.0);
    EXPECT_NEAR(t.track(2)->command_horizon_s(), 0.15 + 2 * 0.1, 1e-9);
  }
  const std::int64_t last = 50 * kPosePeriodNs;
  // Within the horizon: the constant-velocity Kalman prediction, unchanged (the normal case).
  const RobotEstimate soon = tracker.predict(last + 50'000'000).robots.at(0);
  EXPECT_DOUBLE_EQ(soon.heading_rad, w * 5.0);
  // Stopped: on the arc (a straight coast would be v·ω·t²/2 = 0.21 m off), turned with it, and held.
  const RobotEstimate stopped = tracker.predict(last + 2'000'000'000).robots.at(0);
  const RobotEstimate later = tracker.predict(last + 30'000'000'000).robots.at(0);
  const Vec2 truth = on_circle(5.0 + 2.0);
  EXPECT_LT(std::hypot(stopped.position_m.x - truth.x, stopped.position_m.y - truth.y), 0.05);
  EXPECT_NEAR(stopped.heading_rad, w * 5.0 + w * (2.0 - 0.2), 1e-9);
  EXPECT_DOUBLE_EQ(later.position_m.x, stopped.position_m.x);
  EXPECT_DOUBLE_EQ(later.heading_rad, stopped.heading_rad);
  // The process noise (a live client changing its commands) stops at the horizon: the position σ at
  // the stop is below what the white acceleration noise alone adds over the whole coast (σ_a·√(t³/3),
  // 0.82 m: a 3σ box 5 m wide around a robot that can move 1.4 m in 2 s at a P3-AT's top speed).
  const double q_only_sigma_m = o.accel_noise_mps2 * std::sqrt(o.coast_s * o.coast_s * o.coast_s / 3.0);
  EXPECT_LT(std::sqrt(stopped.position_cov_m2(0, 0)), q_only_sigma_m);
  EXPECT_LT(std::sqrt(stopped.position_cov_m2(1, 1)), q_only_sigma_m);
  // ... but the velocity uncertainty it had still spreads the position while it coasts.
  const RobotEstimate at_horizon = tracker.predict(last + 200'000'000).robots.at(0);
  EXPECT_GT(stopped.position_cov_m2(0, 0), 4.0 * at_horizon.position_cov_m2(0, 0));
}

TEST(Tracker, RejectsBadIdsAndNonFinitePoses) {
  TeamTracker tracker;
  tracker.add_pose(0, 0, {0, 0, 0}, 0);
  tracker.add_pose(33, 0, {0, 0, 0}, 0);
  tracker.add_pose(1, 0, {NAN, 0, 0}, 0);
  EXPECT_EQ(tracker.rejected_poses(), 3u);
  EXPECT_TRUE(tracker.predict(0).robots.empty());
}

TEST(Tracker, CovarianceStaysSymmetricPositiveDefinite) {
  TeamTracker tracker;
  for (int i = 0; i < 200; ++i) tracker.add_pose(4, i * kPosePeriodNs, {std::sin(i * 0.1), std::cos(i * 0.1), i * 0.1}, 0.1);
  const RobotTrack* t = tracker.track(4);
  ASSERT_NE(t, nullptr);
  const auto& p = t->covariance();
  EXPECT_NEAR((p - p.transpose()).norm(), 0.0, 1e-12);
  EXPECT_GT(p.determinant(), 0.0);
}

// ---- odometry drift (docs/beyond.md "Drift") ----------------------------------------------

namespace drift {
constexpr double kPi = 3.14159265358979323846;
}

TEST(TrackerDrift, PositionSigmaGrowsWithTheDistanceDrivenAndIsAddedToTheKalmanCovariance) {
  TrackerOptions with;
  with.drift_m_per_m = 0.01;
  TrackerOptions without = with;
  without.drift_m_per_m = 0.0;
  TeamTracker a(with), b(without);
  // 0.5 m/s along x for 10 s: 100 steps of 5 cm = 5 m driven (distance from the reported speed).
  for (int i = 0; i <= 100; ++i) {
    a.add_pose(3, i * kPosePeriodNs, {0.05 * i, 0.0, 0.0}, 0.5);
    b.add_pose(3, i * kPosePeriodNs, {0.05 * i, 0.0, 0.0}, 0.5);
  }
  const RobotEstimate ea = *a.predict(100 * kPosePeriodNs).find(3), eb = *b.predict(100 * kPosePeriodNs).find(3);
  EXPECT_NEAR(ea.distance_m, 5.0, 1e-9);
  EXPECT_NEAR(ea.drift_cov_m2(0, 0), 0.05 * 0.05, 1e-12);
  EXPECT_NEAR(ea.drift_cov_m2(1, 1), 0.05 * 0.05, 1e-12);
  EXPECT_EQ(ea.drift_cov_m2(0, 1), 0.0);
  EXPECT_TRUE(((ea.position_cov_m2 - ea.drift_cov_m2) - eb.position_cov_m2).cwiseAbs().maxCoeff() < 1e-15);
  EXPECT_EQ(eb.drift_cov_m2, Eigen::Matrix2d::Zero());
  EXPECT_EQ(ea.heading_sigma_rad, 0.0);
  // Same estimate otherwise: drift is uncertainty, not a correction.
  EXPECT_EQ(ea.position_m.x, eb.position_m.x);
}

// A registration (scan-to-map match) is a measurement of the position with its σ: the drift restarts
// from it (its σ the base) and grows again from where the robot was registered.
TEST(TrackerDrift, ARegistrationReplacesTheAccumulatedDriftWithItsSigma) {
  TrackerOptions o;
  o.drift_m_per_m = 0.01;
  o.drift_heading_rad_per_m = 0.002;
  TeamTracker t(o);
  for (int i = 0; i <= 100; ++i) t.add_pose(3, i * kPosePeriodNs, {0.05 * i, 0.0, 0.0}, 0.5);  // 5 m
  const RobotEstimate before = *t.predict(100 * kPosePeriodNs).find(3);
  EXPECT_GT(std::sqrt(before.drift_cov_m2(0, 0)), 0.05);
  t.registered(3, 0.01, 0.002);
  t.registered(4, 0.01, 0.002);  // no track: ignored
  const RobotEstimate at = *t.predict(100 * kPosePeriodNs).find(3);
  EXPECT_NEAR(at.drift_cov_m2(0, 0), 0.01 * 0.01, 1e-12);
  EXPECT_NEAR(at.heading_sigma_rad, 0.002, 1e-12);
  EXPECT_LT(at.position_cov_m2(0, 0), before.position_cov_m2(0, 0));
  EXPECT_EQ(at.position_m.x, before.position_m.x);  // uncertainty, not a move: corrected poses move it
  // 1 m further: 0.01 m of slip, and the heading σ (0.002 + 0.002) times 1 m from the registration.
  for (int i = 101; i <= 120; ++i) t.add_pose(3, i * kPosePeriodNs, {0.05 * i, 0.0, 0.0}, 0.5);
  const RobotEstimate later = *t.predict(120 * kPosePeriodNs).find(3);
  EXPECT_NEAR(std::sqrt(later.drift_cov_m2(0, 0)), 0.01 + 0.01 + 0.004 * 1.0, 1e-3);
  EXPECT_LT(later.drift_cov_m2(0, 0), before.drift_cov_m2(0, 0));
}

TEST(TrackerDrift, TurningGrowsTheHeadingSigmaWhoseLeverIsTheDistanceFromTheStart) {
  TrackerOptions o;
  o.drift_m_per_m = 0.0;
  o.drift_heading_rad_per_rad = 0.1;
  TeamTracker t(o);
  // Turn on the spot by 90° in 10 steps (speed 0): σ_θ = 0.1 · π/2, position σ 0 (still at the start).
  for (int i = 0; i <= 10; ++i) t.add_pose(1, i * kPosePeriodNs, {0.0, 0.0, drift::kPi / 2 * i / 10.0}, 0.0);
  RobotEstimate e = *t.predict(10 * kPosePeriodNs).find(1);
  EXPECT_NEAR(e.heading_sigma_rad, 0.1 * drift::kPi / 2, 1e-12);
  EXPECT_NEAR(e.drift_cov_m2(0, 0), 0.0, 1e-18);
  // Then 2 m straight along +y (heading 90°, no turn): the heading error turns the path about the
  // start, so the position σ is σ_θ · 2 m.
  for (int i = 1; i <= 20; ++i) t.add_pose(1, (10 + i) * kPosePeriodNs, {0.0, 0.1 * i, drift::kPi / 2}, 1.0);
  e = *t.predict(30 * kPosePeriodNs).find(1);
  EXPECT_NEAR(e.heading_sigma_rad, 0.1 * drift::kPi / 2, 1e-12);
  EXPECT_NEAR(std::sqrt(e.drift_cov_m2(0, 0)), 0.1 * drift::kPi / 2 * 2.0, 1e-9);
}

TEST(TrackerDrift, AHeadingWrapCountsTheShortTurn) {
  TrackerOptions o;
  o.drift_heading_rad_per_rad = 1.0;
  TeamTracker t(o);
  t.add_pose(1, 0, {0.0, 0.0, 3.1}, 0.0);
  t.add_pose(1, kPosePeriodNs, {0.0, 0.0, -3.1}, 0.0);  // 0.083 rad across ±π, not 6.2 rad
  EXPECT_NEAR(t.predict(kPosePeriodNs).find(1)->heading_sigma_rad, 2 * drift::kPi - 6.2, 1e-9);
}

}  // namespace
}  // namespace teamscan::mapping
