// Local SLAM's search (SlamOptions::local_search_score): a robot turning in place while its wheels slip,
// its odometry reporting less than half of each turn. The refinement alone, started from the odometry's
// prediction, cannot reach a scan turned degrees away and follows the odometry; with the search each
// scan is placed where the room's walls put it.
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
  auto add = [&](const Pose2& true_motion, const Pose2& reported_motion, bool turning) {
    truth = truth * true_motion;
    odometry = odometry * reported_motion;
    const std::size_t node = slam.add_scan(1, odometry, test::scan(truth));
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
  SlamOptions without;
  without.local_search_score = 0.0;
  const Turn followed = turn_in_place(without);
  const Turn searched = turn_in_place(SlamOptions{});
  std::printf("local SLAM's worst heading error in the turn: %.2f° refined alone, %.2f° with the search (%zu searches, %zu placed)\n",
              followed.worst_heading_deg, searched.worst_heading_deg, searched.stats.local_searches, searched.stats.local_found);
  EXPECT_EQ(followed.stats.local_searches, 0u);
  EXPECT_GT(followed.worst_heading_deg, 10.0);  // the refinement stays near the odometry's prediction
  EXPECT_GT(searched.stats.local_found, 0u);
  EXPECT_LT(searched.worst_heading_deg, 1.0);
}

TEST(SlamLocalSearch, TiltedLasersNodesAreNotSearched) {
  // A tilted laser's node holds a few wall returns and scores low on any submap: its odometry places it.
  EXPECT_EQ(tilted_laser_options().local_search_score, 0.0);
  EXPECT_GT(SlamOptions{}.local_search_score, 0.0);
}

}  // namespace
}  // namespace teamscan::posegraph
