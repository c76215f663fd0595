// SendQueue (onboard/daemon/send_queue.hpp): the daemon's writes go out from the queue's thread in the
// order they were handed over, the caller never waits for a writer that blocks, a full queue refuses
// with an error and counts it, back-fill takes at most half, the writer's refusals are counted, the
// reader-match count is read on the sender's thread, and the stop writes what is queued within its
// drain time.
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <functional>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "onboard/daemon/send_queue.hpp"

namespace teamscan::onboard {
namespace {

using namespace std::chrono_literals;

// What reached the writer underneath, shared with the test (the queue owns the publisher).
struct Written {
  std::mutex m;
  std::condition_variable cv;
  bool open = true;                 // writes wait while false
  std::chrono::milliseconds each{0};
  bool fail = false;
  std::vector<std::string> log;     // "pose 3", "scan 7", "status 1", "backfill 9", "backfill_pose 2"
  std::uint32_t matches = 0;        // the writer's reader-match count (read waits while closed, too)
  std::size_t size() {
    std::lock_guard lock{m};
    return log.size();
  }
  void set_open(bool o) {
    {
      std::lock_guard lock{m};
      open = o;
    }
    cv.notify_all();
  }
};

class GatedPublisher final : public Publisher {
 public:
  explicit GatedPublisher(Written& w) : w_{w} {}
  Status publish_pose(const OnboardPose& p) override { return record("pose", p.seq); }
  Status publish_scan(const ScanPoints& s) override { return record("scan", s.seq); }
  Status publish_status(const OnboardStatus& s) override { return record("status", s.seq); }
  Status publish_backfill(const ScanPoints& s) override { return record("backfill", s.seq); }
  Status publish_backfill_pose(const OnboardPose& p) override { return record("backfill_pose", p.seq); }
  bool take_team(TeamSnapshot&) override { return false; }
  std::uint32_t scan_reader_matches() const override {
    std::unique_lock lock{w_.m};
    w_.cv.wait(lock, [&] { return w_.open; });
    return w_.matches;
  }
  const char* name() const override { return "gated"; }

 private:
  Status record(const char* what, std::uint32_t seq) {
    std::unique_lock lock{w_.m};
    w_.cv.wait(lock, [&] { return w_.open; });
    if (w_.each.count() > 0) {
      lock.unlock();
      std::this_thread::sleep_for(w_.each);
      lock.lock();
    }
    w_.log.push_back(std::string{what} + " " + std::to_string(seq));
    if (w_.fail) return Error{"gated: refused"};
    return ok_status();
  }
  Written& w_;
};

std::unique_ptr<SendQueue> make_queue(Written& w, SendQueueOptions options = {}) {
  auto q = SendQueue::create(std::make_unique<GatedPublisher>(w), options);
  EXPECT_TRUE(q.ok());
  return std::move(q.value());
}

bool wait_for(const std::function<bool()>& pred, std::chrono::seconds timeout = 20s) {
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  while (std::chrono::steady_clock::now() < deadline) {
    if (pred()) return true;
    std::this_thread::sleep_for(2ms);
  }
  return pred();
}

ScanPoints scan_with_seq(std::uint32_t seq) {
  ScanPoints s;
  s.seq = seq;
  s.count = 361;
  return s;
}

TEST(SendQueue, WritesEverythingInTheOrderGivenWithoutTheCallerWaiting) {
  Written w;
  w.set_open(false);  // the link is down: every write underneath blocks
  auto q = make_queue(w);
  std::vector<std::string> expected;
  for (std::uint32_t k = 1; k <= 300; ++k) {
    if (k % 8 == 0) {
      OnboardPose p;
      p.seq = k;
      ASSERT_TRUE(q->publish_pose(p).ok());
      expected.push_back("pose " + std::to_string(k));
    } else if (k % 50 == 0) {
      OnboardStatus s;
      s.seq = k;
      ASSERT_TRUE(q->publish_status(s).ok());
      expected.push_back("status " + std::to_string(k));
    } else {
      ASSERT_TRUE(q->publish_scan(scan_with_seq(k)).ok());
      expected.push_back("scan " + std::to_string(k));
    }
  }
  // Every call returned while the writer underneath could not take a single message.
  EXPECT_EQ(w.size(), 0u);
  EXPECT_GE(q->health().depth, 299u);  // the first may be inside its (blocked) write
  EXPECT_EQ(q->health().high_water, 300u);
  w.set_open(true);
  ASSERT_TRUE(wait_for([&] { return w.size() == expected.size(); }));
  {
    std::lock_guard lock{w.m};
    EXPECT_EQ(w.log, expected);
  }
  ASSERT_TRUE(wait_for([&] { return q->health().depth == 0; }));
  EXPECT_EQ(q->health().refused, 0u);
  EXPECT_EQ(q->health().write_errors, 0u);
  EXPECT_TRUE(q->health().queued);
}

TEST(SendQueue, AFullQueueRefusesAndCountsAndBackfillTakesAtMostHalf) {
  Written w;
  w.set_open(false);
  auto q = make_queue(w);
  // Back-fill first: at most half the queue.
  std::uint32_t backfill_taken = 0;
  for (std::uint32_t k = 0; k < kSendQueueItems; ++k)
    if (q->publish_backfill(scan_with_seq(k)).ok()) ++backfill_taken;
  EXPECT_EQ(backfill_taken, kSendQueueItems / 2);
  OnboardPose p;
  const Status bp = q->publish_backfill_pose(p);
  ASSERT_FALSE(bp.ok());
  EXPECT_NE(std::string{bp.error().what}.find("back-fill"), std::string::npos) << bp.error().what;
  // The live scans still find the other half.
  std::uint32_t live_taken = 0;
  Status last = ok_status();
  for (std::uint32_t k = 0; k < kSendQueueItems; ++k) {
    last = q->publish_scan(scan_with_seq(1000 + k));
    if (last.ok()) ++live_taken;
  }
  EXPECT_EQ(live_taken, kSendQueueItems / 2);
  ASSERT_FALSE(last.ok());
  EXPECT_NE(std::string{last.error().what}.find("send queue full"), std::string::npos) << last.error().what;
  const PublisherHealth h = q->health();
  EXPECT_EQ(h.refused, (kSendQueueItems - backfill_taken) + 1 + (kSendQueueItems - live_taken));
  EXPECT_EQ(h.high_water, kSendQueueItems);
  // Once the link takes them, everything that was accepted goes out and the queue takes messages again.
  w.set_open(true);
  ASSERT_TRUE(wait_for([&] { return w.size() == kSendQueueItems; }));
  ASSERT_TRUE(wait_for([&] { return q->health().depth == 0; }));
  EXPECT_TRUE(q->publish_scan(scan_with_seq(5000)).ok());
  ASSERT_TRUE(wait_for([&] { return w.size() == kSendQueueItems + 1; }));
}

TEST(SendQueue, TheWritersRefusalsAreCounted) {
  Written w;
  w.fail = true;
  auto q = make_queue(w);
  for (std::uint32_t k = 0; k < 10; ++k) ASSERT_TRUE(q->publish_scan(scan_with_seq(k)).ok());
  ASSERT_TRUE(wait_for([&] { return q->health().write_errors == 10; }));
  EXPECT_EQ(q->health().refused, 0u);
}

TEST(SendQueue, TheStopWritesWhatIsQueuedWithinItsDrainTime) {
  {
    Written w;
    {
      auto q = make_queue(w);
      w.set_open(false);
      for (std::uint32_t k = 0; k < 100; ++k) ASSERT_TRUE(q->publish_scan(scan_with_seq(k)).ok());
      w.set_open(true);
    }  // the destructor drains
    EXPECT_EQ(w.size(), 100u);
  }
  {
    // A link that takes 100 ms per message: the stop gives up after its drain time and leaves the rest.
    Written w;
    w.each = 100ms;
    SendQueueOptions options;
    options.drain_timeout = 300ms;
    {
      auto q = make_queue(w, options);
      for (std::uint32_t k = 0; k < 50; ++k) ASSERT_TRUE(q->publish_scan(scan_with_seq(k)).ok());
    }
    EXPECT_GE(w.size(), 1u);
    EXPECT_LT(w.size(), 50u);
  }
}

TEST(SendQueue, TheReaderMatchCountIsReadOnTheSenderAndNeverWaits) {
  Written w;
  w.matches = 1;
  SendQueueOptions options;
  options.matches_refresh = 20ms;
  auto q = make_queue(w, options);
  ASSERT_TRUE(wait_for([&] { return q->scan_reader_matches() == 1u; }));  // read as the sender starts
  {
    std::lock_guard lock{w.m};
    w.matches = 2;
  }
  ASSERT_TRUE(wait_for([&] { return q->scan_reader_matches() == 2u; }));  // an idle queue refreshes it
  // The link goes down with a write in flight: the writer's own count would wait for it, the queue's
  // answer does not.
  w.set_open(false);
  ASSERT_TRUE(q->publish_scan(scan_with_seq(1)).ok());
  std::atomic<bool> answered{false};
  std::thread reader{[&] {
    (void)q->scan_reader_matches();
    answered = true;
  }};
  const bool in_time = wait_for([&] { return answered.load(); }, 5s);
  {
    std::lock_guard lock{w.m};
    w.matches = 3;  // a station matched during the shadow
  }
  w.set_open(true);
  reader.join();
  EXPECT_TRUE(in_time);
  ASSERT_TRUE(wait_for([&] { return q->scan_reader_matches() == 3u; }));
  EXPECT_EQ(w.size(), 1u);
}

TEST(SendQueue, RefusesToStartWithoutAWriter) {
  auto q = SendQueue::create(nullptr);
  ASSERT_FALSE(q.ok());
  EXPECT_NE(std::string{q.error().what}.find("no publisher"), std::string::npos);
}

}  // namespace
}  // namespace teamscan::onboard
