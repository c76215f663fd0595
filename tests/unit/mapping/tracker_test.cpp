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

TEST(Tracker, UncertaintyGrowsWithPredictionTimeAndTrackGoesInvalid) {
  TrackerOptions o;
  o.lost_after_s = 1.0;
  TeamTracker tracker(o);
  for (int i = 0; i < 10; ++i) tracker.add_pose(3, i * kPosePeriodNs, {0.1 * i, 0.0, 0.0}, 1.0);
  const std::int64_t last = 9 * kPosePeriodNs;
  const RobotEstimate near = tracker.predict(last + 10'000'000).robots.at(0);
  const RobotEstimate far = tracker.predict(last + 900'000'000).robots.at(0);
  const RobotEstimate lost = tracker.predict(last + 1'500'000'000).robots.at(0);
  EXPECT_LT(near.position_cov_m2(0, 0), far.position_cov_m2(0, 0));
  EXPECT_TRUE(far.valid);
  EXPECT_FALSE(lost.valid);
  EXPECT_NEAR(far.position_m.x, 0.9 + 0.9, 0.02);  // 1 m/s for 0.9 s
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

}  // namespace
}  // namespace teamscan::mapping
