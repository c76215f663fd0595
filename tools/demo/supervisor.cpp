// Child processes of the demo (supervisor.hpp).
#include "tools/demo/supervisor.hpp"

#include <fcntl.h>
#include <signal.h>
#include <sys/prctl.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <iterator>
#include <sstream>
#include <thread>

namespace teamscan::demo {

Result<pid_t> Supervisor::spawn(const std::vector<std::string>& argv, const std::string& log) {
  if (argv.empty()) return Error{"spawn: no program"};
  const pid_t pid = ::fork();
  if (pid < 0) return Error{"fork failed", errno};
  if (pid == 0) {
    ::setpgid(0, pgid_);  // pgid_ == 0 for the first child: a new group led by it
    ::prctl(PR_SET_PDEATHSIG, SIGTERM);  // the demo killed outright (SIGKILL): its children still stop
    ::signal(SIGINT, SIG_DFL);
    ::signal(SIGTERM, SIG_DFL);
    const int fd = ::open(log.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
    if (fd >= 0) {
      ::dup2(fd, 1);
      ::dup2(fd, 2);
    }
    exec_or_exit(argv);
  }
  ::setpgid(pid, pgid_);  // also from the parent: no race with the child's own call
  if (pgid_ == 0) pgid_ = pid;
  return pid;
}

void exec_or_exit(const std::vector<std::string>& argv) {
  std::vector<char*> args;
  for (const std::string& a : argv) args.push_back(const_cast<char*>(a.c_str()));
  args.push_back(nullptr);
  ::execv(args[0], args.data());
  std::fprintf(stderr, "exec %s: %s\n", args[0], std::strerror(errno));
  ::_exit(127);
}

void Supervisor::kill_group() {
  if (pgid_ > 0) ::kill(-pgid_, SIGKILL);
}

void reap(Child& c, bool block) {
  if (c.exited || c.pid <= 0) return;
  int st = 0;
  struct rusage ru{};
  const pid_t r = ::wait4(c.pid, &st, block ? 0 : WNOHANG, &ru);
  if (r == c.pid) {
    c.exited = true;
    c.cpu_s = static_cast<double>(ru.ru_utime.tv_sec + ru.ru_stime.tv_sec) +
              1e-6 * static_cast<double>(ru.ru_utime.tv_usec + ru.ru_stime.tv_usec);
    c.exit_code = WIFEXITED(st) ? WEXITSTATUS(st) : 128 + WTERMSIG(st);
  }
}

void stop_child(Child& c, std::chrono::milliseconds grace) {
  reap(c, false);
  if (c.exited || c.pid <= 0) return;
  ::kill(c.pid, SIGTERM);
  const auto end = std::chrono::steady_clock::now() + grace;
  while (std::chrono::steady_clock::now() < end) {
    reap(c, false);
    if (c.exited) return;
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  ::kill(c.pid, SIGKILL);
  reap(c, true);
}

void kill_child(Child& c) {
  reap(c, false);
  if (c.exited || c.pid <= 0) return;
  ::kill(c.pid, SIGKILL);
  reap(c, true);
}

double proc_cpu_s(pid_t pid) {
  if (pid <= 0) return 0;
  std::ifstream in("/proc/" + std::to_string(pid) + "/stat");
  std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const auto close = text.rfind(')');
  if (close == std::string::npos) return 0;
  std::istringstream fields(text.substr(close + 2));
  std::string f;
  double ticks = 0;
  for (int k = 3; k <= 15 && fields >> f; ++k)
    if (k == 14 || k == 15) ticks += std::stod(f);
  return ticks / static_cast<double>(::sysconf(_SC_CLK_TCK));
}

double self_cpu_s() {
  struct rusage ru{};
  ::getrusage(RUSAGE_SELF, &ru);
  return static_cast<double>(ru.ru_utime.tv_sec + ru.ru_stime.tv_sec) +
         1e-6 * static_cast<double>(ru.ru_utime.tv_usec + ru.ru_stime.tv_usec);
}

}  // namespace teamscan::demo
