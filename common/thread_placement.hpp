// Where a thread runs: its CPUs (set from inside the thread) and its scheduling as the kernel reports
// it (sched(7)). The station keeps its receive loop on the cores it is given and moves its helper
// threads (the model writer, the view's server) to others: fusion.writer_cpus, view.cpus.
#pragma once

#include <pthread.h>

#include <span>
#include <string>
#include <vector>

namespace teamscan {

// A thread's scheduling as the kernel reports it.
struct ThreadScheduling {
  int policy = -1;        // SCHED_OTHER, SCHED_BATCH, SCHED_IDLE, ... (-1: not known)
  int nice = 0;
  std::vector<int> cpus;  // its affinity
  int affinity_error = 0; // errno of setting the CPUs it was asked to run on (0: set, or none asked)
};

// The calling thread's kernel id (gettid()).
[[nodiscard]] int current_thread_id();

// The calling thread's CPUs (its affinity), ascending.
[[nodiscard]] std::vector<int> current_thread_cpus();

// Restricts the calling thread to `cpus` (none: unchanged). Returns 0 or the errno (EINVAL: no CPU
// of the set is online or allowed; out-of-range numbers are ignored).
[[nodiscard]] int set_current_thread_cpus(std::span<const int> cpus);

// Puts the calling thread below a station's loop: nice 10 on its own thread id and SCHED_BATCH (no
// preemption on wake-up). Best effort: what the kernel refuses is left as it was.
void set_current_thread_below_loop();

// The scheduling of the thread `handle` whose kernel id is `tid` (gettid()); policy -1 if it is gone.
[[nodiscard]] ThreadScheduling thread_scheduling(pthread_t handle, int tid);

// "SCHED_BATCH, nice 0, CPUs 0,1" (for the logs).
[[nodiscard]] std::string describe(const ThreadScheduling& s);

}  // namespace teamscan
