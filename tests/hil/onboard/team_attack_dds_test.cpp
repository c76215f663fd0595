// Malformed team states on the robots, over DDS: a ground station publishes a good team state at 20 Hz on
// teamscan/team while a second participant publishes malformed team states at 50 Hz on the same topic.
// A robot's DdsBridge takes the team every 10 ms (as the daemon's loop does) into the pipeline, and every
// scan's direction-filter flags equal those of a reference pipeline that only ever sees the good states.
// Every malformed state the robot took is refused and counted; none reaches the filter.
#include <gtest/gtest.h>

#include <unistd.h>

#include <chrono>
#include <climits>
#include <limits>
#include <string>
#include <thread>

#include <dds/dds.h>

#include "common/clock.hpp"
#include "onboard/core/pipeline.hpp"
#include "onboard/bridge/bridge.hpp"
#include "dds/qos.hpp"
#include "dds/topics.hpp"
#include "teamscan.h"
#include "tests/support/onboard_config_fixture.hpp"
#include "tests/support/pipeline_scan.hpp"

namespace teamscan::onboard {
namespace {

using namespace std::chrono_literals;

struct TeamWriter {
  dds_entity_t participant = 0, writer = 0;
  explicit TeamWriter(std::uint32_t domain) {
    participant = dds_create_participant(domain, nullptr, nullptr);
    const dds_entity_t topic = dds_create_topic(participant, &teamscan_msg_TeamState_desc, dds::kTopicTeam, nullptr, nullptr);
    dds_qos_t* q = dds::make_team_writer_qos(2s);
    writer = dds_create_writer(participant, topic, q, nullptr);
    dds_delete_qos(q);
  }
  ~TeamWriter() {
    if (participant > 0) (void)dds_delete(participant);
  }
};

// Teammates 2 and 3 standing 3 m ahead of robot 1 (which stands at the map origin facing +x).
void good_team(teamscan_msg_TeamState& t, std::uint32_t seq, std::int64_t now_ns) {
  t = teamscan_msg_TeamState{};
  t.seq = seq;
  t.stamp_ns = now_ns;
  t.count = 2;
  for (std::uint32_t i = 0; i < 2; ++i) {
    teamscan_msg_TeamMember& m = t.members[i];
    m.robot_id = i + 2;
    m.x_mm = 3000;
    m.y_mm = i == 0 ? 0 : 1200;
    m.cov_xx_mm2 = m.cov_yy_mm2 = 400.0f;
    m.length_mm = 508;
    m.width_mm = 497;
    m.height_mm = 500;
    m.valid_ns = now_ns;
  }
}

// Member 0 moved to a plausible other place, member 1 carries the fault (the malformed publisher).
void malformed_team(teamscan_msg_TeamState& t, std::uint32_t k, std::int64_t now_ns) {
  good_team(t, 1000 + k, now_ns);
  t.members[0].y_mm = -2000;
  teamscan_msg_TeamMember& m = t.members[1];
  switch (k % 7) {
    case 0: m.robot_id = 0; break;
    case 1: m.robot_id = 999999; break;
    case 2: m.cov_xx_mm2 = std::numeric_limits<float>::quiet_NaN(); break;
    case 3: m.cov_yy_mm2 = -5.0f; break;
    case 4: m.x_mm = INT32_MAX; break;
    case 5: m.valid_ns = 0; break;
    default: m.vx_mmps = INT32_MIN; break;
  }
}

struct Beams {
  std::array<std::uint32_t, 361> range{};
  std::array<std::uint8_t, 361> flags{};
  BeamSpans spans() const { return {range, flags}; }
};

TEST(TeamAttackOverDds, MalformedTeamStatesAt50HzChangeNoDecision) {
  const auto domain = static_cast<std::uint32_t>(150 + ::getpid() % 80);
  std::string msg;
  auto cfg = parse_onboard_config(test::pipeline_test_config_toml(1, false), msg);
  ASSERT_TRUE(cfg.ok()) << msg;
  auto robot = OnboardPipeline::create(cfg.value());
  auto reference = OnboardPipeline::create(cfg.value());
  ASSERT_TRUE(robot.ok() && reference.ok());
  DdsBridgeOptions o;
  o.robot_id = 1;
  o.domain_id = domain;
  auto bridge = DdsBridge::create(o);
  ASSERT_TRUE(bridge.ok()) << bridge.error().what;
  TeamWriter station(domain), attacker(domain);
  ASSERT_GT(station.writer, 0);
  ASSERT_GT(attacker.writer, 0);
  const auto match_deadline = std::chrono::steady_clock::now() + 10s;
  for (dds_entity_t w : {station.writer, attacker.writer}) {
    dds_publication_matched_status_t st{};
    while ((dds_get_publication_matched_status(w, &st) != 0 || st.current_count == 0) &&
           std::chrono::steady_clock::now() < match_deadline)
      std::this_thread::sleep_for(10ms);
    ASSERT_GT(st.current_count, 0u);
  }

  Beams beams;
  for (std::size_t b = 0; b < beams.range.size(); ++b) beams.range[b] = 2800 + static_cast<std::uint32_t>(b % 23) * 30;
  OnboardPose pose;
  static teamscan_msg_TeamState good, bad;
  static TeamSnapshot taken, reference_team;
  std::uint32_t good_seq = 0, bad_k = 0, scans = 0;
  std::uint64_t filtered = 0, taken_count = 0;
  const Time start = now_monotonic();
  Time next_good = start, next_bad = start + 5ms, next_poll = start, next_scan = start + 100ms, next_odom = start;
  // 3 s: good team 20 Hz, malformed 50 Hz, team taken every 10 ms, odometry 10 Hz, scans ~75 Hz.
  while (now_monotonic() - start < 3s) {
    const Time now = now_monotonic();
    const Time rt = now_realtime();
    if (now >= next_odom) {
      ASSERT_TRUE(robot->on_odometry(rt, {0.0, 0.0, 0.0}, 0, 0, pose));
      ASSERT_TRUE(reference->on_odometry(rt, {0.0, 0.0, 0.0}, 0, 0, pose));
      next_odom = now + 100ms;
    }
    if (now >= next_good) {
      good_team(good, ++good_seq, rt.ns());
      ASSERT_EQ(dds_write(station.writer, &good), 0);
      ASSERT_TRUE(decode_team(good, reference_team));
      ASSERT_TRUE(reference->on_team(reference_team, rt).ok());
      next_good = now + 50ms;
    }
    if (now >= next_bad) {
      malformed_team(bad, bad_k++, rt.ns());
      ASSERT_EQ(dds_write(attacker.writer, &bad), 0);
      next_bad = now + 20ms;
    }
    if (now >= next_poll) {
      if (bridge->take_team(taken)) {
        ++taken_count;
        (void)robot->on_team(taken, rt);
      }
      next_poll = now + 10ms;
    }
    if (now >= next_scan && robot->odometry().size() >= 2) {
      const ScanPoints& a = test::scan_of(*reference, beams.spans(), rt - 5ms);
      const ScanPoints& b = test::scan_of(*robot, beams.spans(), rt - 5ms);
      ASSERT_EQ(a.count, b.count);
      for (std::uint16_t i = 0; i < a.count; ++i) ASSERT_EQ(a.points[i].flags, b.points[i].flags) << "scan " << scans << " point " << i;
      filtered += reference->last_filter_stats().filtered;
      ++scans;
      next_scan = now + 13ms;
    }
    std::this_thread::sleep_for(1ms);
  }
  EXPECT_GT(scans, 50u);
  EXPECT_GT(filtered, 0u);  // the filter really flagged the teammates' ghosts
  EXPECT_GT(robot->team_checks().rejected, 10u);   // malformed states arrived and were refused
  EXPECT_GT(robot->team_checks().accepted, 5u);    // good ones too
  EXPECT_EQ(robot->team_checks().rejected + robot->team_checks().accepted, taken_count);
  EXPECT_EQ(bridge->counters().bad_team_samples, 0u);  // all had count ≤ 32: refused by the check, not the decoder
}

}  // namespace
}  // namespace teamscan::onboard
