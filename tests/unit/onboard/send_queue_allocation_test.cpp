// Firmware discipline (STYLE.md 5) for the send queue: once created, handing it 20 000 scans, poses and
// statuses allocates nothing on the daemon's thread, whether the queue has room or is full (tests/support
// alloc counter, per thread: the writer underneath here allocates nothing either, checked process-wide).
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <cstdio>
#include <ctime>
#include <thread>

#include "onboard/daemon/send_queue.hpp"
#include "tests/support/alloc_counter.hpp"

namespace teamscan::onboard {
namespace {

// Counts what it is given; optionally slow, so that the queue fills.
class CountingPublisher final : public Publisher {
 public:
  explicit CountingPublisher(std::atomic<std::uint64_t>& n, std::atomic<bool>& slow) : n_{n}, slow_{slow} {}
  Status publish_pose(const OnboardPose&) override { return count(); }
  Status publish_scan(const ScanPoints&) override { return count(); }
  Status publish_status(const OnboardStatus&) override { return count(); }
  bool take_team(TeamSnapshot&) override { return false; }
  const char* name() const override { return "counting"; }

 private:
  Status count() {
    while (slow_.load()) {
      // A link that blocks: spin with a short sleep (nanosleep allocates nothing).
      timespec ts{0, 1'000'000};
      ::nanosleep(&ts, nullptr);
    }
    n_.fetch_add(1);
    return ok_status();
  }
  std::atomic<std::uint64_t>& n_;
  std::atomic<bool>& slow_;
};

TEST(SendQueueAllocation, CounterIsLinkedIn) { EXPECT_TRUE(test::alloc_counter_active()); }

TEST(SendQueueAllocation, PublishingAllocatesNothingWithRoomOrFull) {
  std::atomic<std::uint64_t> written{0};
  std::atomic<bool> slow{false};
  auto q = SendQueue::create(std::make_unique<CountingPublisher>(written, slow));
  ASSERT_TRUE(q.ok()) << q.error().what;
  Publisher& pub = *q.value();
  static ScanPoints scan;
  scan.count = 361;
  OnboardPose pose;
  OnboardStatus status;

  const test::AllocStats process_before = test::process_alloc_stats();
  test::AllocScope scope;
  std::uint64_t accepted = 0;
  for (std::uint32_t k = 0; k < 20'000; ++k) {
    if (k == 5'000) slow.store(true);   // the link goes down: the queue fills and refuses
    if (k == 8'000) slow.store(false);  // and comes back
    scan.seq = k;
    if (pub.publish_scan(scan).ok()) ++accepted;
    if (k % 8 == 0 && pub.publish_pose(pose).ok()) ++accepted;
    if (k % 100 == 0 && pub.publish_status(status).ok()) ++accepted;
    if (k % 50 == 0) std::this_thread::yield();
  }
  const test::AllocStats ours = scope.delta();
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(30);
  while (written.load() < accepted && std::chrono::steady_clock::now() < deadline) {
    timespec ts{0, 1'000'000};
    ::nanosleep(&ts, nullptr);
  }
  const test::AllocStats all = test::process_alloc_stats() - process_before;
  EXPECT_EQ(ours.allocs, 0u);
  EXPECT_EQ(all.allocs, 0u);  // the sender thread's loop allocates nothing either
  EXPECT_EQ(written.load(), accepted);
  EXPECT_GT(pub.health().refused, 0u);  // the full queue was exercised
  std::printf("send queue: %llu of %u messages accepted, %llu refused while the link was down, max %u waiting\n",
              static_cast<unsigned long long>(accepted), 20'000u + 2'500u + 200u,
              static_cast<unsigned long long>(pub.health().refused), pub.health().high_water);
}

}  // namespace
}  // namespace teamscan::onboard
