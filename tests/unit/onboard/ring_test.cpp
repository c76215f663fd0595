// The store-and-forward ring (onboard/ring): the record codec against the CRC-32C check value and its own
// bytes, the index's bookkeeping (full ring, confirmations, back-fill order and rate), and the ring file
// through restarts: records survive, torn ones are counted and skipped, a wrapped ring recovers its order.
#include <fcntl.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <array>
#include <cstdio>
#include <cstring>
#include <string>
#include <vector>

#include "onboard/core/config.hpp"
#include "onboard/ring/record.hpp"
#include "onboard/ring/ring_index.hpp"
#include "onboard/ring/scan_ring.hpp"

namespace teamscan::onboard::ring {
namespace {

ScanPoints make_scan(std::uint32_t seq, std::uint16_t count) {
  ScanPoints s;
  s.robot_id = 3;
  s.seq = seq;
  s.stamp = Time::from_ns(1'700'000'000'000'000'000 + static_cast<std::int64_t>(seq) * 13'333'333);
  s.origin_x_mm = -1000 + static_cast<std::int32_t>(seq);
  s.origin_y_mm = 2000;
  s.origin_z_mm = 450;
  s.applied = OdomCorrection{12, -7, 3456, 9};
  s.count = count;
  for (std::uint16_t i = 0; i < count; ++i)
    s.points[i] = ScanPoint{static_cast<std::int32_t>(i * 3 + seq), -static_cast<std::int32_t>(i), 17, i,
                            static_cast<std::uint16_t>(i % 7)};
  return s;
}

void expect_same(const ScanPoints& a, const ScanPoints& b) {
  EXPECT_EQ(a.robot_id, b.robot_id);
  EXPECT_EQ(a.seq, b.seq);
  EXPECT_EQ(a.stamp, b.stamp);
  EXPECT_EQ(a.origin_x_mm, b.origin_x_mm);
  EXPECT_EQ(a.origin_y_mm, b.origin_y_mm);
  EXPECT_EQ(a.origin_z_mm, b.origin_z_mm);
  EXPECT_EQ(a.applied.x_mm, b.applied.x_mm);
  EXPECT_EQ(a.applied.y_mm, b.applied.y_mm);
  EXPECT_EQ(a.applied.yaw_urad, b.applied.yaw_urad);
  EXPECT_EQ(a.applied.seq, b.applied.seq);
  ASSERT_EQ(a.count, b.count);
  for (std::uint16_t i = 0; i < a.count; ++i) {
    EXPECT_EQ(a.points[i].x_mm, b.points[i].x_mm);
    EXPECT_EQ(a.points[i].y_mm, b.points[i].y_mm);
    EXPECT_EQ(a.points[i].z_mm, b.points[i].z_mm);
    EXPECT_EQ(a.points[i].beam, b.points[i].beam);
    EXPECT_EQ(a.points[i].flags, b.points[i].flags);
  }
}

TEST(RingRecord, Crc32cCheckValue) {
  const char* text = "123456789";
  EXPECT_EQ(crc32c(std::span<const std::uint8_t>(reinterpret_cast<const std::uint8_t*>(text), 9)), 0xE3069283u);
  // Split anywhere, the running CRC is the same.
  const std::uint32_t head = crc32c(std::span<const std::uint8_t>(reinterpret_cast<const std::uint8_t*>(text), 4));
  EXPECT_EQ(crc32c(std::span<const std::uint8_t>(reinterpret_cast<const std::uint8_t*>(text) + 4, 5), head),
            0xE3069283u);
  EXPECT_EQ(crc32c({}), 0u);
}

TEST(RingRecord, ScansRoundTripAtEveryCount) {
  std::array<std::uint8_t, kSlotBytes> slot{};
  for (std::uint16_t count : {0, 1, 361, 401}) {
    const ScanPoints in = make_scan(42, count);
    const std::size_t n = encode_scan_record(in, 1234567890123ull, slot);
    EXPECT_EQ(n, kHeaderBytes + kScanFixedBytes + count * kPointBytes);
    RecordHeader h;
    ASSERT_EQ(check_record(slot, h), RecordError::kNone) << count;
    EXPECT_EQ(h.kind, RecordKind::kScan);
    EXPECT_EQ(h.ring_seq, 1234567890123ull);
    EXPECT_EQ(h.seq, 42u);
    EXPECT_EQ(h.robot_id, 3u);
    ScanPoints out;
    decode_scan_payload(slot, h, out);
    expect_same(in, out);
  }
  // The layout's first bytes: "TSRG", version 1, kind 1.
  EXPECT_EQ(slot[0], 'T');
  EXPECT_EQ(slot[1], 'S');
  EXPECT_EQ(slot[2], 'R');
  EXPECT_EQ(slot[3], 'G');
  EXPECT_EQ(slot[4], 1);
  EXPECT_EQ(slot[6], 1);
}

TEST(RingRecord, PoseRoundTrip) {
  std::array<std::uint8_t, kSlotBytes> slot{};
  OnboardPose p{3, 77, 1'700'000'000'123'456'789, -5, 6, -3'141'592, 700, -1, 30};
  EXPECT_EQ(encode_pose_record(p, 5, slot), kHeaderBytes + kPosePayloadBytes);
  RecordHeader h;
  ASSERT_EQ(check_record(slot, h), RecordError::kNone);
  EXPECT_EQ(h.kind, RecordKind::kPose);
  OnboardPose q;
  decode_pose_payload(slot, h, q);
  EXPECT_EQ(q.seq, 77u);
  EXPECT_EQ(q.stamp_ns, p.stamp_ns);
  EXPECT_EQ(q.yaw_urad, p.yaw_urad);
  EXPECT_EQ(q.yaw_rate_mradps, 30);
}

TEST(RingRecord, BadRecordsAreNamed) {
  std::array<std::uint8_t, kSlotBytes> slot{};
  RecordHeader h;
  EXPECT_EQ(check_record(slot, h), RecordError::kEmpty);
  EXPECT_EQ(check_record(std::span<const std::uint8_t>(slot.data(), 10), h), RecordError::kShort);
  const std::size_t n = encode_scan_record(make_scan(1, 361), 0, slot);
  std::array<std::uint8_t, kSlotBytes> bad = slot;
  bad[n - 1] ^= 0x01;  // the last point's flags: a torn tail
  EXPECT_EQ(check_record(bad, h), RecordError::kCrc);
  bad = slot;
  bad[kHeaderBytes + 36] = 0x92;  // count 0x192 = 402
  bad[kHeaderBytes + 37] = 0x01;
  EXPECT_EQ(check_record(bad, h), RecordError::kCount);
  bad = slot;
  bad[16] = 0xFF;  // payload_bytes beyond the slot
  bad[17] = 0xFF;
  EXPECT_EQ(check_record(bad, h), RecordError::kLength);
  bad = slot;
  bad[6] = 9;
  EXPECT_EQ(check_record(bad, h), RecordError::kKind);
  bad = slot;
  bad[0] = 'X';
  EXPECT_EQ(check_record(bad, h), RecordError::kMagic);
  // A record that does not fit the buffer it is checked in is a length error, never a read past it.
  EXPECT_EQ(check_record(std::span<const std::uint8_t>(slot.data(), n - 1), h), RecordError::kLength);
  // Encoding refuses a count above the capacity and a short slot.
  ScanPoints big = make_scan(1, 1);
  big.count = static_cast<std::uint16_t>(kMaxBeams + 1);
  EXPECT_EQ(encode_scan_record(big, 0, slot), 0u);
  EXPECT_EQ(encode_scan_record(make_scan(1, 10), 0, std::span<std::uint8_t>(slot.data(), 100)), 0u);
}

RingIndexOptions index_options(std::uint64_t slots) {
  RingIndexOptions o;
  o.slots = slots;
  o.robot_id = 3;
  o.live_window = 4;
  o.backfill_rate_hz = 100.0;
  o.backfill_burst = 8;
  return o;
}

const Time t0 = Time::from_ns(1'000'000'000'000);

// Scans first..last written to the ring, all successfully.
void write_scans(RingIndex& idx, std::uint32_t first, std::uint32_t last) {
  for (std::uint32_t s = first; s <= last; ++s) idx.written(RecordKind::kScan, s, true);
}

// A live writer that keeps 10 scans for a matched station but offers one that (re)joins only its newest.
RingIndexOptions rejoin_options() {
  RingIndexOptions o = index_options(64);
  o.live_window = 10;
  o.rejoin_window = 1;
  return o;
}

// A ring whose station confirmed scans 1..5 at t0; then 6..newest were written while `silence` passed
// (`now` is t0 + silence).
std::unique_ptr<RingIndex> confirmed_5_then(const RingIndexOptions& o, std::uint32_t newest, Time& now,
                                            Duration silence) {
  auto idx = std::move(RingIndex::create(o).value());
  write_scans(*idx, 1, 5);
  now = t0;
  EXPECT_EQ(idx->on_confirmation(3, 5, now), Confirmation::kAccepted);
  write_scans(*idx, 6, newest);
  now = now + silence;
  return idx;
}

// `turns` loop turns `step` apart from `now` (advanced), each taking every back-fill due (scans, or poses
// with &RingIndex::next_backfill_pose), at most the burst of 8 a turn: the seqs sent.
using NextBackfill = bool (RingIndex::*)(Time, std::uint64_t&, std::uint32_t&);
std::vector<std::uint32_t> backfill_turns(RingIndex& idx, Time& now, int turns, Duration step,
                                          NextBackfill next = &RingIndex::next_backfill) {
  std::vector<std::uint32_t> sent;
  std::uint64_t slot = 0;
  std::uint32_t seq = 0;
  for (int turn = 0; turn < turns; ++turn) {
    now = now + step;
    idx.start_turn(now);
    int in_turn = 0;
    while ((idx.*next)(now, slot, seq)) {
      sent.push_back(seq);
      ++in_turn;
    }
    EXPECT_LE(in_turn, 8) << "backfill_burst per turn";
  }
  return sent;
}

TEST(RingIndex, FullRingDropsOnlyUnconfirmedScans) {
  auto idx = std::move(RingIndex::create(index_options(16)).value());
  for (std::uint32_t s = 1; s <= 16; ++s) idx->written(RecordKind::kScan, s, true);
  EXPECT_EQ(idx->on_confirmation(3, 10, t0), Confirmation::kAccepted);
  for (std::uint32_t s = 17; s <= 30; ++s) idx->written(RecordKind::kScan, s, true);
  // 14 overwritten: seqs 1..14, of which 11..14 were not confirmed.
  EXPECT_EQ(idx->counters().dropped_unconfirmed, 4u);
  EXPECT_EQ(idx->oldest_scan_seq(), 15u);
  EXPECT_EQ(idx->newest_scan_seq(), 30u);
  const ShadowState st = idx->shadow(t0);
  EXPECT_EQ(st.unconfirmed, 16u);  // 15..30
}

TEST(RingIndex, RefusesUnknownRobotsAndTheFuture) {
  auto idx = std::move(RingIndex::create(index_options(32)).value());
  for (std::uint32_t s = 1; s <= 5; ++s) idx->written(RecordKind::kScan, s, true);
  EXPECT_EQ(idx->on_confirmation(0, 1, t0), Confirmation::kUnknownRobot);
  EXPECT_EQ(idx->on_confirmation(33, 1, t0), Confirmation::kUnknownRobot);
  EXPECT_EQ(idx->on_confirmation(4, 1, t0), Confirmation::kOtherRobot);
  EXPECT_EQ(idx->on_confirmation(3, 6, t0), Confirmation::kFuture);
  EXPECT_EQ(idx->counters().confirmations_unknown_robot, 2u);
  EXPECT_EQ(idx->counters().confirmations_future, 1u);
  EXPECT_EQ(idx->counters().confirmations, 0u);
  EXPECT_FALSE(idx->shadow(t0).ever_confirmed);
  EXPECT_EQ(idx->on_confirmation(3, 5, t0), Confirmation::kAccepted);
  EXPECT_EQ(idx->shadow(t0).unconfirmed, 0u);
}

TEST(RingIndex, BackfillsWhatIsNotConfirmedInOrderAtTheRate) {
  auto idx = std::move(RingIndex::create(index_options(64)).value());
  for (std::uint32_t s = 1; s <= 10; ++s) {
    idx->written(RecordKind::kScan, s, true);
    idx->written(RecordKind::kPose, s, true);
  }
  Time now = t0;
  ASSERT_EQ(idx->on_confirmation(3, 2, now), Confirmation::kAccepted);
  // Shadow: no confirmation for longer than reachable_timeout; 30 more scans.
  for (std::uint32_t s = 11; s <= 40; ++s) idx->written(RecordKind::kScan, s, true);
  now = now + std::chrono::seconds(10);
  idx->start_turn(now);
  std::uint64_t slot = 0;
  std::uint32_t seq = 0;
  EXPECT_FALSE(idx->next_backfill(now, slot, seq));  // not reachable
  ShadowState st = idx->shadow(now);
  EXPECT_FALSE(st.reachable);
  EXPECT_EQ(st.shadow_since, t0);
  EXPECT_EQ(st.unconfirmed, 38u);
  // The station is back at seq 2: back-fill 3..36 (37..40 are the live window), 8 per turn at most.
  ASSERT_EQ(idx->on_confirmation(3, 2, now), Confirmation::kAccepted);
  EXPECT_EQ(idx->shadow(now).backfill_total, 34u);
  EXPECT_EQ(idx->shadow(now).last_shadow, std::chrono::seconds(10));
  std::vector<std::uint32_t> sent;
  for (int turn = 0; turn < 10; ++turn) {
    now = now + std::chrono::milliseconds(100);  // 100 Hz: 10 tokens a turn, the burst caps at 8
    idx->start_turn(now);
    int in_turn = 0;
    while (idx->next_backfill(now, slot, seq)) {
      sent.push_back(seq);
      ++in_turn;
    }
    EXPECT_LE(in_turn, 8);
    ASSERT_EQ(idx->on_confirmation(3, sent.empty() ? 2 : sent.back(), now), Confirmation::kAccepted);
  }
  ASSERT_EQ(sent.size(), 34u);
  for (std::size_t i = 0; i < sent.size(); ++i) EXPECT_EQ(sent[i], 3 + i);
  EXPECT_EQ(idx->shadow(now).backfill_remaining, 0u);
}

TEST(RingIndex, AfterAShadowTheBackfillTakesAllButTheLiveWritersRejoinWindow) {
  // The live writer offers a returning station only its newest scan (late-joiner depth 1): at the return
  // the back-fill takes everything below it at once, not only what is below the live window.
  const RingIndexOptions o = rejoin_options();
  Time now;
  auto idx = confirmed_5_then(o, 30, now, std::chrono::seconds(10));
  ASSERT_EQ(idx->on_confirmation(3, 5, now), Confirmation::kAccepted);
  EXPECT_EQ(idx->shadow(now).backfill_total, 24u);  // 6..29; 30 comes live
  const std::vector<std::uint32_t> sent = backfill_turns(*idx, now, 10, std::chrono::milliseconds(100));
  ASSERT_EQ(sent.size(), 24u);
  EXPECT_EQ(sent.front(), 6u);
  EXPECT_EQ(sent.back(), 29u);
  // The first contact is no return: with rejoin_window = 1, a station heard for the first time still
  // gets the live window live (nothing below it is back-filled twice).
  auto fresh = std::move(RingIndex::create(o).value());
  write_scans(*fresh, 1, 30);
  ASSERT_EQ(fresh->on_confirmation(3, 25, t0), Confirmation::kAccepted);
  EXPECT_EQ(fresh->shadow(t0).backfill_total, 0u);
}

TEST(RingIndex, AStationThatMatchesAgainWithinTheTimeoutGetsWhatTheLiveWriterNoLongerOffers) {
  // The station restarts in two seconds: its confirmations never lapse for reachable_timeout, so no
  // return is seen from them; but its new reader got only the live writer's newest scan, and the scans
  // published while it was down are the back-fill's.
  const RingIndexOptions o = rejoin_options();
  Time now;
  auto idx = confirmed_5_then(o, 12, now, std::chrono::seconds(2));
  EXPECT_TRUE(backfill_turns(*idx, now, 1, Duration{0}).empty()) << "all within the live window: the live writer's";
  idx->on_live_reader_matched(now);
  ASSERT_EQ(idx->on_confirmation(3, 5, now), Confirmation::kAccepted);  // the restarted station, from its session
  const std::vector<std::uint32_t> sent = backfill_turns(*idx, now, 10, std::chrono::milliseconds(100));
  ASSERT_EQ(sent.size(), 6u);  // 6..11; 12 came live
  EXPECT_EQ(sent.front(), 6u);
  EXPECT_EQ(sent.back(), 11u);
}

TEST(RingIndex, ResendsWhenTheConfirmationsDoNotFollow) {
  auto idx = std::move(RingIndex::create(index_options(64)).value());
  for (std::uint32_t s = 1; s <= 20; ++s) idx->written(RecordKind::kScan, s, true);
  Time now = t0;
  ASSERT_EQ(idx->on_confirmation(3, 5, now), Confirmation::kAccepted);
  std::uint64_t slot = 0;
  std::uint32_t seq = 0;
  now = now + std::chrono::seconds(1);
  idx->start_turn(now);
  ASSERT_TRUE(idx->next_backfill(now, slot, seq));
  EXPECT_EQ(seq, 6u);
  // The station keeps confirming 5 (the back-filled 6 got lost): after resend_after, 6 again.
  for (int i = 0; i < 6; ++i) {
    now = now + std::chrono::seconds(1);
    ASSERT_EQ(idx->on_confirmation(3, 5, now), Confirmation::kAccepted);
  }
  idx->start_turn(now);
  bool again = false;
  while (idx->next_backfill(now, slot, seq)) again = again || seq == 6;
  EXPECT_TRUE(again);
  EXPECT_EQ(idx->counters().backfill_rewinds, 1u);
}

TEST(RingIndex, TheBackfillStaysWithinItsWindowAboveTheConfirmation) {
  // A slow link: the back-fill sends at most backfill_window scans above what the station confirmed, so
  // none is pushed out of the back-fill writer's history before the station has it; each confirmation
  // opens the window by as much as it moved.
  RingIndexOptions o = index_options(256);
  o.backfill_window = 20;
  o.backfill_rate_hz = 1000.0;
  Time now;
  auto idx = confirmed_5_then(o, 200, now, std::chrono::seconds(10));
  ASSERT_EQ(idx->on_confirmation(3, 5, now), Confirmation::kAccepted);  // back after a shadow
  constexpr auto kTurn = std::chrono::milliseconds(10);
  std::vector<std::uint32_t> sent = backfill_turns(*idx, now, 20, kTurn);
  ASSERT_EQ(sent.size(), 20u);  // 6..25, then it waits for the station
  EXPECT_EQ(sent.back(), 25u);
  ASSERT_EQ(idx->on_confirmation(3, 15, now), Confirmation::kAccepted);
  sent = backfill_turns(*idx, now, 20, kTurn);
  ASSERT_EQ(sent.size(), 10u);  // 26..35
  EXPECT_EQ(sent.front(), 26u);
  EXPECT_EQ(sent.back(), 35u);
  // 16 never arrives: after resend_after without progress, the window is sent again from 16, no further.
  for (int i = 0; i < 3; ++i) {
    now = now + std::chrono::seconds(1);
    ASSERT_EQ(idx->on_confirmation(3, 15, now), Confirmation::kAccepted);
  }
  sent = backfill_turns(*idx, now, 20, kTurn);
  ASSERT_EQ(sent.size(), 20u);
  EXPECT_EQ(sent.front(), 16u);
  EXPECT_EQ(sent.back(), 35u);
  EXPECT_EQ(idx->counters().backfill_rewinds, 1u);
}

TEST(RingIndex, AnOldConfirmationIsNoContact) {
  auto idx = std::move(RingIndex::create(index_options(64)).value());
  for (std::uint32_t s = 1; s <= 20; ++s) idx->written(RecordKind::kScan, s, true);
  // A restarted robot receives the station's last confirmation (transient-local), published long ago.
  ASSERT_EQ(idx->on_confirmation(3, 5, t0, false), Confirmation::kAccepted);
  ShadowState st = idx->shadow(t0);
  EXPECT_TRUE(st.ever_confirmed);
  EXPECT_FALSE(st.reachable);
  EXPECT_EQ(st.confirmed_seq, 5u);
  idx->start_turn(t0);
  std::uint64_t slot = 0;
  std::uint32_t seq = 0;
  EXPECT_FALSE(idx->next_backfill(t0, slot, seq));
  // A fresh one: the station is there, the back-fill starts after 5.
  ASSERT_EQ(idx->on_confirmation(3, 5, t0 + std::chrono::seconds(1)), Confirmation::kAccepted);
  idx->start_turn(t0 + std::chrono::seconds(1));
  ASSERT_TRUE(idx->next_backfill(t0 + std::chrono::seconds(1), slot, seq));
  EXPECT_EQ(seq, 6u);
}

// Pose back-fill turns (backfill_turns).
std::vector<std::uint32_t> pose_backfill_turns(RingIndex& idx, Time& now, int turns, Duration step) {
  return backfill_turns(idx, now, turns, step, &RingIndex::next_backfill_pose);
}

TEST(RingIndex, BackfillsThePosesBelowTheLivePoseHistoryThatTheStationLacks) {
  RingIndexOptions o = index_options(256);
  o.pose_live_window = 10;
  auto idx = std::move(RingIndex::create(o).value());
  for (std::uint32_t s = 1; s <= 5; ++s) {
    idx->written(RecordKind::kScan, s, true);
    idx->written(RecordKind::kPose, s, true);
  }
  Time now = t0;
  ASSERT_EQ(idx->on_confirmation(3, 5, now, true, 5), Confirmation::kAccepted);
  EXPECT_EQ(idx->pose_confirmed_seq(), 5u);
  // A shadow of 10 s: poses 6..60 written (and their scans).
  for (std::uint32_t s = 6; s <= 60; ++s) {
    idx->written(RecordKind::kPose, s, true);
    idx->written(RecordKind::kScan, s, true);
  }
  now = now + std::chrono::seconds(10);
  std::vector<std::uint32_t> sent = pose_backfill_turns(*idx, now, 1, Duration{0});
  EXPECT_TRUE(sent.empty()) << "not reachable: nothing is sent";
  ASSERT_EQ(idx->on_confirmation(3, 5, now, true, 5), Confirmation::kAccepted);  // back
  sent = pose_backfill_turns(*idx, now, 10, std::chrono::milliseconds(100));
  // 6..50: the newest 10 are the live pose writer's; in order, each once.
  ASSERT_EQ(sent.size(), 45u);
  for (std::size_t i = 0; i < sent.size(); ++i) EXPECT_EQ(sent[i], 6 + i);
  EXPECT_EQ(idx->counters().poses_backfilled, 45u);
  // The station stored them all (and the live history): nothing more, even after resend_after.
  ASSERT_EQ(idx->on_confirmation(3, 60, now, true, 60), Confirmation::kAccepted);
  now = now + std::chrono::seconds(3);
  ASSERT_EQ(idx->on_confirmation(3, 60, now, true, 60), Confirmation::kAccepted);
  EXPECT_TRUE(pose_backfill_turns(*idx, now, 5, std::chrono::milliseconds(100)).empty());
}

TEST(RingIndex, APoseLostOnTheWayIsSentAgainAndAPoseFromTheFutureIsRefused) {
  RingIndexOptions o = index_options(256);
  o.pose_live_window = 4;
  auto idx = std::move(RingIndex::create(o).value());
  for (std::uint32_t s = 1; s <= 30; ++s) idx->written(RecordKind::kPose, s, true);
  idx->written(RecordKind::kScan, 1, true);
  Time now = t0;
  // A confirmation of a pose this robot never wrote: counted, the pose confirmation unchanged.
  ASSERT_EQ(idx->on_confirmation(3, 1, now, true, 31), Confirmation::kAccepted);
  EXPECT_EQ(idx->counters().pose_confirmations_future, 1u);
  EXPECT_EQ(idx->pose_confirmed_seq(), 0u);
  EXPECT_TRUE(pose_backfill_turns(*idx, now, 1, Duration{0}).empty()) << "no pose confirmed: none back-filled";
  ASSERT_EQ(idx->on_confirmation(3, 1, now, true, 10), Confirmation::kAccepted);
  std::vector<std::uint32_t> sent = pose_backfill_turns(*idx, now, 5, std::chrono::milliseconds(100));
  ASSERT_EQ(sent.size(), 16u);  // 11..26
  EXPECT_EQ(sent.front(), 11u);
  EXPECT_EQ(sent.back(), 26u);
  // 12 never arrived: the station stays at 11; after resend_after the poses go again from 12.
  for (int i = 0; i < 3; ++i) {
    now = now + std::chrono::seconds(1);
    ASSERT_EQ(idx->on_confirmation(3, 1, now, true, 11), Confirmation::kAccepted);
  }
  sent = pose_backfill_turns(*idx, now, 5, std::chrono::milliseconds(100));
  ASSERT_FALSE(sent.empty());
  EXPECT_EQ(sent.front(), 12u);
  EXPECT_EQ(sent.back(), 26u);
  EXPECT_EQ(idx->counters().backfill_rewinds, 1u);
}

// A ring file in the test's temporary folder, removed at the end.
struct TempRing {
  std::string path;
  RingConfig config;
  explicit TempRing(const char* name, double capacity_s) {
    path = testing::TempDir() + "/" + name + "-" + std::to_string(::getpid()) + ".ring";
    std::remove(path.c_str());
    config.path = path;
    config.capacity_s = capacity_s;
    config.flush_records = 4;
  }
  ~TempRing() { std::remove(path.c_str()); }
};

TEST(ScanRing, RecordsSurviveARestart) {
  TempRing t("restart", 1.0);  // 85 slots
  {
    auto ring = ScanRing::open(t.config, 3, 4);
    ASSERT_TRUE(ring.ok()) << ring.error().what;
    EXPECT_TRUE(ring.value()->created());
    for (std::uint32_t s = 1; s <= 30; ++s) {
      ASSERT_TRUE(ring.value()->append_scan(make_scan(s, static_cast<std::uint16_t>(s * 13 % 402)), t0).ok());
      OnboardPose p{3, s, t0.ns(), 1, 2, 3, 4, 5, 6};
      ASSERT_TRUE(ring.value()->append_pose(p, t0).ok());
    }
    // No flush: the page cache holds the records for a restarted process (a power cut would not).
  }
  auto ring = ScanRing::open(t.config, 3, 4);
  ASSERT_TRUE(ring.ok());
  const RingIndex& idx = ring.value()->index();
  EXPECT_EQ(idx.counters().recovered_scans, 30u);
  EXPECT_EQ(idx.counters().recovered_poses, 30u);
  EXPECT_EQ(idx.counters().recovered_empty, 85u - 60u);
  EXPECT_EQ(idx.counters().torn, 0u);
  EXPECT_EQ(idx.newest_scan_seq(), 30u);
  EXPECT_EQ(idx.newest_pose_seq(), 30u);
  EXPECT_EQ(idx.oldest_scan_seq(), 1u);
  // What it back-fills is what was written.
  Time now = t0;
  ASSERT_EQ(ring.value()->on_confirmation(3, 10, now, true, 25), Confirmation::kAccepted);
  ring.value()->start_turn(now + std::chrono::seconds(1));
  ScanPoints out;
  ASSERT_TRUE(ring.value()->next_backfill(now + std::chrono::seconds(1), out));
  expect_same(out, make_scan(11, 11 * 13 % 402));
  // The poses written before the restart are in no live writer's history now: all of them are
  // back-filled, the newest too, though they lie within the live pose history's depth.
  std::vector<std::uint32_t> poses;
  OnboardPose pose{};
  while (ring.value()->next_backfill_pose(now + std::chrono::seconds(1), pose)) poses.push_back(pose.seq);
  EXPECT_EQ(poses, (std::vector<std::uint32_t>{26, 27, 28, 29, 30}));
}

TEST(ScanRing, BackfilledPosesAreTheOnesWritten) {
  TempRing t("poses", 1.0);
  auto ring = ScanRing::open(t.config, 3, 4);
  ASSERT_TRUE(ring.ok()) << ring.error().what;
  for (std::uint32_t s = 1; s <= kPoseHistoryDepth + 20; ++s) {
    const OnboardPose p{3, s, t0.ns() + s, static_cast<std::int32_t>(s), -2, 3, 4, 5, 6};
    ASSERT_TRUE(ring.value()->append_pose(p, t0).ok());
  }
  Time now = t0;
  ASSERT_EQ(ring.value()->on_confirmation(3, 0, now, true, 10), Confirmation::kAccepted);
  now = now + std::chrono::milliseconds(100);
  ring.value()->start_turn(now);
  OnboardPose out{};
  ASSERT_TRUE(ring.value()->next_backfill_pose(now, out));
  EXPECT_EQ(out.robot_id, 3u);
  EXPECT_EQ(out.seq, 11u);
  EXPECT_EQ(out.stamp_ns, t0.ns() + 11);
  EXPECT_EQ(out.x_mm, 11);
  EXPECT_EQ(out.y_mm, -2);
  EXPECT_EQ(out.yaw_rate_mradps, 6);
}

TEST(ScanRing, TornRecordsAreCountedAndSkipped) {
  TempRing t("torn", 1.0);
  {
    auto ring = ScanRing::open(t.config, 3, 4);
    ASSERT_TRUE(ring.ok());
    for (std::uint32_t s = 1; s <= 20; ++s) ASSERT_TRUE(ring.value()->append_scan(make_scan(s, 361), t0).ok());
    ASSERT_TRUE(ring.value()->flush().ok());
  }
  // A power cut in the middle of two writes: slot 7's record is half written (its tail zero), slot 12's
  // header is there but its payload is of an older record (one flipped byte).
  const int fd = ::open(t.path.c_str(), O_RDWR);
  ASSERT_GE(fd, 0);
  std::vector<std::uint8_t> zeros(3000, 0);
  ASSERT_EQ(::pwrite(fd, zeros.data(), zeros.size(), static_cast<off_t>(7 * kSlotBytes + 3000)), 3000);
  std::uint8_t b = 0;
  ASSERT_EQ(::pread(fd, &b, 1, static_cast<off_t>(12 * kSlotBytes + 100)), 1);
  b ^= 0x40;
  ASSERT_EQ(::pwrite(fd, &b, 1, static_cast<off_t>(12 * kSlotBytes + 100)), 1);
  ::close(fd);
  auto ring = ScanRing::open(t.config, 3, 4);
  ASSERT_TRUE(ring.ok());
  const RingIndex& idx = ring.value()->index();
  EXPECT_EQ(idx.counters().torn, 2u);
  EXPECT_EQ(idx.counters().recovered_scans, 18u);
  EXPECT_EQ(idx.newest_scan_seq(), 20u);
  // Back-filling from 0 skips the two torn scans (seqs 8 and 13) and sends the 18 others, the newest too:
  // they were written before the restart, so no live writer of this process offers them.
  Time now = t0;
  ASSERT_EQ(ring.value()->on_confirmation(3, 0, now), Confirmation::kAccepted);
  std::vector<std::uint32_t> sent;
  ScanPoints out;
  for (int turn = 0; turn < 10; ++turn) {
    now = now + std::chrono::milliseconds(100);
    ring.value()->start_turn(now);
    while (ring.value()->next_backfill(now, out)) sent.push_back(out.seq);
  }
  std::vector<std::uint32_t> want;
  for (std::uint32_t s = 1; s <= 20; ++s)
    if (s != 8 && s != 13) want.push_back(s);
  EXPECT_EQ(sent, want);
}

TEST(ScanRing, AWrappedRingRecoversItsOrder) {
  TempRing t("wrap", 1.0);  // 85 slots
  {
    auto ring = ScanRing::open(t.config, 3, 4);
    ASSERT_TRUE(ring.ok());
    for (std::uint32_t s = 1; s <= 200; ++s) ASSERT_TRUE(ring.value()->append_scan(make_scan(s, 5), t0).ok());
    EXPECT_EQ(ring.value()->index().counters().dropped_unconfirmed, 200u - 85u);
  }
  auto ring = ScanRing::open(t.config, 3, 4);
  ASSERT_TRUE(ring.ok());
  const RingIndex& idx = ring.value()->index();
  EXPECT_EQ(idx.counters().recovered_scans, 85u);
  EXPECT_EQ(idx.newest_scan_seq(), 200u);
  EXPECT_EQ(idx.oldest_scan_seq(), 116u);
  EXPECT_EQ(idx.next_ring_seq(), 200u);
  // The next record continues the ring (overwrites the oldest).
  ASSERT_TRUE(ring.value()->append_scan(make_scan(201, 5), t0).ok());
  EXPECT_EQ(idx.oldest_scan_seq(), 117u);
}

TEST(ScanRing, AnotherRobotsRingIsNotTaken) {
  TempRing t("foreign", 1.0);
  {
    auto ring = ScanRing::open(t.config, 3, 4);
    ASSERT_TRUE(ring.ok());
    for (std::uint32_t s = 1; s <= 5; ++s) ASSERT_TRUE(ring.value()->append_scan(make_scan(s, 5), t0).ok());
  }
  auto ring = ScanRing::open(t.config, 4, 4);
  ASSERT_TRUE(ring.ok());
  EXPECT_EQ(ring.value()->index().counters().foreign, 5u);
  EXPECT_EQ(ring.value()->index().counters().recovered_scans, 0u);
}

TEST(ScanRing, FlushPolicy) {
  TempRing t("flush", 1.0);
  t.config.flush_records = 3;
  t.config.flush_period = std::chrono::milliseconds(200);
  auto ring = ScanRing::open(t.config, 3, 4);
  ASSERT_TRUE(ring.ok());
  ScanRing& r = *ring.value();
  ASSERT_TRUE(r.append_scan(make_scan(1, 5), t0).ok());
  ASSERT_TRUE(r.flush_if_due(t0 + std::chrono::milliseconds(100)).ok());
  EXPECT_EQ(r.flush_counters().flushes, 0u);
  ASSERT_TRUE(r.flush_if_due(t0 + std::chrono::milliseconds(200)).ok());  // the period
  EXPECT_EQ(r.flush_counters().flushes, 1u);
  for (std::uint32_t s = 2; s <= 4; ++s) ASSERT_TRUE(r.append_scan(make_scan(s, 5), t0).ok());
  ASSERT_TRUE(r.flush_if_due(t0).ok());  // the count
  EXPECT_EQ(r.flush_counters().flushes, 2u);
  EXPECT_EQ(r.flush_counters().unflushed, 0u);
}

TEST(ScanRing, AMissingFolderIsAnError) {
  RingConfig c;
  c.path = "/nonexistent-folder-of-teamscan/ring.bin";
  auto ring = ScanRing::open(c, 3, 4);
  ASSERT_FALSE(ring.ok());
  EXPECT_NE(ring.error().sys_errno, 0);
}

}  // namespace
}  // namespace teamscan::onboard::ring
