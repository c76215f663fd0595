// Real data: registration on the Intel Research Lab log (tests/data/real/intel-lab-every5th.clf, a
// horizontal 2-D laser, 18 cm and up to 25° of real, drifting odometry between scans) with the
// policy for planar scans (registration::planar_scan_options, what `teamscan eval --registration`
// uses on an imported 2-D log): matches are accepted, and the map is more consistent than odometry
// alone by the revisit figure (docs/registration.md "Real data").
#include <gtest/gtest.h>

#include <fstream>
#include <sstream>
#include <vector>

#include "common/dataset/carmen.hpp"
#include "groundstation/mapping/dataset_registration.hpp"
#include "groundstation/registration/registration.hpp"
#include "tests/support/real_data.hpp"

namespace teamscan::registration {
namespace {

Dataset intel_lab(std::size_t scans) {
  std::ifstream in(test::real_data_path("intel-lab-every5th.clf"), std::ios::binary);
  std::stringstream text;
  text << in.rdbuf();
  CarmenLog log = parse_carmen(text.str());
  if (log.lasers.size() > scans) log.lasers.resize(scans);
  Result<Dataset> d = carmen_to_dataset(log, CarmenImportOptions{});
  return d ? std::move(d.value()) : Dataset{};
}

struct LogRun {
  mapping::RevisitConsistency odometry, registered;
  RobotCorrection robot;
};

// Every scan through the registration in log order, each point placed with the correction of its scan.
LogRun register_log(const Dataset& d, const RegistrationOptions& options) {
  std::vector<std::vector<Vec3>> points(d.scans.size());
  for (const LabelledPoint& p : d.points)
    if (p.scan < points.size()) points[p.scan].push_back({p.x, p.y, p.z});
  Registration reg(options);
  std::vector<Pose2> correction(d.scans.size());
  for (std::size_t i = 0; i < d.scans.size(); ++i)
    correction[i] = reg.add_scan(1, d.scans[i].stamp_ns, d.scans[i].pose, points[d.scans[i].scan], {}).map_from_odom;
  std::vector<mapping::MapPoint> placed(d.points.size());
  for (std::size_t i = 0; i < d.points.size(); ++i) {
    const LabelledPoint& p = d.points[i];
    const Vec2 q = correction[p.scan].apply({p.x, p.y});
    placed[i] = {static_cast<float>(q.x), static_cast<float>(q.y), p.z};
  }
  return {mapping::revisit_consistency(d), mapping::revisit_consistency(d, placed), *reg.correction(1)};
}

double share(std::uint64_t part, std::uint64_t all) { return all ? static_cast<double>(part) / static_cast<double>(all) : 0.0; }

TEST(IntelLab, PlanarPolicyAcceptsMatchesAndMakesTheMapMoreConsistent) {
  const Dataset d = intel_lab(10000);  // the whole log: 2726 scans, 506 m
  ASSERT_EQ(d.scans.size(), 2726u);
  const LogRun r = register_log(d, planar_scan_options());
  const double odometry_on_earlier = share(r.odometry.on_earlier_points, r.odometry.points);
  const double registered_on_earlier = share(r.registered.on_earlier_points, r.registered.points);
  std::printf("%llu matches, %llu accepted; within 10 cm of the earlier pass %.1f %% -> %.1f %%, "
              "revisits %.1f %% -> %.1f %%, median %.1f -> %.1f cm\n",
              static_cast<unsigned long long>(r.robot.matches), static_cast<unsigned long long>(r.robot.accepted),
              100 * odometry_on_earlier, 100 * registered_on_earlier, 100 * share(r.odometry.revisit_points, r.odometry.points),
              100 * share(r.registered.revisit_points, r.registered.points), 100 * r.odometry.median_m, 100 * r.registered.median_m);
  // The policy matches the sparse scans: a good share of the attempts is used (none were before).
  EXPECT_GT(r.robot.matches, 2000u);
  EXPECT_GT(share(r.robot.accepted, r.robot.matches), 0.25);
  // More of the log lands on what was mapped before, and more of it is recognised as a revisit.
  EXPECT_GT(registered_on_earlier, odometry_on_earlier + 0.08);
  EXPECT_GT(share(r.registered.revisit_points, r.registered.points), share(r.odometry.revisit_points, r.odometry.points) + 0.10);
}

TEST(IntelLab, TheTiltedLaserPolicyFindsNoMatchOnPlanarScans) {
  // Why the planar policy exists: the default (3 s window of 3-D surface features) on the same scans.
  RegistrationOptions o;
  o.surface.planar_scans = true;
  const LogRun r = register_log(intel_lab(600), o);
  EXPECT_EQ(r.robot.accepted, 0u);
  EXPECT_GT(r.robot.matches, 0u);
}

}  // namespace
}  // namespace teamscan::registration
