// A scripted SerialEndpoint for the serial tests: sends bytes at given times, answers received bytes
// through an optional responder, remembers what it received and when, and can change its rate right
// after a send (as the LMS-200 does after acknowledging a baud change).
#pragma once

#include <cstdint>
#include <functional>
#include <limits>
#include <span>
#include <utility>
#include <vector>

#include "drivers/serial/endpoint.hpp"

namespace teamscan::serial::testing {

class ScriptedEndpoint : public SerialEndpoint {
 public:
  using Bytes = std::vector<std::uint8_t>;
  struct Received {
    Time time;
    Bytes bytes;
  };

  explicit ScriptedEndpoint(std::uint32_t baud) : baud_{baud} {}

  // Queue `bytes` for sending at `when` (or now, if `when` has passed).
  void send_at(Time when, Bytes bytes) { script_.emplace_back(when, std::move(bytes)); }
  void send_now(const Bytes& bytes) { pending_.insert(pending_.end(), bytes.begin(), bytes.end()); }
  // Called with every received piece; may call send_now / switch_baud_after_send.
  std::function<void(ScriptedEndpoint&, std::span<const std::uint8_t>, Time)> responder;
  // The next take_tx that empties the queue switches the rate to `baud` afterwards.
  void switch_baud_after_send(std::uint32_t baud) { switch_to_ = baud; }
  void set_baud(std::uint32_t baud) { baud_ = baud; }
  // A periodic timer: next_deadline() steps by `period` from `first` (0 = none).
  void set_period(Time first, Duration period) {
    next_tick_ = first;
    period_ = period;
  }

  void on_rx(std::span<const std::uint8_t> bytes, Time now) override {
    received.push_back({now, Bytes(bytes.begin(), bytes.end())});
    if (responder) responder(*this, bytes, now);
  }
  void on_tick(Time now) override {
    ticks.push_back(now);
    for (auto it = script_.begin(); it != script_.end();) {
      if (it->first <= now) {
        pending_.insert(pending_.end(), it->second.begin(), it->second.end());
        it = script_.erase(it);
      } else {
        ++it;
      }
    }
    if (period_ > Duration::zero())
      while (next_tick_ <= now) next_tick_ += period_;
  }
  std::size_t take_tx(std::span<std::uint8_t> out) override {
    const std::size_t n = std::min(out.size(), pending_.size());
    std::copy_n(pending_.begin(), n, out.begin());
    pending_.erase(pending_.begin(), pending_.begin() + static_cast<std::ptrdiff_t>(n));
    if (n > 0 && pending_.empty() && switch_to_ != 0) {
      baud_ = switch_to_;
      switch_to_ = 0;
    }
    return n;
  }
  [[nodiscard]] std::uint32_t baud() const override { return baud_; }
  [[nodiscard]] Time next_deadline() const override {
    Time next = Time::from_ns(std::numeric_limits<std::int64_t>::max());
    for (const auto& s : script_) next = std::min(next, s.first);
    if (period_ > Duration::zero()) next = std::min(next, next_tick_);
    return next;
  }

  [[nodiscard]] Bytes received_bytes() const {
    Bytes all;
    for (const auto& r : received) all.insert(all.end(), r.bytes.begin(), r.bytes.end());
    return all;
  }

  std::vector<Received> received;
  std::vector<Time> ticks;

 private:
  std::uint32_t baud_;
  std::uint32_t switch_to_ = 0;
  std::vector<std::pair<Time, Bytes>> script_;
  Bytes pending_;
  Time next_tick_{};
  Duration period_{};
};

}  // namespace teamscan::serial::testing
