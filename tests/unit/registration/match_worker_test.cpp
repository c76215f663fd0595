// MatchWorker: the registration's match thread runs jobs in the order given, where it is placed, and
// a caller's wait returns once its job (and every earlier one) has run.
#include <gtest/gtest.h>

#include <atomic>
#include <cerrno>
#include <chrono>
#include <memory>
#include <thread>
#include <vector>

#include "common/thread_placement.hpp"
#include "groundstation/registration/match_worker.hpp"

namespace teamscan::registration {
namespace {

TEST(MatchWorker, RunsJobsInOrderAndAWaitReturnsOnceItsJobRan) {
  MatchWorker w;
  std::vector<int> order;  // written by the worker only, read after a wait
  std::atomic<int> ran{0};
  std::uint64_t tenth = 0;
  for (int i = 0; i < 50; ++i) {
    const std::uint64_t t = w.submit([&, i] {
      std::this_thread::sleep_for(std::chrono::microseconds(200));
      order.push_back(i);
      ++ran;
    });
    EXPECT_EQ(t, static_cast<std::uint64_t>(i + 1));
    if (i == 9) tenth = t;
  }
  w.wait(tenth);
  EXPECT_GE(ran.load(), 10);
  w.wait_idle();
  ASSERT_EQ(order.size(), 50u);
  for (int i = 0; i < 50; ++i) EXPECT_EQ(order[static_cast<std::size_t>(i)], i);
  EXPECT_GE(w.waits_blocked(), 1u);  // the first wait found its job queued behind 9 others
  w.wait(5);                         // long done: returns at once, not counted
  EXPECT_LE(w.waits_blocked(), 2u);
}

TEST(MatchWorker, TheDestructorRunsWhatIsQueued) {
  std::atomic<int> ran{0};
  {
    MatchWorker w;
    for (int i = 0; i < 20; ++i)
      w.submit([&] {
        std::this_thread::sleep_for(std::chrono::microseconds(500));
        ++ran;
      });
  }
  EXPECT_EQ(ran.load(), 20);
}

TEST(MatchWorker, TheThreadRunsOnItsCpusTheCallerKeepsItsOwn) {
  const std::vector<int> mine = current_thread_cpus();
  ASSERT_FALSE(mine.empty());
  const int cpu = mine.back();
  MatchWorker w({cpu});
  const ThreadScheduling s = w.scheduling();
  EXPECT_EQ(s.affinity_error, 0);
  EXPECT_EQ(s.cpus, std::vector<int>{cpu});
  EXPECT_EQ(current_thread_cpus(), mine);
  // A set with no usable CPU is refused; the thread stays where the caller's threads may run.
  MatchWorker refused({1023});
  EXPECT_EQ(refused.scheduling().affinity_error, EINVAL);
  EXPECT_EQ(refused.scheduling().cpus, mine);
}

}  // namespace
}  // namespace teamscan::registration
