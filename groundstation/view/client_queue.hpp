// ClientQueue: one browser's outgoing messages, bounded in bytes and count. A client that cannot keep up
// never makes the station hold more: when a push would exceed a bound, everything queued is dropped and
// the client is marked to receive the whole current state next (skip to the latest; counted in skips()).
// A new client starts in that state: it receives the whole map first. Pure, single-threaded.
#pragma once

#include <cstddef>
#include <cstdint>
#include <deque>

#include "groundstation/view/protocol.hpp"

namespace teamscan::view {

struct QueueLimits {
  std::size_t max_bytes = 8u << 20;
  std::size_t max_messages = 64;
};

class ClientQueue {
 public:
  explicit ClientQueue(QueueLimits limits = {}) : limits_{limits} {}

  void push(SharedMessage m) {
    if (whole_pending_) return;  // the whole state sent next carries this change too
    const std::size_t size = m->bytes.size();
    if (queue_.size() + 1 > limits_.max_messages || bytes_ + size > limits_.max_bytes) {
      skip();
      return;
    }
    bytes_ += size;
    queue_.push_back(std::move(m));
  }

  enum class Next { kNothing, kMessage, kWholeState };
  // What to send next. kWholeState: the caller sends the whole current state (the queue is empty then).
  Next next(SharedMessage& out) {
    if (whole_pending_) {
      whole_pending_ = false;
      return Next::kWholeState;
    }
    if (queue_.empty()) return Next::kNothing;
    out = std::move(queue_.front());
    queue_.pop_front();
    bytes_ -= out->bytes.size();
    return Next::kMessage;
  }

  [[nodiscard]] std::size_t size() const { return queue_.size(); }
  [[nodiscard]] std::size_t bytes() const { return bytes_; }
  [[nodiscard]] bool whole_pending() const { return whole_pending_; }
  [[nodiscard]] std::uint64_t skips() const { return skips_; }

 private:
  void skip() {
    queue_.clear();
    bytes_ = 0;
    whole_pending_ = true;
    ++skips_;
  }

  QueueLimits limits_;
  std::deque<SharedMessage> queue_;
  std::size_t bytes_ = 0;
  bool whole_pending_ = true;  // a new client receives the whole state first
  std::uint64_t skips_ = 0;
};

}  // namespace teamscan::view
