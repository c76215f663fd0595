// sd_notify harness for tests (DDS_SYSTEMD.md 5.2): plays systemd's part without PID 1. It binds an
// AF_UNIX datagram socket, fork/execs a daemon with NOTIFY_SOCKET, WATCHDOG_USEC and WATCHDOG_PID set,
// and collects the daemon's READY/STATUS/WATCHDOG/STOPPING messages with their arrival times, checking
// the sender's pid (SCM_CREDENTIALS) like systemd's NotifyAccess=main.
#pragma once

#include <sys/types.h>

#include <optional>
#include <string>
#include <vector>

#include "common/time.hpp"

namespace teamscan::test {

struct NotifyMessage {
  Duration since_spawn{};   // arrival time after fork
  std::string key;          // "READY", "WATCHDOG", "STATUS", "STOPPING", ...
  std::string value;        // "1", the status text, ...
  pid_t sender = 0;
};

class NotifyHarness {
 public:
  NotifyHarness();            // aborts the test binary if the socket cannot be created (test bug)
  ~NotifyHarness();           // SIGKILLs and reaps a child still running
  NotifyHarness(const NotifyHarness&) = delete;
  NotifyHarness& operator=(const NotifyHarness&) = delete;

  // Starts argv[0] with argv; watchdog zero = no WATCHDOG_USEC. extra_env entries are "KEY=VALUE".
  // Returns the child's pid, or -1.
  pid_t spawn(const std::vector<std::string>& argv, Duration watchdog,
              const std::vector<std::string>& extra_env = {});

  // Collects messages until one with `key` arrives (returned) or the timeout passes (nullopt).
  std::optional<NotifyMessage> wait_for(const std::string& key, Duration timeout);
  // Collects messages for `d`.
  void collect_for(Duration d);
  // Acts like the service manager's watchdog for up to `total`: if no WATCHDOG=1 arrives for longer
  // than the watchdog timeout, sends SIGABRT (WatchdogSignal=) and returns the time the miss was seen
  // (since spawn). nullopt if the daemon kept pinging for the whole time.
  std::optional<Duration> supervise(Duration total);

  // What the service manager does after a watchdog miss once supervise() has sent SIGABRT: SIGCONT (so
  // a stopped process gets to act on the signal; systemd's kill sends SIGCONT after every signal but
  // SIGKILL) unless `send_sigcont` is false, then up to `abort_timeout` (TimeoutAbortSec=) for the
  // child to die, then SIGKILL. Returns the raw wait status and whether SIGKILL was needed.
  struct WatchdogKill {
    int wait_status = 0;
    bool escalated_to_sigkill = false;
  };
  std::optional<WatchdogKill> finish_watchdog_kill(Duration abort_timeout, bool send_sigcont = true);

  // Sends a signal to the child.
  void signal(int sig);
  // Waits for the child to exit; the raw wait status, or nullopt on timeout.
  std::optional<int> wait_exit(Duration timeout);

  [[nodiscard]] const std::vector<NotifyMessage>& messages() const { return messages_; }
  [[nodiscard]] std::vector<Duration> times_of(const std::string& key) const;
  [[nodiscard]] pid_t pid() const { return child_; }
  [[nodiscard]] std::uint64_t foreign_messages() const { return foreign_; }  // wrong sender pid
  [[nodiscard]] const std::string& socket_path() const { return path_; }

 private:
  // Receives for at most `timeout`; true if a message arrived.
  bool receive_one(Duration timeout);
  [[nodiscard]] Duration elapsed() const;

  int fd_ = -1;
  std::string path_;
  pid_t child_ = -1;
  bool reaped_ = false;
  int exit_status_ = 0;
  Duration watchdog_{};
  std::int64_t spawn_ns_ = 0;
  std::vector<NotifyMessage> messages_;
  std::uint64_t foreign_ = 0;
};

}  // namespace teamscan::test
