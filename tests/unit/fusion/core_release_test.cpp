// FusionCore's release rule with the registration on: scans go in stamp order, each as soon as no
// earlier-stamped scan can still arrive (every robot still sending has a scan stamped after it minus
// min_scan_interval_s); a scan stamped closer to its predecessor than that is released late, counted.
#include <gtest/gtest.h>

#include <cstdint>
#include <memory>
#include <vector>

#include "groundstation/fusion/core.hpp"

namespace teamscan::fusion {
namespace {

constexpr std::int64_t kMs = 1'000'000;
constexpr std::int64_t kPeriodNs = 13'333'333;  // 75 Hz

struct Released {
  std::uint8_t robot;
  std::uint32_t scan;
  std::int64_t stamp_ns;
  std::int64_t released_at_ns;  // the arrival clock of the call that released it
};

class ReleaseRule {
 public:
  explicit ReleaseRule(double min_scan_interval_s) {
    CoreOptions o;
    o.method = "position";
    o.registration = true;
    o.max_points_per_voxel = 0;
    o.min_scan_interval_s = min_scan_interval_s;
    auto core = FusionCore::create(o);
    EXPECT_TRUE(core.ok());
    core_ = std::move(*core);
    core_->set_release_callback([this](const FusedScan& f) {
      released.push_back({f.view->robot, f.view->scan, f.view->stamp_ns, now_ns_});
    });
    // Both robots' poses up to 3 s, arrived at 0: the pose watermark never holds a scan here.
    for (std::uint8_t r = 1; r <= 2; ++r)
      for (std::int64_t t = 0; t <= 3'000 * kMs; t += 10 * kMs)
        core_->add_pose({r, t, 0, Pose2{static_cast<double>(r), 0.0, 0.0}, 0.0, 0.0});
  }

  // A scan of `robot` stamped `stamp_ns`, arriving at its stamp.
  void scan(std::uint8_t robot, std::uint32_t seq, std::int64_t stamp_ns) {
    now_ns_ = stamp_ns;
    const std::vector<mapping::MapPoint> points{{static_cast<float>(robot), 1.0f, 0.5f}, {2.0f, 1.0f, 0.5f}};
    ScanInput in;
    in.robot = robot;
    in.scan = seq;
    in.stamp_ns = stamp_ns;
    in.origin_m = {static_cast<double>(robot), 0.0, 0.3};
    in.points = points;
    in.arrival_ns = stamp_ns;
    ASSERT_TRUE(core_->add_scan(in));
  }

  // Robot 1 at 1 s + k·period, robot 2 5 ms later, k < n, fed in stamp order (the start-up hold, the
  // first hold_s of arrival time, is over at 1 s).
  void two_robots(std::uint32_t n) {
    for (std::uint32_t k = 0; k < n; ++k) {
      scan(1, k + 1, 1'000 * kMs + k * kPeriodNs);
      scan(2, k + 1, 1'005 * kMs + k * kPeriodNs);
    }
  }

  [[nodiscard]] const FusionCore& core() const { return *core_; }
  void flush() { core_->flush(); }

  std::vector<Released> released;

 private:
  std::unique_ptr<FusionCore> core_;
  std::int64_t now_ns_ = 0;
};

void expect_stamp_order(const std::vector<Released>& released) {
  for (std::size_t i = 1; i < released.size(); ++i) EXPECT_LE(released[i - 1].stamp_ns, released[i].stamp_ns) << i;
}

TEST(FusionCoreRelease, AScanGoesAsSoonAsNoEarlierStampedScanCanStillArrive) {
  ReleaseRule rule(to_seconds(kLmsRevolution) / 2);  // the default: 6.67 ms
  ASSERT_EQ(rule.core().options().min_scan_interval_s, CoreOptions{}.min_scan_interval_s);
  rule.two_robots(20);
  expect_stamp_order(rule.released);
  for (const Released& r : rule.released) {
    const std::int64_t wait = r.released_at_ns - r.stamp_ns;
    // Robot 2's scan at t: robot 1's newest is t − 5 ms, and robot 1 stamps nothing before t − 5 + 6.67 ms:
    // released on arrival. Robot 1's scan waits for robot 2's, 5 ms later (robot 2's newest, t − 8.3 ms,
    // proves nothing).
    // Robot 1's first goes at once: robot 2 has sent nothing yet, so it holds nothing back.
    EXPECT_EQ(wait, r.robot == 2 || r.scan == 1 ? 0 : 5 * kMs) << "robot " << int(r.robot) << " scan " << r.scan;
  }
  EXPECT_EQ(rule.released.size(), 40u);  // every scan without a flush
  rule.flush();
  EXPECT_EQ(rule.released.size(), 40u);
  EXPECT_EQ(rule.core().counters().scans_out_of_stamp_order, 0u);
}

TEST(FusionCoreRelease, WithoutAnIntervalAScanWaitsForEveryRobotToPassIt) {
  ReleaseRule rule(0.0);
  rule.two_robots(20);
  expect_stamp_order(rule.released);
  for (const Released& r : rule.released) {
    const std::int64_t wait = r.released_at_ns - r.stamp_ns;
    const std::int64_t expected = r.robot == 2 ? kPeriodNs - 5 * kMs : r.scan == 1 ? 0 : 5 * kMs;
    EXPECT_EQ(wait, expected) << "robot " << int(r.robot) << " scan " << r.scan;
  }
  EXPECT_EQ(rule.released.size(), 39u);  // robot 2's last waits for a scan of robot 1 stamped at or after it
  rule.flush();
  EXPECT_EQ(rule.released.size(), 40u);
  EXPECT_EQ(rule.core().counters().scans_out_of_stamp_order, 0u);
}

TEST(FusionCoreRelease, AScanStampedCloserThanTheIntervalIsReleasedLateAndCounted) {
  ReleaseRule rule(to_seconds(kLmsRevolution) / 2);
  rule.two_robots(5);  // robot 1's last at 1 053.3 ms, robot 2's at 1 058.3 ms: both out
  const std::size_t before = rule.released.size();
  ASSERT_EQ(before, 10u);
  // Robot 2's went on the promise that robot 1 stamps nothing before 1 053.3 + 6.67 ms; robot 1's next is
  // stamped only 3 ms after its last (a jittered stamp), before robot 2's.
  rule.scan(1, 6, 1'000 * kMs + 4 * kPeriodNs + 3 * kMs);
  rule.scan(2, 6, 1'005 * kMs + 5 * kPeriodNs);
  rule.flush();
  EXPECT_EQ(rule.released.size(), 12u);  // nothing lost
  EXPECT_EQ(rule.core().counters().scans_out_of_stamp_order, 1u);
  EXPECT_EQ(rule.core().counters().scans_released, 12u);
}

}  // namespace
}  // namespace teamscan::fusion
