// Cyclone DDS's receive threads made SCHED_BATCH: they stop preempting the process's busy thread for
// every packet and run at its next scheduler tick or when it waits, taking all queued packets at once.
#pragma once

#include <cstddef>

namespace teamscan::dds {

// What batch_receive_threads() found and did.
struct ReceiveThreads {
  std::size_t found = 0;    // threads of this process named recv* (Cyclone: recv, recvUC, recvMC, recvMCUC)
  std::size_t batched = 0;  // of them, now SCHED_BATCH
};

// Sets every receive thread of this process's Cyclone domains (created with the first participant) to
// SCHED_BATCH (sched(7): a batch thread does not preempt on wakeup; unprivileged, it keeps the nice value).
// Why: each sample wakes the receive thread; on a loop that is busy fusing, a normal thread preempts it
// once per packet (at 2 400 scans/s, ~18 % of a core in context switches and per-packet work). As a batch
// thread it runs within a tick (4 ms at HZ=250) or as soon as the loop waits, and takes every packet
// queued by then in one go. Linux only; elsewhere nothing is found.
ReceiveThreads batch_receive_threads();

}  // namespace teamscan::dds
