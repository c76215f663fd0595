// The registration's correction reaches teamscan/team from a live teamscan-groundstation process when
// its scans are released by the loop's clock, not by a sample: two test robots (DdsBridge in this
// process, loopback DDS) send a 12 s survey, robot 2's odometry drifting (tests/support/odometry_drift.hpp),
// stamped 12 s behind real time and in one burst (a robot's backlog after a link outage). The core holds
// the burst for its start-up hold (fusion.hold_s), then the loop's clock releases it all at once after
// the last sample; robot 2's correction must then be on teamscan/team within a few team periods. It was
// not (docs/registration.md "Back on the robots": the corrections went to the team source only from the
// sample hooks, so those of a release by the clock waited for a next sample that never came).
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <thread>

#include "common/clock.hpp"
#include "onboard/bridge/bridge.hpp"
#include "tests/bench/mapping/synthetic_survey.hpp"
#include "tests/hil/station/process.hpp"
#include "tests/hil/station/robot_bridges.hpp"
#include "tests/support/odometry_drift.hpp"
#include "tests/support/test_domain.hpp"

namespace teamscan {
namespace {

using namespace std::chrono_literals;

std::int32_t mm(double m) { return static_cast<std::int32_t>(std::lround(m * 1000.0)); }

TEST(StationRegistrationLoop, ACorrectionOfScansReleasedByTheClockIsOnTheTeamWithoutAnotherSample) {
  bench::SurveyOptions so;
  so.duration_s = 12.0;
  so.room_m = 6.0;
  so.seed = 3;
  Dataset d = bench::synthetic_survey(so);
  test::add_odometry_drift(d, 2);
  const std::int64_t base_ns = now_realtime().ns() - 12'000'000'000;
  for (ScanRecord& r : d.scans) r.stamp_ns += base_ns;
  for (TrajectorySample& s : d.odom) s.stamp_ns += base_ns;

  char tmpl[] = "/tmp/teamscan-station-regloop-XXXXXX";
  const std::string root = ::mkdtemp(tmpl);
  const std::string session = root + "/session", config = root + "/gs.toml";
  {
    std::ofstream c(config);
    c << "[fusion]\nmethod = \"best\"\nwrite_interval_s = 0.0\n"
      << "[registration]\nwindow_s = 1.0\nmatch_every_s = 0.3\nmin_map_features = 20\n"
      << "[ros2]\nenabled = false\n[view]\nlisten = \"\"\n";
  }
  std::vector<onboard::DdsBridge> robots;
  test::start_robot_bridges(robots);
  ASSERT_FALSE(::testing::Test::HasFatalFailure());
  test::ChildProcess gs({TEAMSCAN_GROUNDSTATION, "--config", config, "--session-dir", session, "--domain", test::test_domain_arg()});
  for (auto& b : robots) {
    const auto deadline = std::chrono::steady_clock::now() + 15s;
    while (b.scan_subscribers() < 1 && std::chrono::steady_clock::now() < deadline) std::this_thread::sleep_for(10ms);
    ASSERT_EQ(b.scan_subscribers(), 1u);
  }
  std::this_thread::sleep_for(300ms);  // pose reader matched too

  // The burst: in stamp order, each robot's pose at a scan's stamp, then the scan (2 ms apart: the
  // pose topic is keep-last 1).
  std::map<std::pair<std::uint8_t, std::uint32_t>, std::vector<const LabelledPoint*>> points;
  for (const LabelledPoint& p : d.points) points[{p.robot, p.scan}].push_back(&p);
  static ScanPoints scan;
  std::size_t next_odom = 0;
  for (const ScanRecord& r : d.scans) {
    while (next_odom < d.odom.size() && d.odom[next_odom].stamp_ns <= r.stamp_ns) {
      const TrajectorySample& s = d.odom[next_odom++];
      onboard::OnboardPose pose;
      pose.robot_id = s.robot;
      pose.seq = static_cast<std::uint32_t>(next_odom);
      pose.stamp_ns = s.stamp_ns;
      pose.x_mm = mm(s.pose.x_m);
      pose.y_mm = mm(s.pose.y_m);
      pose.yaw_urad = static_cast<std::int32_t>(std::lround(s.pose.theta_rad * 1e6));
      ASSERT_TRUE(robots[s.robot - 1u].publish_pose(pose).ok());
      std::this_thread::sleep_for(2ms);
    }
    scan.robot_id = r.robot;
    scan.seq = r.scan + 1;
    scan.stamp = Time::from_ns(r.stamp_ns);
    scan.origin_x_mm = mm(r.origin.x);
    scan.origin_y_mm = mm(r.origin.y);
    scan.origin_z_mm = mm(r.origin.z);
    scan.count = 0;
    for (const LabelledPoint* p : points[{r.robot, r.scan}])
      scan.points[scan.count++] = ScanPoint{mm(p->x), mm(p->y), mm(p->z), p->beam, 0};
    ASSERT_TRUE(robots[r.robot - 1u].publish_scan(scan).ok());
  }
  for (auto& b : robots) ASSERT_TRUE(b.wait_for_scan_acks(from_seconds(20.0)).ok());
  const auto sent = std::chrono::steady_clock::now();

  // No more samples: robot 2's correction must come with the team states that follow.
  OdomCorrection seen;
  double after_s = -1;
  while (seen.none() && std::chrono::steady_clock::now() < sent + 10s) {
    onboard::TeamSnapshot team;
    while (robots[1].take_team(team)) {
      for (std::uint32_t i = 0; i < team.count; ++i) {
        if (team.members[i].robot_id == 2 && !team.members[i].correction.none() && seen.none()) {
          seen = team.members[i].correction;
          after_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - sent).count();
        }
      }
    }
    std::this_thread::sleep_for(20ms);
  }
  ASSERT_FALSE(seen.none()) << "no correction for robot 2 on teamscan/team within 10 s after the burst";
  // The survey's drift reaches ≈ (14, −10) cm by 12 s: the correction is not a rounding of the identity.
  EXPECT_GT(std::abs(seen.x_mm) + std::abs(seen.y_mm), 20) << seen.x_mm << ", " << seen.y_mm;
  std::printf("robot 2's correction (%d mm, %d mm, %d urad) #%u on teamscan/team %.2f s after the last sample\n", seen.x_mm,
              seen.y_mm, seen.yaw_urad, seen.seq, after_s);
  gs.signal(SIGTERM);
  const auto st = gs.wait(30s);
  ASSERT_TRUE(st.has_value());
  EXPECT_TRUE(WIFEXITED(*st) && WEXITSTATUS(*st) == 0);
  if (!HasFailure()) std::filesystem::remove_all(root);
}

}  // namespace
}  // namespace teamscan
