// Cyclone DDS's receive threads made SCHED_BATCH: they stop preempting the process's busy thread for
// every packet and run at its next scheduler tick or when it waits, taking all queued packets at once.
#pragma once

#include <chrono>
#include <cstddef>
#include <vector>

namespace teamscan::dds {

// The kernel ids of this process's threads now.
[[nodiscard]] std::vector<int> thread_ids();

// What batch_receive_threads() found and did.
struct ReceiveThreads {
  std::size_t found = 0;    // new threads named recv* (Cyclone: recv, recvUC, recvMC, recvMCUC)
  std::size_t batched = 0;  // of them, now SCHED_BATCH
  std::size_t unnamed = 0;  // new threads that had not named themselves within `wait`
};

// Sets the receive threads that Cyclone started since `before` (thread_ids() taken before the first
// participant of a domain was created) to SCHED_BATCH (sched(7): a batch thread does not preempt on
// wakeup; unprivileged, it keeps the nice value). A new thread names itself once it runs, so this waits
// up to `wait` for every new thread to carry a name other than the caller's.
// Why: each sample wakes the receive thread; on a loop that is busy fusing, a normal thread preempts it
// once per packet, and context switches and per-packet work take a share of a core. As a batch
// thread it runs within a tick (4 ms at HZ=250) or as soon as the loop waits, and takes every packet
// queued by then in one go. Linux only; elsewhere nothing is found.
ReceiveThreads batch_receive_threads(const std::vector<int>& before,
                                     std::chrono::milliseconds wait = std::chrono::milliseconds(1000));

}  // namespace teamscan::dds
