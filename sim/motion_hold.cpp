// MotionHold (motion_hold.hpp).
#include "sim/motion_hold.hpp"

#include <algorithm>

namespace teamscan::sim {

void MotionHold::hold(double from_s) {
  std::lock_guard<std::mutex> lock{mutex_};
  if (!intervals_.empty() && intervals_.back().to_s == kOpen) return;
  // A hold never starts before the last one ended (the clock of the callers only moves on).
  if (!intervals_.empty()) from_s = std::max(from_s, intervals_.back().to_s);
  intervals_.push_back({from_s, kOpen});
  any_.store(true, std::memory_order_release);
}

void MotionHold::release(double at_s) {
  std::lock_guard<std::mutex> lock{mutex_};
  if (intervals_.empty() || intervals_.back().to_s != kOpen) return;
  intervals_.back().to_s = std::max(at_s, intervals_.back().from_s);
}

double MotionHold::track_time(double t_s) const {
  if (!any_.load(std::memory_order_acquire)) return t_s;
  std::lock_guard<std::mutex> lock{mutex_};
  double held_s = 0;
  for (const Interval& h : intervals_) {
    if (h.from_s >= t_s) break;
    held_s += std::min(t_s, h.to_s) - h.from_s;
  }
  return t_s - held_s;
}

bool MotionHold::held_at(double t_s) const {
  if (!any_.load(std::memory_order_acquire)) return false;
  std::lock_guard<std::mutex> lock{mutex_};
  for (const Interval& h : intervals_)
    if (h.from_s <= t_s && t_s < h.to_s) return true;
  return false;
}

std::size_t MotionHold::holds() const {
  std::lock_guard<std::mutex> lock{mutex_};
  return intervals_.size();
}

}  // namespace teamscan::sim
