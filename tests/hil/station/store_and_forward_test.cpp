// The Station library in this process against an in-process robot bridge (onboard/bridge) on loopback
// DDS, as far as store and forward goes (docs/onboard.md "The ring"): back-filled poses are stored once,
// go to the back-fill pose hooks only and are confirmed on teamscan/stored beside the scans; a live
// duplicate of a stored pose is counted, not stored; a scan the edge validation refuses, sent by its own
// robot, is stored raw and confirmed (its ring does not send it again and again).
#include <gtest/gtest.h>

#include <chrono>
#include <filesystem>
#include <optional>

#include "common/clock.hpp"
#include "groundstation/station/session_replay.hpp"
#include "groundstation/station/session_store.hpp"
#include "groundstation/station/station.hpp"
#include "onboard/bridge/bridge.hpp"
#include "tests/hil/station/station_fixture.hpp"
#include "tests/support/test_domain.hpp"

namespace teamscan::station {
namespace {

using namespace std::chrono_literals;

constexpr std::uint32_t kRobot = 7;

using Fixture = test::StationFixture;

onboard::OnboardPose pose(std::uint32_t seq, std::int64_t stamp_ns) {
  return onboard::OnboardPose{kRobot, seq, stamp_ns, 1000 + static_cast<std::int32_t>(seq), 2000, 0, 100, 0, 0};
}

ScanPoints scan(std::uint32_t seq, std::int64_t stamp_ns, std::int32_t origin_x_mm) {
  ScanPoints s;
  s.robot_id = kRobot;
  s.seq = seq;
  s.stamp = Time::from_ns(stamp_ns);
  s.origin_x_mm = origin_x_mm;
  s.origin_z_mm = 450;
  s.count = 3;
  for (std::uint16_t b = 0; b < 3; ++b) s.points[b] = ScanPoint{1500 + b, 2000, 300, b, 0};
  return s;
}

TEST(StationStoreAndForward, BackfilledPosesAreStoredOnceAndConfirmedAndRefusedScansConfirmed) {
  Fixture f;
  std::uint64_t live_hook = 0, backfill_hook = 0;
  f.station->add_pose_hook([&](const PoseObservation&) { ++live_hook; });
  f.station->add_backfill_pose_hook([&](const PoseObservation&) { ++backfill_hook; });
  onboard::DdsBridgeOptions o;
  o.robot_id = kRobot;
  o.domain_id = test::test_domain_id();
  o.store_and_forward = true;
  o.subscribe_team = false;
  auto bridge = onboard::DdsBridge::create(o);
  ASSERT_TRUE(bridge.ok()) << bridge.error().what;
  onboard::DdsBridge& b = bridge.value();
  const std::int64_t now = now_realtime().ns();
  const std::int64_t shadow = now - 600'000'000'000;  // ten minutes ago

  // Live: poses 1..3, scans 1..3 of which 2 lies outside the site (refused at the edge, stored raw).
  for (std::uint32_t s = 1; s <= 3; ++s) ASSERT_TRUE(b.publish_pose(pose(s, now - (4 - s) * 100'000'000)).ok());
  ASSERT_TRUE(f.run_until([&] { return f.station->robot(kRobot).poses >= 3; }, 10s));
  // Poses but no scan stored yet: teamscan/stored does not name the robot (contiguous_seq 0 would tell it
  // none of its ring's scans is stored). It is published at least once a second.
  bool named = false;
  std::uint32_t stored_samples = 0;
  f.run_until(
      [&] {
        onboard::StoredSnapshot got{};
        while (b.take_stored(got)) {
          ++stored_samples;
          for (std::uint32_t i = 0; i < got.count; ++i) named = named || got.robots[i].robot_id == kRobot;
        }
        return false;
      },
      1500ms);
  EXPECT_GT(stored_samples, 0u);
  EXPECT_FALSE(named);
  for (std::uint32_t s = 1; s <= 3; ++s)
    ASSERT_TRUE(b.publish_scan(scan(s, now - (4 - s) * 13'000'000, s == 2 ? 20'000'000 : 1000)).ok());
  ASSERT_TRUE(f.run_until([&] { return f.station->stored(kRobot).contiguous() >= 3; }, 10s))
      << "scans confirmed up to " << f.station->stored(kRobot).contiguous();
  EXPECT_EQ(f.station->robot(kRobot).scans, 2u);  // the refused one is not the robot's stored-and-fused count
  EXPECT_GE(f.station->counters().rejected, 1u);

  // From the ring: poses 4 and 5 of a shadow, and pose 2 again (the station has it).
  ASSERT_TRUE(b.publish_backfill_pose(pose(2, now - 200'000'000)).ok());
  ASSERT_TRUE(b.publish_backfill_pose(pose(4, shadow)).ok());
  ASSERT_TRUE(b.publish_backfill_pose(pose(5, shadow + 100'000'000)).ok());
  ASSERT_TRUE(f.run_until([&] { return f.station->stored_poses(kRobot).contiguous() >= 5; }, 10s))
      << "poses confirmed up to " << f.station->stored_poses(kRobot).contiguous();
  EXPECT_EQ(f.station->robot(kRobot).poses_backfilled, 2u);
  EXPECT_EQ(f.station->robot(kRobot).poses_duplicate, 1u);
  EXPECT_EQ(f.station->counters().poses_backfilled, 2u);
  EXPECT_EQ(live_hook, 3u);
  EXPECT_EQ(backfill_hook, 2u);

  // The robot hears both confirmations on teamscan/stored.
  onboard::StoredSnapshot stored{};
  const bool heard = f.run_until(
      [&] {
        onboard::StoredSnapshot got{};
        while (b.take_stored(got)) stored = got;
        return stored.count == 1 && stored.robots[0].pose_contiguous_seq == 5 && stored.robots[0].contiguous_seq == 3;
      },
      10s);
  ASSERT_TRUE(heard) << "count " << stored.count << ", scans " << stored.robots[0].contiguous_seq << ", poses "
                     << stored.robots[0].pose_contiguous_seq;
  EXPECT_EQ(stored.robots[0].robot_id, kRobot);

  // The session: every pose seq once, the back-filled ones with their old stamps.
  f.store->sync();
  std::vector<std::uint32_t> seqs;
  SessionReadStats stats;
  ASSERT_TRUE(replay_session_files(
                  f.root + "/session",
                  [&](const PoseObservation& p) {
                    seqs.push_back(p.seq);
                    if (p.seq >= 4) {
                      EXPECT_LT(p.stamp.ns(), now - 500'000'000'000) << p.seq;
                    }
                  },
                  [](const ScanPoints&, const Receipt&) {}, stats)
                  .ok());
  std::sort(seqs.begin(), seqs.end());
  EXPECT_EQ(seqs, (std::vector<std::uint32_t>{1, 2, 3, 4, 5}));
}

}  // namespace
}  // namespace teamscan::station
