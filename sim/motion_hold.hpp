// World time -> track time of a robot that its firmware held still for a while (the Pioneer stops its
// motors when its client is silent for the watchdog time, PROTOCOLS.md §1.6; arcos::PioneerEmulator
// tells the simulator when). The robot's track (sim/track.hpp) advances only while it is not held, so
// it drives on from where it stopped. Thread-safe: the ARCOS side writes, every ray caster reads.
#pragma once

#include <atomic>
#include <limits>
#include <mutex>
#include <vector>

namespace teamscan::sim {

class MotionHold {
 public:
  // Held from world time `from_s` on (no effect while already held).
  void hold(double from_s);
  // Drives on from world time `at_s` (no effect unless held; never before the hold began).
  void release(double at_s);
  // The time on the robot's track at world time t_s: t_s less every hold before it.
  [[nodiscard]] double track_time(double t_s) const;
  // True when the robot stands held at world time t_s.
  [[nodiscard]] bool held_at(double t_s) const;
  // How many holds began so far.
  [[nodiscard]] std::size_t holds() const;

 private:
  struct Interval {
    double from_s;
    double to_s;  // +infinity while held
  };
  static constexpr double kOpen = std::numeric_limits<double>::infinity();
  std::atomic<bool> any_{false};  // fast path: a robot never held costs no lock
  mutable std::mutex mutex_;
  std::vector<Interval> intervals_;  // in time order, disjoint
};

}  // namespace teamscan::sim
