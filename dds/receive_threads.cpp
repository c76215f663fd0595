// batch_receive_threads: Cyclone's receive threads to SCHED_BATCH, found by name in /proc/self/task.
#include "dds/receive_threads.hpp"

#include <dirent.h>
#include <sched.h>
#include <sys/syscall.h>
#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <thread>

namespace teamscan::dds {

namespace {

// A thread's name (/proc/self/task/TID/comm), empty if it is gone.
std::string comm_of(int tid) {
  char path[64];
  std::snprintf(path, sizeof path, "/proc/self/task/%d/comm", tid);
  std::FILE* f = std::fopen(path, "r");
  if (f == nullptr) return {};
  char comm[32] = {};
  const bool read = std::fgets(comm, sizeof comm, f) != nullptr;
  std::fclose(f);
  if (!read) return {};
  std::string s(comm);
  if (!s.empty() && s.back() == '\n') s.pop_back();
  return s;
}

}  // namespace

std::vector<int> thread_ids() {
  std::vector<int> out;
  DIR* tasks = ::opendir("/proc/self/task");
  if (tasks == nullptr) return out;
  while (const dirent* e = ::readdir(tasks)) {
    if (e->d_name[0] >= '0' && e->d_name[0] <= '9') out.push_back(static_cast<int>(std::strtol(e->d_name, nullptr, 10)));
  }
  ::closedir(tasks);
  return out;
}

ReceiveThreads batch_receive_threads(const std::vector<int>& before, std::chrono::milliseconds wait) {
  ReceiveThreads out;
  const std::string creator = comm_of(static_cast<int>(::syscall(SYS_gettid)));
  const auto deadline = std::chrono::steady_clock::now() + wait;
  std::vector<int> fresh;
  std::vector<std::string> names;
  for (;;) {
    fresh.clear();
    names.clear();
    std::size_t unnamed = 0;
    for (int tid : thread_ids()) {
      if (std::find(before.begin(), before.end(), tid) != before.end()) continue;
      std::string name = comm_of(tid);
      if (name.empty()) continue;  // ended meanwhile
      if (name == creator) ++unnamed;
      fresh.push_back(tid);
      names.push_back(std::move(name));
    }
    out.unnamed = unnamed;
    if (unnamed == 0 || std::chrono::steady_clock::now() >= deadline) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  }
  for (std::size_t i = 0; i < fresh.size(); ++i) {
    if (names[i].rfind("recv", 0) != 0) continue;
    ++out.found;
    const sched_param param{};
    if (::sched_setscheduler(fresh[i], SCHED_BATCH, &param) == 0) ++out.batched;
  }
  return out;
}

}  // namespace teamscan::dds
