// dds/: topics by generated type, the participant's ownership, and the one take loop (batches, every
// sample once, invalid samples handed on), over loopback DDS in one process.
#include <gtest/gtest.h>

#include <dirent.h>
#include <sched.h>

#include <chrono>
#include <cstdio>
#include <string>
#include <cstring>
#include <thread>
#include <vector>

#include "dds/participant.hpp"
#include "dds/qos.hpp"
#include "dds/receive_threads.hpp"
#include "dds/take.hpp"
#include "dds/topics.hpp"
#include "tests/support/test_domain.hpp"

namespace teamscan::dds {
namespace {

TEST(DdsTopics, EachTypeHasItsOneName) {
  EXPECT_STREQ(TopicOf<teamscan_msg_RobotPose>::name, "teamscan/pose");
  EXPECT_STREQ(TopicOf<teamscan_msg_ScanPoints>::name, "teamscan/scan");
  EXPECT_STREQ(TopicOf<teamscan_msg_RobotStatus>::name, "teamscan/status");
  EXPECT_STREQ(TopicOf<teamscan_msg_TeamState>::name, "teamscan/team");
  EXPECT_STREQ(TopicOf<teamscan_msg_MapUpdate>::name, "teamscan/map");
  EXPECT_EQ(TopicOf<teamscan_msg_RobotPose>::descriptor(), &teamscan_msg_RobotPose_desc);
  EXPECT_EQ(TopicOf<teamscan_msg_ScanPoints>::descriptor(), &teamscan_msg_ScanPoints_desc);
}

// The scheduling policy of each thread of this process whose name starts with `prefix`.
std::vector<int> policies_of_threads(const char* prefix) {
  std::vector<int> out;
  DIR* d = ::opendir("/proc/self/task");
  if (d == nullptr) return out;
  while (const dirent* e = ::readdir(d)) {
    if (e->d_name[0] == '.') continue;
    std::FILE* f = std::fopen((std::string("/proc/self/task/") + e->d_name + "/comm").c_str(), "r");
    if (f == nullptr) continue;
    char comm[32] = {};
    const bool ok = std::fgets(comm, sizeof comm, f) != nullptr;
    std::fclose(f);
    if (ok && std::strncmp(comm, prefix, std::strlen(prefix)) == 0) out.push_back(::sched_getscheduler(std::stoi(e->d_name)));
  }
  ::closedir(d);
  return out;
}

TEST(DdsReceiveThreads, CycloneReceiveThreadsBecomeBatchTheOthersKeepTheirPolicy) {
  const std::vector<int> threads_before = thread_ids();
  Result<Participant> p = Participant::create(test::test_domain_id());
  ASSERT_TRUE(p.ok()) << p.error().what;
  // Cyclone's new threads name themselves once they run (later, on a loaded machine): the call waits.
  const ReceiveThreads r = batch_receive_threads(threads_before);
  EXPECT_EQ(r.unnamed, 0u);
  ASSERT_GE(r.found, 1u) << "Cyclone names its receive threads recv*";
  EXPECT_EQ(r.batched, r.found);
  EXPECT_EQ(policies_of_threads("recv").size(), r.found);
  for (int policy : policies_of_threads("recv")) EXPECT_EQ(policy, SCHED_BATCH);
  // This thread (the caller's loop) and Cyclone's others (tev: heartbeats and acks) are untouched.
  EXPECT_EQ(::sched_getscheduler(0), SCHED_OTHER);
  for (int policy : policies_of_threads("tev")) EXPECT_EQ(policy, SCHED_OTHER);
}

TEST(DdsParticipant, OwnsItsHandleAndMoves) {
  Result<Participant> p = Participant::create(test::test_domain_id());
  ASSERT_TRUE(p.ok()) << p.error().what;
  const dds_entity_t h = p->handle();
  EXPECT_GT(h, 0);
  Participant moved = std::move(p.value());
  EXPECT_EQ(moved.handle(), h);
  EXPECT_FALSE(p->valid());
  moved.reset();
  EXPECT_FALSE(moved.valid());
  // The entity is gone: Cyclone refuses it.
  EXPECT_LT(dds_get_parent(h), 0);
}

TEST(DdsParticipant, NoTopicWithoutAParticipant) {
  const Participant none;
  EXPECT_FALSE(none.topic<teamscan_msg_RobotPose>().ok());
}

// A writer and a reader of teamscan/pose on one participant; the reader keeps all.
struct PosePair {
  Participant participant;
  dds_entity_t writer = 0;
  dds_entity_t reader = 0;
};

PosePair make_pair() {
  PosePair pp;
  Result<Participant> p = Participant::create(test::test_domain_id());
  if (!p.ok()) return pp;
  pp.participant = std::move(p.value());
  dds_qos_t* q = make_state_reader_qos();
  Result<dds_entity_t> r = create_reader<teamscan_msg_RobotPose>(pp.participant, q);
  dds_delete_qos(q);
  q = make_scan_writer_qos(1, 100, std::chrono::seconds(2), std::chrono::milliseconds(100));
  Result<dds_entity_t> w = create_writer<teamscan_msg_RobotPose>(pp.participant, q);
  dds_delete_qos(q);
  if (r.ok()) pp.reader = r.value();
  if (w.ok()) pp.writer = w.value();
  return pp;
}

// Takes until `want` samples arrived or 10 s passed.
std::vector<teamscan_msg_RobotPose> take_until(dds_entity_t reader, TakeBuffer<teamscan_msg_RobotPose>& buf,
                                               std::size_t want, std::size_t* batches, std::size_t* invalid) {
  std::vector<teamscan_msg_RobotPose> got;
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(10);
  while (got.size() < want && std::chrono::steady_clock::now() < deadline) {
    (void)take_all(
        reader, buf, [&] { ++*batches; },
        [&](const teamscan_msg_RobotPose& s, const dds_sample_info_t& info) {
          if (info.valid_data) got.push_back(s); else ++*invalid;
        });
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  return got;
}

// What a reader that joins late gets of a scan-QoS writer's history: all of it, or only the newest
// late_joiner_depth samples (a robot with a ring: its back-fill sends the rest, docs/radio.md).
std::size_t late_joiner_gets(std::uint32_t late_joiner_depth) {
  Result<Participant> p = Participant::create(test::test_domain_id());
  if (!p.ok()) return 0;
  dds_qos_t* q = make_scan_writer_qos(1, 20, std::chrono::seconds(2), std::chrono::milliseconds(100), late_joiner_depth);
  Result<dds_entity_t> w = create_writer<teamscan_msg_RobotPose>(p.value(), q);
  dds_delete_qos(q);
  if (!w.ok()) return 0;
  for (std::uint32_t seq = 1; seq <= 10; ++seq) {
    teamscan_msg_RobotPose s{};
    s.robot_id = 1;
    s.seq = seq;
    if (dds_write(w.value(), &s) != DDS_RETCODE_OK) return 0;
  }
  q = make_state_reader_qos();
  Result<dds_entity_t> r = create_reader<teamscan_msg_RobotPose>(p.value(), q);
  dds_delete_qos(q);
  if (!r.ok()) return 0;
  TakeBuffer<teamscan_msg_RobotPose> buf(16);
  std::size_t got = 0;
  // The history arrives at once (in-process); 1 s is ample for all 10 to show up when offered.
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(1);
  while (got < 10 && std::chrono::steady_clock::now() < deadline) {
    (void)take_all(
        r.value(), buf, [] {}, [&](const teamscan_msg_RobotPose&, const dds_sample_info_t& info) { got += info.valid_data ? 1 : 0; });
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  return got;
}

TEST(DdsQos, ALateJoinerGetsTheNewestLateJoinerDepthSamples) {
  EXPECT_EQ(late_joiner_gets(0), 10u);  // the whole history (depth 20)
  EXPECT_EQ(late_joiner_gets(1), 1u);
}

TEST(DdsTake, EverySampleOnceInBatchesOfTheBufferSize) {
  PosePair pp = make_pair();
  ASSERT_GT(pp.reader, 0);
  ASSERT_GT(pp.writer, 0);
  // 10 robots (10 instances), 2 samples each, with a buffer of 3: several dds_takes per take_all.
  for (std::uint32_t seq = 0; seq < 2; ++seq) {
    for (std::uint32_t id = 1; id <= 10; ++id) {
      teamscan_msg_RobotPose s{};
      s.robot_id = id;
      s.seq = seq;
      ASSERT_EQ(dds_write(pp.writer, &s), DDS_RETCODE_OK);
    }
  }
  TakeBuffer<teamscan_msg_RobotPose> buf(3);
  EXPECT_EQ(buf.capacity(), 3u);
  std::size_t batches = 0, invalid = 0;
  const std::vector<teamscan_msg_RobotPose> got = take_until(pp.reader, buf, 20, &batches, &invalid);
  ASSERT_EQ(got.size(), 20u);
  EXPECT_GE(batches, 7u);  // at least ceil(20 / 3)
  EXPECT_EQ(invalid, 0u);
  std::vector<int> seen(10 * 2, 0);
  for (const auto& s : got) {
    ASSERT_GE(s.robot_id, 1u);
    ASSERT_LE(s.robot_id, 10u);
    ASSERT_LT(s.seq, 2u);
    ++seen[(s.robot_id - 1) * 2 + s.seq];
  }
  for (int n : seen) EXPECT_EQ(n, 1);
  // Empty now: no batch, nothing taken.
  std::size_t after = 0;
  EXPECT_EQ(take_all(pp.reader, buf, [&] { ++after; }, [](const auto&, const auto&) {}), 0u);
  EXPECT_EQ(after, 0u);
}

TEST(DdsTake, ADisposeIsHandedOnAsAnInvalidSample) {
  PosePair pp = make_pair();
  ASSERT_GT(pp.reader, 0);
  teamscan_msg_RobotPose s{};
  s.robot_id = 7;
  ASSERT_EQ(dds_write(pp.writer, &s), DDS_RETCODE_OK);
  TakeBuffer<teamscan_msg_RobotPose> buf(4);
  std::size_t batches = 0, invalid = 0;
  ASSERT_EQ(take_until(pp.reader, buf, 1, &batches, &invalid).size(), 1u);
  ASSERT_EQ(dds_dispose(pp.writer, &s), DDS_RETCODE_OK);
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(10);
  std::uint32_t state = 0;
  while (invalid == 0 && std::chrono::steady_clock::now() < deadline) {
    (void)take_all(pp.reader, buf, [] {}, [&](const teamscan_msg_RobotPose&, const dds_sample_info_t& info) {
      if (!info.valid_data) {
        ++invalid;
        state = info.instance_state;
      }
    });
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  EXPECT_EQ(invalid, 1u);
  EXPECT_EQ(state, static_cast<std::uint32_t>(DDS_NOT_ALIVE_DISPOSED_INSTANCE_STATE));
}

}  // namespace
}  // namespace teamscan::dds
