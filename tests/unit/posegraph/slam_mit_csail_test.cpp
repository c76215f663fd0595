// The team SLAM on MIT CSAIL's log (tests/data/real/mit-csail.clf.xz, 1 988 scans over 424 s, one big
// loop): its odometry stalls twice in a turn (the same pose for four scans while the robot turns on)
// and then jumps by 50° and 86°. With local SLAM's coasting guess the big loop closes and the published
// relations (mit-csail.relations, five decimals: they name their scans rounded) are met to centimetres;
// from the odometry's prediction alone local SLAM's heading jumps at the stalls and the loop stays open.
#include <gtest/gtest.h>

#include <cstdint>
#include <cstdio>

#include "groundstation/posegraph/slam.hpp"
#include "groundstation/trajectory/relations.hpp"
#include "tests/unit/posegraph/carmen_log.hpp"

namespace teamscan::posegraph {
namespace {

TEST(SlamMitCsail, TheBigLoopClosesThroughTheOdometrysStalls) {
  const test::CarmenLogScans log = test::carmen_log("mit-csail.clf.xz", SIZE_MAX, test::FlaserBeams::fov_over_n);
  ASSERT_EQ(log.points.size(), 1988u);
  const std::vector<trajectory::Relation> relations = test::real_relations("mit-csail.relations");
  ASSERT_EQ(relations.size(), 1172u);
  SlamOptions without;
  without.coast_guess = false;
  SlamStats coasted;
  const trajectory::RelationErrors with = test::relation_errors_of(log, test::slam_poses(log, {}, &coasted), relations);
  const trajectory::RelationErrors none = test::relation_errors_of(log, test::slam_poses(log, without), relations);
  std::printf("MIT CSAIL relations: %.4f m / %.3f° with the coasting guess (%zu scans placed by it), %.4f m / %.3f° without\n",
              with.translation_mean_m, with.rotation_mean_deg, coasted.coasted, none.translation_mean_m, none.rotation_mean_deg);
  EXPECT_EQ(with.used, 1172u);  // every relation named its scans, most of them rounded
  EXPECT_GT(with.rounded, 1000u);
  EXPECT_GT(coasted.coasted, 0u);
  EXPECT_LT(with.translation_mean_m, 0.04);
  EXPECT_LT(with.rotation_mean_deg, 0.5);
  EXPECT_GT(none.translation_mean_m, 0.5);  // the loop open
}

}  // namespace
}  // namespace teamscan::posegraph
