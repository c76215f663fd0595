// Local SLAM's guesses beyond the odometry's prediction. The search (SlamOptions::local_search_score): a
// robot turning in place while its wheels slip, its odometry reporting less than half of each turn. The
// refinement alone, started from the odometry's prediction, cannot reach a scan turned degrees away and
// follows the odometry; with the search each scan is placed where the room's walls put it. The coasting
// guess (SlamOptions::coast_guess): odometry that stalls in a turn and catches up in one jump. A robot
// most of whose scans score low is searched no more (SlamOptions::local_search_max_share).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

#include "common/units.hpp"
#include "groundstation/posegraph/slam.hpp"
#include "tests/unit/posegraph/room.hpp"

namespace teamscan::posegraph {
namespace {

struct Turn {
  SlamStats stats;
  double worst_heading_deg = 0;  // local SLAM's largest heading error in the turn, against the truth (less its error before)
};

// Twelve scans driving slowly along the room with exact odometry (the first submap fills), then a
// quarter turn in place, 18° a scan, of which the odometry reports 30 %: 12.6° a scan missed.
Turn turn_in_place(const SlamOptions& options) {
  PlanarSlam slam(options);
  Turn out;
  double before = 0;
  Pose2 truth{2.0, 1.5, 0.0}, odometry = truth;
  std::int64_t stamp_ns = 0;  // 10 scans a second
  auto add = [&](const Pose2& true_motion, const Pose2& reported_motion, bool turning) {
    truth = truth * true_motion;
    odometry = odometry * reported_motion;
    const std::size_t node = slam.add_scan(1, stamp_ns += 100'000'000, odometry, test::scan(truth));
    const double error = normalize_angle(slam.local_pose(node).theta_rad - truth.theta_rad);
    if (turning) out.worst_heading_deg = std::max(out.worst_heading_deg, std::abs(error - before) * 180.0 / kPi);
    else before = error;
  };
  for (int k = 0; k < 12; ++k) add({0.02, 0.0, 0.0}, {0.02, 0.0, 0.0}, false);
  const double step = deg_to_rad(18.0);
  for (int k = 0; k < 5; ++k) add({0.0, 0.0, step}, {0.0, 0.0, 0.3 * step}, true);
  out.stats = slam.stats();
  return out;
}

TEST(SlamLocalSearch, ATurnTheOdometryMissesIsFoundByTheSearch) {
  SlamOptions with;
  with.coast_guess = false;  // the search alone
  SlamOptions without = with;
  without.local_search_score = 0.0;
  const Turn followed = turn_in_place(without);
  const Turn searched = turn_in_place(with);
  std::printf("local SLAM's worst heading error in the turn: %.2f° refined alone, %.2f° with the search (%zu searches, %zu placed)\n",
              followed.worst_heading_deg, searched.worst_heading_deg, searched.stats.local_searches, searched.stats.local_found);
  EXPECT_EQ(followed.stats.local_searches, 0u);
  EXPECT_GT(followed.worst_heading_deg, 10.0);  // the refinement stays near the odometry's prediction
  EXPECT_GT(searched.stats.local_found, 0u);
  EXPECT_LT(searched.worst_heading_deg, 1.0);
}

// A robot driving a left-hand arc, 4 cm and 8° a scan at 10 scans a second. Its odometry stalls in the
// arc: it reports the same pose for four scans while the robot turns 32°, then catches up in one jump of
// 40° (the pose it should have reported). Local SLAM's worst heading error against the truth over the
// drive, less its error before the stall.
double worst_heading_in_a_stall_deg(const SlamOptions& options, SlamStats* stats) {
  PlanarSlam slam(options);
  Pose2 truth{2.0, 1.2, 0.0}, reported = truth;
  double before = 0, worst = 0;
  const Pose2 step{0.04, 0.0, deg_to_rad(8.0)};
  for (int k = 0; k < 30; ++k) {
    truth = truth * (k < 12 ? Pose2{0.02, 0.0, 0.0} : step);  // the first submap fills on a straight line
    const bool stalled = k >= 18 && k < 22;
    if (!stalled) reported = truth;
    const std::size_t node = slam.add_scan(1, (k + 1) * 100'000'000LL, reported, test::scan(truth));
    const double error = normalize_angle(slam.local_pose(node).theta_rad - truth.theta_rad);
    if (k < 18) before = error;
    else worst = std::max(worst, std::abs(error - before) * 180.0 / kPi);
  }
  if (stats) *stats = slam.stats();
  return worst;
}

TEST(SlamCoast, OdometryThatStallsInATurnAndJumpsDoesNotTurnLocalSlam) {
  SlamOptions without;
  without.coast_guess = false;
  SlamStats stats;
  const double followed = worst_heading_in_a_stall_deg(without, nullptr);
  const double coasted = worst_heading_in_a_stall_deg(SlamOptions{}, &stats);
  std::printf("local SLAM's worst heading error through the stall: %.2f° from the odometry alone, %.2f° with the coasting guess (%zu scans placed by it)\n",
              followed, coasted, stats.coasted);
  EXPECT_GT(followed, 10.0);
  EXPECT_GT(stats.coasted, 0u);
  EXPECT_LT(coasted, 1.0);
}

// The search is a rescue from rare misses (SlamOptions::local_search_max_share). A robot all of whose
// scans score below the search's score (set at 0.999 here, as open spaces with few returns do at 0.7)
// is searched until it has local_search_share_after_scans scans, then no more; one whose scans score
// well for as long is still searched, and rescued, when its wheels slip in a turn.
TEST(SlamLocalSearch, ARobotMostOfWhoseScansScoreLowIsSearchedNoMore) {
  constexpr int kScans = 300;
  const auto drive = [](const SlamOptions& options) {
    PlanarSlam slam(options);
    for (int k = 0; k < kScans; ++k) {
      const Pose2 truth{1.0 + 0.01 * (k % 100), 1.5, 0.0};  // along the room and back, the odometry exact
      (void)slam.add_scan(1, (k + 1) * 100'000'000LL, truth, test::scan(truth));
    }
    return slam.stats();
  };
  SlamOptions low;
  low.coast_guess = false;
  low.local_search_score = 0.999;
  SlamOptions unlimited = low;
  unlimited.local_search_max_share = 1.0;
  const SlamStats limited_stats = drive(low), unlimited_stats = drive(unlimited);
  std::printf("every scan below the search's score: %zu searched and %zu not with the limit, %zu searched without it\n",
              limited_stats.local_searches, limited_stats.local_declined, unlimited_stats.local_searches);
  EXPECT_EQ(unlimited_stats.local_declined, 0u);
  EXPECT_GT(unlimited_stats.local_searches, static_cast<std::size_t>(kScans) * 9 / 10);
  EXPECT_LE(limited_stats.local_searches, static_cast<std::size_t>(low.local_search_share_after_scans));
  EXPECT_GT(limited_stats.local_declined, static_cast<std::size_t>(kScans - low.local_search_share_after_scans) * 9 / 10);
  EXPECT_EQ(limited_stats.local_searches + limited_stats.local_declined, unlimited_stats.local_searches);
}

TEST(SlamLocalSearch, ATurnTheOdometryMissesAfterManyGoodScansIsStillFound) {
  SlamOptions options;
  options.coast_guess = false;
  PlanarSlam slam(options);
  Pose2 truth{1.0, 1.5, 0.0}, odometry = truth;
  std::int64_t stamp_ns = 0;
  for (int k = 0; k < 250; ++k) {  // well above local_search_share_after_scans, along the room and back
    const Pose2 move{k % 100 < 50 ? 0.02 : -0.02, 0.0, 0.0};
    truth = truth * move;
    odometry = odometry * move;
    (void)slam.add_scan(1, stamp_ns += 100'000'000, odometry, test::scan(truth));
  }
  const double before = normalize_angle(slam.local_pose(slam.stats().nodes - 1).theta_rad - truth.theta_rad);
  double worst_deg = 0;
  const double step = deg_to_rad(18.0);
  for (int k = 0; k < 5; ++k) {  // the slipping quarter turn of ATurnTheOdometryMissesIsFoundByTheSearch
    truth = truth * Pose2{0.0, 0.0, step};
    odometry = odometry * Pose2{0.0, 0.0, 0.3 * step};
    const std::size_t node = slam.add_scan(1, stamp_ns += 100'000'000, odometry, test::scan(truth));
    worst_deg = std::max(worst_deg, std::abs(normalize_angle(slam.local_pose(node).theta_rad - truth.theta_rad) - before) * 180.0 / kPi);
  }
  const SlamStats stats = slam.stats();
  EXPECT_EQ(stats.local_declined, 0u);
  EXPECT_GT(stats.local_found, 0u);
  EXPECT_LT(worst_deg, 1.0);
}

TEST(SlamCoast, TiltedLasersNodesDoNotCoast) {
  // A tilted laser's node scores low on any submap, wherever it is placed: its odometry places it,
  // through the same stall as above.
  SlamStats stats;
  (void)worst_heading_in_a_stall_deg(tilted_laser_options(), &stats);
  EXPECT_EQ(stats.coasted, 0u);
  EXPECT_FALSE(tilted_laser_options().coast_guess);
}

TEST(SlamLocalSearch, TiltedLasersNodesAreNotSearched) {
  // A tilted laser's node holds a few wall returns and scores low on any submap: its odometry places it.
  EXPECT_EQ(tilted_laser_options().local_search_score, 0.0);
  EXPECT_GT(SlamOptions{}.local_search_score, 0.0);
}

}  // namespace
}  // namespace teamscan::posegraph
