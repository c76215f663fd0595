// Where a thread runs (thread_placement.hpp).
#include "common/thread_placement.hpp"

#include <pthread.h>
#include <sched.h>
#include <sys/resource.h>
#include <sys/syscall.h>
#include <unistd.h>

#include <cerrno>

namespace teamscan {

int current_thread_id() { return static_cast<int>(::syscall(SYS_gettid)); }

void set_current_thread_below_loop() {
  (void)::setpriority(PRIO_PROCESS, static_cast<id_t>(current_thread_id()), 10);
  sched_param p{};
  p.sched_priority = 0;
  (void)::pthread_setschedparam(::pthread_self(), SCHED_BATCH, &p);
}

int set_current_thread_cpus(std::span<const int> cpus) {
  if (cpus.empty()) return 0;
  cpu_set_t set;
  CPU_ZERO(&set);
  for (int cpu : cpus)
    if (cpu >= 0 && cpu < CPU_SETSIZE) CPU_SET(static_cast<std::size_t>(cpu), &set);
  return ::pthread_setaffinity_np(::pthread_self(), sizeof set, &set);
}

namespace {

std::vector<int> affinity_of(pthread_t handle) {
  std::vector<int> out;
  cpu_set_t set;
  CPU_ZERO(&set);
  if (::pthread_getaffinity_np(handle, sizeof set, &set) != 0) return out;
  for (int cpu = 0; cpu < CPU_SETSIZE; ++cpu)
    if (CPU_ISSET(static_cast<std::size_t>(cpu), &set)) out.push_back(cpu);
  return out;
}

}  // namespace

std::vector<int> current_thread_cpus() { return affinity_of(::pthread_self()); }

ThreadScheduling thread_scheduling(pthread_t handle, int tid) {
  ThreadScheduling out;
  if (tid == 0) return out;
  sched_param p{};
  int policy = -1;
  if (::pthread_getschedparam(handle, &policy, &p) != 0) return out;
  errno = 0;
  const int nice = ::getpriority(PRIO_PROCESS, static_cast<id_t>(tid));
  if (nice == -1 && errno != 0) return out;
  out.policy = policy;
  out.nice = nice;
  out.cpus = affinity_of(handle);
  return out;
}

std::string describe(const ThreadScheduling& s) {
  std::string policy;
  switch (s.policy) {
    case SCHED_OTHER: policy = "SCHED_OTHER"; break;
    case SCHED_BATCH: policy = "SCHED_BATCH"; break;
    case SCHED_IDLE: policy = "SCHED_IDLE"; break;
    case SCHED_FIFO: policy = "SCHED_FIFO"; break;
    case SCHED_RR: policy = "SCHED_RR"; break;
    default: policy = "policy " + std::to_string(s.policy); break;
  }
  // Appended piece by piece (GCC 12 at -O3 warns on `"," + std::string` here: a false -Wrestrict).
  std::string out = policy;
  out += ", nice ";
  out += std::to_string(s.nice);
  out += ", CPUs ";
  if (s.cpus.empty()) out += '-';
  for (std::size_t i = 0; i < s.cpus.size(); ++i) {
    if (i > 0) out += ',';
    out += std::to_string(s.cpus[i]);
  }
  return out;
}

}  // namespace teamscan
