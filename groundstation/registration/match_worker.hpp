// One thread that runs the registration's matches beside the station's receive loop, in the order
// they were submitted (registration.hpp, RegistrationOptions::match_delay_s). The caller waits for a
// match by its ticket only when it is due, so the loop's core never builds a window grid or searches
// the reference; the answer is the same whichever thread computed it (docs/registration.md "Cost").
#pragma once

#include <condition_variable>
#include <cstdint>
#include <deque>
#include <functional>
#include <mutex>
#include <thread>
#include <vector>

#include "common/thread_placement.hpp"

namespace teamscan::registration {

class MatchWorker {
 public:
  // `cpus`: where the thread runs (empty: where the caller's threads may); a set the kernel refuses
  // leaves the thread where it was (placement_error()).
  explicit MatchWorker(std::vector<int> cpus = {});
  // Runs what is queued, then joins.
  ~MatchWorker();
  MatchWorker(const MatchWorker&) = delete;
  MatchWorker& operator=(const MatchWorker&) = delete;

  // Queues `job`; returns its ticket (1, 2, ...).
  std::uint64_t submit(std::function<void()> job);
  // Returns once the job of `ticket` (and every one before it) has run.
  void wait(std::uint64_t ticket);
  // Returns once every submitted job has run.
  void wait_idle() { wait(submitted_); }
  // The ticket of the latest job.
  [[nodiscard]] std::uint64_t submitted() const { return submitted_; }

  // Where the thread runs and its class, as the kernel reports it (affinity_error: placing it on `cpus`).
  [[nodiscard]] ThreadScheduling scheduling() const;
  // Waits that found their job not done yet (the loop stopped for the worker).
  [[nodiscard]] std::uint64_t waits_blocked() const { return waits_blocked_; }

 private:
  void run();

  mutable std::mutex mutex_;
  std::condition_variable wake_, done_;
  std::deque<std::function<void()>> queue_;
  std::uint64_t submitted_ = 0;  // the caller's only
  std::uint64_t completed_ = 0;  // under mutex_
  std::uint64_t waits_blocked_ = 0;
  int thread_id_ = 0, placement_error_ = 0;  // under mutex_, set by the thread at its start
  pthread_t handle_{};
  bool started_ = false, stop_ = false;
  std::vector<int> cpus_;
  std::thread thread_;
};

}  // namespace teamscan::registration
