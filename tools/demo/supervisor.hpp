// The demo's child processes: started in one process group of their own (so Ctrl-C on the terminal
// reaches only the demo, which then stops its children in order), each with its log file; stopped with
// SIGTERM, then SIGKILL after a grace time; exit codes and CPU times collected.
#pragma once

#include <sys/types.h>

#include <chrono>
#include <string>
#include <vector>

#include "common/result.hpp"

namespace teamscan::demo {

struct Child {
  std::string name;
  std::string log;
  pid_t pid = -1;
  int exit_code = -1;    // 128 + signal if killed
  bool exited = false;
  double cpu_s = 0;      // user + system CPU time (from wait4)
  double run_cpu_s = 0;  // user + system CPU time up to the end of the run (before stopping)
};

class Supervisor {
 public:
  Supervisor() = default;
  Supervisor(const Supervisor&) = delete;
  Supervisor& operator=(const Supervisor&) = delete;

  // Starts argv[0] (a path) with stdout and stderr into `log`. The child gets SIGTERM if the demo dies
  // (PR_SET_PDEATHSIG) and default SIGINT/SIGTERM handling.
  [[nodiscard]] Result<pid_t> spawn(const std::vector<std::string>& argv, const std::string& log);
  // SIGKILL to every process left in the group (call while a child of the group may still run: a group
  // id whose processes are all gone may be reused by someone else's).
  void kill_group();
  [[nodiscard]] pid_t group() const { return pgid_; }

 private:
  pid_t pgid_ = 0;
};

// In a forked child: replaces it with argv[0] (a path) and `argv`; on failure says why on stderr and exits 127.
[[noreturn]] void exec_or_exit(const std::vector<std::string>& argv);

// Collects `c`'s exit if it has exited (block: waits for it).
void reap(Child& c, bool block);
// SIGTERM, then SIGKILL after `grace`; reaps.
void stop_child(Child& c, std::chrono::milliseconds grace);
// SIGKILL now; reaps.
void kill_child(Child& c);
// utime + stime of a live process (/proc/PID/stat fields 14 and 15), seconds; 0 if unreadable.
[[nodiscard]] double proc_cpu_s(pid_t pid);
// User + system CPU time of this process, seconds.
[[nodiscard]] double self_cpu_s();

}  // namespace teamscan::demo
