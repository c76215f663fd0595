// batch_receive_threads: Cyclone's receive threads to SCHED_BATCH, found by name in /proc/self/task.
#include "dds/receive_threads.hpp"

#include <dirent.h>
#include <sched.h>

#include <cstdio>
#include <cstdlib>
#include <cstring>

namespace teamscan::dds {

ReceiveThreads batch_receive_threads() {
  ReceiveThreads out;
  DIR* tasks = ::opendir("/proc/self/task");
  if (tasks == nullptr) return out;
  while (const dirent* e = ::readdir(tasks)) {
    if (e->d_name[0] < '0' || e->d_name[0] > '9') continue;
    char path[300];
    std::snprintf(path, sizeof path, "/proc/self/task/%s/comm", e->d_name);
    std::FILE* f = std::fopen(path, "r");
    if (f == nullptr) continue;  // the thread ended meanwhile
    char comm[32] = {};
    const bool read = std::fgets(comm, sizeof comm, f) != nullptr;
    std::fclose(f);
    if (!read || std::strncmp(comm, "recv", 4) != 0) continue;
    ++out.found;
    const sched_param param{};
    if (::sched_setscheduler(static_cast<pid_t>(std::strtol(e->d_name, nullptr, 10)), SCHED_BATCH, &param) == 0) ++out.batched;
  }
  ::closedir(tasks);
  return out;
}

}  // namespace teamscan::dds
