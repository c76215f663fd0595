// sd_notify harness (see notify_harness.hpp).
#include "tests/support/notify_harness.hpp"

#include <poll.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <ctime>

namespace teamscan::test {
namespace {

std::int64_t mono_ns() {
  timespec ts{};
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return static_cast<std::int64_t>(ts.tv_sec) * 1'000'000'000 + ts.tv_nsec;
}

}  // namespace

NotifyHarness::NotifyHarness() {
  fd_ = ::socket(AF_UNIX, SOCK_DGRAM | SOCK_CLOEXEC, 0);
  if (fd_ < 0) { std::perror("notify harness: socket"); std::abort(); }
  char tmpl[] = "/tmp/teamscan-notify-XXXXXX";
  if (::mkdtemp(tmpl) == nullptr) { std::perror("notify harness: mkdtemp"); std::abort(); }
  path_ = std::string(tmpl) + "/notify.sock";
  sockaddr_un addr{};
  addr.sun_family = AF_UNIX;
  std::snprintf(addr.sun_path, sizeof addr.sun_path, "%s", path_.c_str());
  if (::bind(fd_, reinterpret_cast<sockaddr*>(&addr), sizeof addr) != 0) {
    std::perror("notify harness: bind");
    std::abort();
  }
  const int one = 1;
  (void)::setsockopt(fd_, SOL_SOCKET, SO_PASSCRED, &one, sizeof one);
}

NotifyHarness::~NotifyHarness() {
  if (child_ > 0 && !reaped_) {
    ::kill(child_, SIGKILL);
    int st = 0;
    (void)::waitpid(child_, &st, 0);
  }
  if (fd_ >= 0) ::close(fd_);
  ::unlink(path_.c_str());
  const std::string dir = path_.substr(0, path_.rfind('/'));
  ::rmdir(dir.c_str());
}

pid_t NotifyHarness::spawn(const std::vector<std::string>& argv, Duration watchdog,
                           const std::vector<std::string>& extra_env) {
  if (argv.empty()) return -1;
  watchdog_ = watchdog;
  spawn_ns_ = mono_ns();
  const pid_t pid = ::fork();
  if (pid < 0) return -1;
  if (pid == 0) {
    // Child: the pid survives exec, so WATCHDOG_PID = getpid() is the daemon's pid.
    ::setenv("NOTIFY_SOCKET", path_.c_str(), 1);
    if (watchdog.count() > 0) {
      char buf[32];
      std::snprintf(buf, sizeof buf, "%lld", static_cast<long long>(watchdog.count() / 1000));
      ::setenv("WATCHDOG_USEC", buf, 1);
      std::snprintf(buf, sizeof buf, "%d", static_cast<int>(::getpid()));
      ::setenv("WATCHDOG_PID", buf, 1);
    } else {
      ::unsetenv("WATCHDOG_USEC");
      ::unsetenv("WATCHDOG_PID");
    }
    for (const std::string& kv : extra_env) ::putenv(const_cast<char*>(kv.c_str()));
    std::vector<char*> args;
    for (const std::string& a : argv) args.push_back(const_cast<char*>(a.c_str()));
    args.push_back(nullptr);
    ::execv(args[0], args.data());
    std::perror("notify harness: execv");
    ::_exit(127);
  }
  child_ = pid;
  reaped_ = false;
  return pid;
}

Duration NotifyHarness::elapsed() const { return Duration{mono_ns() - spawn_ns_}; }

bool NotifyHarness::receive_one(Duration timeout) {
  pollfd p{fd_, POLLIN, 0};
  const int ms = static_cast<int>(std::max<std::int64_t>(0, timeout.count() / 1'000'000));
  const int r = ::poll(&p, 1, ms);
  if (r <= 0) return false;
  char data[4096];
  alignas(cmsghdr) char control[CMSG_SPACE(sizeof(ucred))];
  iovec iov{data, sizeof data - 1};
  msghdr msg{};
  msg.msg_iov = &iov;
  msg.msg_iovlen = 1;
  msg.msg_control = control;
  msg.msg_controllen = sizeof control;
  const ssize_t n = ::recvmsg(fd_, &msg, MSG_DONTWAIT);
  if (n < 0) return false;
  const Duration at = elapsed();
  pid_t sender = 0;
  for (cmsghdr* c = CMSG_FIRSTHDR(&msg); c != nullptr; c = CMSG_NXTHDR(&msg, c)) {
    if (c->cmsg_level == SOL_SOCKET && c->cmsg_type == SCM_CREDENTIALS) {
      ucred cred{};
      std::memcpy(&cred, CMSG_DATA(c), sizeof cred);
      sender = cred.pid;
    }
  }
  if (sender != child_) {  // NotifyAccess=main: systemd ignores other senders
    ++foreign_;
    return true;
  }
  std::string text(data, static_cast<std::size_t>(n));
  std::size_t pos = 0;
  while (pos < text.size()) {
    std::size_t end = text.find('\n', pos);
    if (end == std::string::npos) end = text.size();
    const std::string line = text.substr(pos, end - pos);
    const std::size_t eq = line.find('=');
    if (!line.empty()) {
      NotifyMessage m;
      m.since_spawn = at;
      m.key = line.substr(0, eq);
      m.value = eq == std::string::npos ? std::string{} : line.substr(eq + 1);
      m.sender = sender;
      messages_.push_back(m);
    }
    pos = end + 1;
  }
  return true;
}

std::optional<NotifyMessage> NotifyHarness::wait_for(const std::string& key, Duration timeout) {
  const std::int64_t deadline = mono_ns() + timeout.count();
  std::size_t seen = 0;
  for (;;) {
    for (; seen < messages_.size(); ++seen) {
      if (messages_[seen].key == key) return messages_[seen];
    }
    const std::int64_t left = deadline - mono_ns();
    if (left <= 0) return std::nullopt;
    (void)receive_one(Duration{std::min<std::int64_t>(left, 50'000'000)});
  }
}

void NotifyHarness::collect_for(Duration d) {
  const std::int64_t deadline = mono_ns() + d.count();
  for (std::int64_t left = d.count(); left > 0; left = deadline - mono_ns()) {
    (void)receive_one(Duration{std::min<std::int64_t>(left, 50'000'000)});
  }
}

std::optional<Duration> NotifyHarness::supervise(Duration total) {
  const std::int64_t deadline = mono_ns() + total.count();
  Duration last_ping = elapsed();
  for (const NotifyMessage& m : messages_) {
    if (m.key == "WATCHDOG" && m.value == "1") last_ping = m.since_spawn;
  }
  std::size_t seen = messages_.size();
  while (mono_ns() < deadline) {
    (void)receive_one(std::chrono::milliseconds(10));
    for (; seen < messages_.size(); ++seen) {
      if (messages_[seen].key == "WATCHDOG" && messages_[seen].value == "1") last_ping = messages_[seen].since_spawn;
    }
    const Duration now = elapsed();
    if (watchdog_.count() > 0 && now - last_ping > watchdog_) {
      signal(SIGABRT);
      return now;
    }
  }
  return std::nullopt;
}

std::optional<NotifyHarness::WatchdogKill> NotifyHarness::finish_watchdog_kill(Duration abort_timeout, bool send_sigcont) {
  if (child_ <= 0) return std::nullopt;
  if (send_sigcont) signal(SIGCONT);
  if (const auto st = wait_exit(abort_timeout)) return WatchdogKill{*st, false};
  signal(SIGKILL);
  if (const auto st = wait_exit(std::chrono::seconds(5))) return WatchdogKill{*st, true};
  return std::nullopt;
}

void NotifyHarness::signal(int sig) {
  if (child_ > 0 && !reaped_) ::kill(child_, sig);
}

std::optional<int> NotifyHarness::wait_exit(Duration timeout) {
  if (child_ <= 0) return std::nullopt;
  if (reaped_) return exit_status_;
  const std::int64_t deadline = mono_ns() + timeout.count();
  for (;;) {
    int st = 0;
    const pid_t r = ::waitpid(child_, &st, WNOHANG);
    if (r == child_) {
      reaped_ = true;
      exit_status_ = st;
      return st;
    }
    if (mono_ns() >= deadline) return std::nullopt;
    // Keep draining notifications meanwhile (STOPPING=1 arrives during shutdown).
    (void)receive_one(std::chrono::milliseconds(10));
  }
}

std::vector<Duration> NotifyHarness::times_of(const std::string& key) const {
  std::vector<Duration> out;
  for (const NotifyMessage& m : messages_) {
    if (m.key == key) out.push_back(m.since_spawn);
  }
  return out;
}

}  // namespace teamscan::test
