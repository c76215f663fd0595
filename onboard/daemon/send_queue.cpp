// SendQueue: a single-producer single-consumer ring of messages and the thread that writes them.
#include "onboard/daemon/send_queue.hpp"

#include <pthread.h>

#include <cerrno>
#include <csignal>
#include <cstdio>
#include <ctime>

#include "common/clock.hpp"

namespace teamscan::onboard {

Result<std::unique_ptr<SendQueue>> SendQueue::create(std::unique_ptr<Publisher> inner, const SendQueueOptions& options) {
  if (!inner) return Error{"send queue: no publisher to write to"};
  std::unique_ptr<SendQueue> q{new SendQueue(std::move(inner), options)};
  if (::sem_init(&q->ready_, 0, 0) != 0) return Error{"send queue: sem_init", errno};
  const auto start = [](void* self) -> void* {
    static_cast<SendQueue*>(self)->run();
    return nullptr;
  };
  // The sender takes no signal: it starts with every signal blocked, so SIGTERM and SIGINT reach the
  // daemon's loop (which waits for them on a signalfd) and never this thread's default action.
  sigset_t all, previous;
  ::sigfillset(&all);
  ::pthread_sigmask(SIG_BLOCK, &all, &previous);
  const int err = ::pthread_create(&q->sender_, nullptr, start, q.get());
  ::pthread_sigmask(SIG_SETMASK, &previous, nullptr);
  if (err != 0) {
    ::sem_destroy(&q->ready_);
    return Error{"send queue: cannot start the sender thread", err};
  }
  q->started_ = true;
  ::pthread_setname_np(q->sender_, "send-queue");
  return q;
}

SendQueue::SendQueue(std::unique_ptr<Publisher> inner, const SendQueueOptions& options)
    : inner_{std::move(inner)}, options_{options} {
  std::snprintf(name_, sizeof name_, "%s (send queue of %zu)", inner_->name(), kSendQueueItems);
}

SendQueue::~SendQueue() {
  if (!started_) return;
  stopping_.store(true, std::memory_order_release);
  ::sem_post(&ready_);
  ::pthread_join(sender_, nullptr);
  ::sem_destroy(&ready_);
}

template <class M>
Status SendQueue::push(const M& message, bool backfill) {
  const std::uint64_t tail = tail_.load(std::memory_order_relaxed);
  const std::uint64_t depth = tail - head_.load(std::memory_order_acquire);
  const std::uint64_t room = backfill ? kSendQueueItems / 2 : kSendQueueItems;
  if (depth >= room) {
    ++refused_;
    return Error{backfill ? "send queue: back-fill waits (half the queue is taken)" : "send queue full: the link takes less than the robot sends"};
  }
  Item& item = items_[tail % kSendQueueItems];
  item.message = message;  // the variant's converting assignment: a copy into its storage, no allocation
  item.backfill = backfill;
  tail_.store(tail + 1, std::memory_order_release);
  high_water_ = std::max(high_water_, static_cast<std::uint32_t>(depth + 1));
  ::sem_post(&ready_);
  return ok_status();
}

Status SendQueue::publish_pose(const OnboardPose& pose) { return push(pose, false); }
Status SendQueue::publish_scan(const ScanPoints& scan) { return push(scan, false); }
Status SendQueue::publish_status(const OnboardStatus& status) { return push(status, false); }
Status SendQueue::publish_backfill(const ScanPoints& scan) { return push(scan, true); }
Status SendQueue::publish_backfill_pose(const OnboardPose& pose) { return push(pose, true); }

PublisherHealth SendQueue::health() const {
  PublisherHealth h;
  h.queued = true;
  h.depth = static_cast<std::uint32_t>(tail_.load(std::memory_order_relaxed) - head_.load(std::memory_order_acquire));
  h.high_water = high_water_;
  h.refused = refused_;
  h.write_errors = write_errors_.load(std::memory_order_relaxed) + dropped_at_stop_.load(std::memory_order_relaxed);
  h.longest_write_ns = longest_write_ns_.load(std::memory_order_relaxed);
  return h;
}

Status SendQueue::write(const Item& item) {
  if (const auto* pose = std::get_if<OnboardPose>(&item.message))
    return item.backfill ? inner_->publish_backfill_pose(*pose) : inner_->publish_pose(*pose);
  if (const auto* scan = std::get_if<ScanPoints>(&item.message))
    return item.backfill ? inner_->publish_backfill(*scan) : inner_->publish_scan(*scan);
  return inner_->publish_status(std::get<OnboardStatus>(item.message));
}

void SendQueue::run() {
  bool draining = false;
  Time drain_deadline{};
  Time next_refresh = now_monotonic();
  for (;;) {
    if (const Time now = now_monotonic(); now >= next_refresh) {
      scan_reader_matches_.store(inner_->scan_reader_matches(), std::memory_order_relaxed);
      next_refresh = now + options_.matches_refresh;
    }
    const std::uint64_t head = head_.load(std::memory_order_relaxed);
    if (head == tail_.load(std::memory_order_acquire)) {
      if (stopping_.load(std::memory_order_acquire)) return;
      // Every push posts once, so a wait returns at least once per item (extra posts just loop); the
      // time limit keeps the reader-match count fresh on an idle queue.
      timespec until{};
      until.tv_sec = static_cast<time_t>(next_refresh.ns() / 1'000'000'000);
      until.tv_nsec = static_cast<long>(next_refresh.ns() % 1'000'000'000);
      while (::sem_clockwait(&ready_, CLOCK_MONOTONIC, &until) != 0 && errno == EINTR) {
      }
      continue;
    }
    if (!draining && stopping_.load(std::memory_order_acquire)) {
      draining = true;
      drain_deadline = now_monotonic() + options_.drain_timeout;
    }
    if (draining && now_monotonic() >= drain_deadline) {
      dropped_at_stop_.store(tail_.load(std::memory_order_acquire) - head, std::memory_order_relaxed);
      return;
    }
    const Time start = now_monotonic();
    const Status s = write(items_[head % kSendQueueItems]);
    const std::int64_t took = (now_monotonic() - start).count();
    if (took > longest_write_ns_.load(std::memory_order_relaxed)) longest_write_ns_.store(took, std::memory_order_relaxed);
    if (s.ok()) written_.fetch_add(1, std::memory_order_relaxed);
    else write_errors_.fetch_add(1, std::memory_order_relaxed);
    head_.store(head + 1, std::memory_order_release);
  }
}

}  // namespace teamscan::onboard
