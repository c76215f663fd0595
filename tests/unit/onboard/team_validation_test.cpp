// check_team (onboard/core/team_validation.hpp) and the pipeline's team handling: every malformed team
// state is refused with its reason, and a publisher of malformed team states at 50 Hz
// beside the ground station's 20 Hz does not change one direction-filter decision (the pipeline keeps
// the last good state).
#include "onboard/core/team_validation.hpp"

#include <gtest/gtest.h>

#include <climits>
#include <cmath>
#include <limits>
#include <vector>

#include "onboard/core/pipeline.hpp"
#include "tests/support/onboard_config_fixture.hpp"
#include "tests/support/pipeline_scan.hpp"

namespace teamscan::onboard {
namespace {

using namespace std::chrono_literals;

const Time kNow = Time::from_ns(1'800'000'000'000'000'000);

TeamSnapshot good_team(Time valid) {
  TeamSnapshot t;
  t.count = 2;
  for (std::uint32_t i = 0; i < 2; ++i) {
    TeamMemberState& m = t.members[i];
    m.robot_id = i + 2;
    m.x_mm = 3000;
    m.y_mm = i == 0 ? 0 : 1500;
    m.vx_mmps = 200;
    m.cov_xx = 400.0f;
    m.cov_yy = 400.0f;
    m.cov_xy = 10.0f;
    m.length_mm = 508;
    m.width_mm = 497;
    m.height_mm = 500;
    m.valid_ns = valid.ns();
  }
  return t;
}

// The malformed states, one per reason (member 1 carries the fault; member 0 is moved to a plausible
// other place, so an accepted malformed state would change the filter's decisions).
std::vector<std::pair<TeamSnapshot, TeamReject>> malformed(Time now) {
  std::vector<std::pair<TeamSnapshot, TeamReject>> out;
  auto base = [&] {
    TeamSnapshot t = good_team(now);
    t.members[0].x_mm = 1500;
    t.members[0].y_mm = -2500;
    return t;
  };
  TeamSnapshot t = base();
  t.count = 200;
  out.emplace_back(t, TeamReject::kCount);
  for (std::uint32_t id : {0u, 33u, 999999u}) {
    t = base();
    t.members[1].robot_id = id;
    out.emplace_back(t, TeamReject::kRobotId);
  }
  t = base();
  t.members[1].robot_id = 2;
  out.emplace_back(t, TeamReject::kDuplicateId);
  for (float bad : {std::numeric_limits<float>::quiet_NaN(), std::numeric_limits<float>::infinity(), -1.0f, 1e30f}) {
    t = base();
    t.members[1].cov_yy = bad;
    out.emplace_back(t, TeamReject::kCovariance);
  }
  t = base();
  t.members[1].cov_xy = 5000.0f;  // |xy| > sqrt(xx·yy) = 400: not a covariance
  out.emplace_back(t, TeamReject::kCovariance);
  for (std::int32_t bad : {INT32_MAX, INT32_MIN}) {
    t = base();
    t.members[1].x_mm = bad;
    out.emplace_back(t, TeamReject::kPosition);
  }
  t = base();
  t.members[1].vy_mmps = INT32_MIN;
  out.emplace_back(t, TeamReject::kVelocity);
  t = base();
  t.members[1].height_mm = 65535;
  out.emplace_back(t, TeamReject::kSize);
  for (std::int64_t bad : {std::int64_t{0}, INT64_MIN, INT64_MAX, now.ns() - 3'600'000'000'000}) {
    t = base();
    t.members[1].valid_ns = bad;
    out.emplace_back(t, TeamReject::kStamp);
  }
  for (const OdomCorrection& bad : {OdomCorrection{0, 0, 3'141'594, 4}, OdomCorrection{0, 0, INT32_MIN, 4},
                                    OdomCorrection{20'000'001, 0, 0, 4}, OdomCorrection{0, INT32_MIN, 0, 4},
                                    OdomCorrection{10, 0, 0, 0}}) {  // values with "none"
    t = base();
    t.members[1].correction = bad;
    out.emplace_back(t, TeamReject::kCorrection);
  }
  return out;
}

TEST(TeamValidation, AGoodTeamPasses) {
  const TeamCheckLimits limits;
  EXPECT_TRUE(check_team(good_team(kNow), kNow, limits).ok());
  EXPECT_TRUE(check_team(good_team(kNow - 200ms), kNow, limits).ok());
  TeamSnapshot empty;
  EXPECT_TRUE(check_team(empty, kNow, limits).ok());
  // A lost member keeps its last known position and time, however old.
  TeamSnapshot lost = good_team(kNow);
  lost.members[1].lost = true;
  lost.members[1].valid_ns = (kNow - 3600s).ns();
  EXPECT_TRUE(check_team(lost, kNow, limits).ok());
}

TEST(TeamValidation, PlausibleCorrectionsPass) {
  const TeamCheckLimits limits;
  TeamSnapshot t = good_team(kNow);
  t.members[0].correction = OdomCorrection{-1200, 20'000'000, -3'141'593, 1};
  t.members[1].correction = OdomCorrection{0, 0, 3'141'593, 0xFFFFFFFFu};
  EXPECT_TRUE(check_team(t, kNow, limits).ok());
}

TEST(TeamValidation, TheCorrectionStepIsBoundedInShiftAndTurnTheShortWayRound) {
  const TeamCheckLimits limits;  // 2 m, 30°
  const OdomCorrection from{1000, -1000, 3'000'000, 5};
  EXPECT_TRUE(correction_step_ok(from, {2414, 414, 3'000'000, 6}, limits));    // 1.9997 m diagonal
  EXPECT_FALSE(correction_step_ok(from, {2415, 415, 3'000'000, 6}, limits));   // 2.0011 m
  EXPECT_FALSE(correction_step_ok(from, {3001, -1000, 3'000'000, 6}, limits));
  EXPECT_TRUE(correction_step_ok(from, {1000, -1000, 3'000'000 - 523'599, 6}, limits));
  EXPECT_FALSE(correction_step_ok(from, {1000, -1000, 3'000'000 - 523'600, 6}, limits));
  // 3.0 rad to −3.0 rad is 0.283 rad (16°) across ±π, not 6 rad.
  EXPECT_TRUE(correction_step_ok(from, {1000, -1000, -3'000'000, 6}, limits));
  EXPECT_FALSE(correction_step_ok({}, {INT32_MAX, INT32_MIN, 0, 1}, limits));  // no overflow at the extremes
}

TEST(TeamValidation, EveryMalformedStateIsRefusedWithItsReason) {
  const TeamCheckLimits limits;
  for (const auto& [team, reason] : malformed(kNow)) {
    const TeamCheck c = check_team(team, kNow, limits);
    EXPECT_EQ(c.reason, reason) << team_reject_name(reason);
    if (reason != TeamReject::kCount) {
      EXPECT_EQ(c.member, 1u);
    }
  }
  // A robot whose own clock was never set cannot judge any stamp: refused.
  EXPECT_EQ(check_team(good_team(kNow), Time::from_ns(1'000'000'000), limits).reason, TeamReject::kStamp);
}

struct Beams {
  std::array<std::uint32_t, 361> range{};
  std::array<std::uint8_t, 361> flags{};
  BeamSpans spans() const { return {range, flags}; }
};

// Two pipelines see the same odometry, scans and ground-station team states (20 Hz); the second also
// gets malformed team states at 50 Hz. Every scan's flags must be equal, and every malformed one counted.
TEST(TeamValidation, MalformedTeamStatesAt50HzChangeNoDecision) {
  std::string msg;
  auto cfg = parse_onboard_config(test::pipeline_test_config_toml(1, false), msg);
  ASSERT_TRUE(cfg.ok()) << msg;
  auto clean = OnboardPipeline::create(cfg.value());
  auto attacked = OnboardPipeline::create(cfg.value());
  ASSERT_TRUE(clean.ok() && attacked.ok());
  Beams beams;
  for (std::size_t b = 0; b < beams.range.size(); ++b) beams.range[b] = 2500 + static_cast<std::uint32_t>(b % 37) * 40;
  const auto bad = malformed(kNow);
  OnboardPose pose;
  std::uint64_t filtered = 0, sent_bad = 0;
  std::size_t next_bad = 0;
  // 4 s of robot time in 1 ms steps: scans at 75 Hz, odometry 10 Hz, team 20 Hz, malformed 50 Hz.
  for (int ms = 0; ms < 4000; ++ms) {
    const Time t = kNow + std::chrono::milliseconds(ms);
    if (ms % 100 == 0) {
      const Pose2 odom{0.0003 * ms, 0.0, 0.0};
      ASSERT_TRUE(clean->on_odometry(t, odom, 300, 0, pose));
      ASSERT_TRUE(attacked->on_odometry(t, odom, 300, 0, pose));
    }
    if (ms % 50 == 0) {
      const TeamSnapshot team = good_team(t);
      ASSERT_TRUE(clean->on_team(team, t).ok());
      ASSERT_TRUE(attacked->on_team(team, t).ok());
    }
    if (ms % 20 == 7) {
      auto [team, reason] = bad[next_bad++ % bad.size()];
      for (std::uint32_t m = 0; m < 2; ++m) {
        if (team.members[m].valid_ns == kNow.ns()) team.members[m].valid_ns = t.ns();
      }
      EXPECT_EQ(attacked->on_team(team, t).reason, reason);
      ++sent_bad;
    }
    if (ms % 40 == 13) {  // 75 Hz would be every 13.3 ms; 25 Hz keeps the test fast with the same coverage
      const ScanPoints& a = test::scan_of(*clean, beams.spans(), t);
      const ScanPoints& b = test::scan_of(*attacked, beams.spans(), t);
      ASSERT_EQ(a.count, b.count);
      for (std::uint16_t i = 0; i < a.count; ++i) ASSERT_EQ(a.points[i].flags, b.points[i].flags) << "scan at " << ms << " ms, point " << i;
      filtered += clean->last_filter_stats().filtered;
    }
  }
  EXPECT_GT(filtered, 0u);  // the filter really removed points against the good team
  EXPECT_EQ(attacked->team_checks().rejected, sent_bad);
  EXPECT_EQ(attacked->team_checks().accepted, clean->team_checks().accepted);
  EXPECT_EQ(clean->team_checks().rejected, 0u);
  EXPECT_NE(attacked->team_checks().last_reject, TeamReject::kNone);
}

}  // namespace
}  // namespace teamscan::onboard
