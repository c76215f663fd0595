// A tiny daemon for the sd_notify harness test: the loop shape of the real daemons (READY once up,
// WATCHDOG=1 from the loop at half the watchdog interval, STOPPING=1 on SIGTERM), through
// dds/notify.hpp. --hang-after-ms N stops the loop from pinging after N ms (a hung loop).
#include <csignal>
#include <cstdlib>
#include <cstring>
#include <ctime>

#include "dds/notify.hpp"

namespace {
volatile std::sig_atomic_t g_stop = 0;
void on_term(int) { g_stop = 1; }

std::int64_t mono_ms() {
  timespec ts{};
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return static_cast<std::int64_t>(ts.tv_sec) * 1000 + ts.tv_nsec / 1'000'000;
}
}  // namespace

int main(int argc, char** argv) {
  long hang_after_ms = -1;
  for (int i = 1; i + 1 < argc; ++i) {
    if (std::strcmp(argv[i], "--hang-after-ms") == 0) hang_after_ms = std::strtol(argv[i + 1], nullptr, 10);
  }
  struct sigaction sa{};
  sa.sa_handler = on_term;
  sigaction(SIGTERM, &sa, nullptr);
  const teamscan::Duration wd = teamscan::dds::watchdog_interval();
  const std::int64_t ping_ms = wd.count() > 0 ? wd.count() / 2'000'000 : 100;
  const std::int64_t start = mono_ms();
  teamscan::dds::notify_status("starting");
  teamscan::dds::notify_ready();
  std::int64_t next_ping = start;
  while (g_stop == 0) {
    const std::int64_t now = mono_ms();
    if (hang_after_ms >= 0 && now - start > hang_after_ms) {
      for (;;) pause();  // stuck: no more pings; only a signal ends it
    }
    if (wd.count() > 0 && now >= next_ping) {
      teamscan::dds::notify_watchdog();
      next_ping = now + ping_ms;
    }
    timespec tick{0, 10'000'000};
    nanosleep(&tick, nullptr);
  }
  teamscan::dds::notify_stopping();
  return 0;
}
