// `teamscan replay FILE.cap --link PATH [--speed X]`: plays the device's side of a capture on a pty.
// It sends the device's (rx) bytes with their timing and checks that the host sends the capture's tx
// bytes. Each rx chunk goes out once the tx bytes before it in the capture have arrived and its
// time (relative to the last tx chunk, scaled by 1/speed) has come, so replay follows the host.
// Exit 0: capture done and everything matched; 2: divergence; 3: host silent too long; 1: other errors.
#include <poll.h>
#include <signal.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <csignal>
#include <cstdio>
#include <cstring>
#include <string>
#include <vector>

#include "common/capture.hpp"
#include "common/clock.hpp"
#include "drivers/serial/pty.hpp"
#include "tools/teamscan/subcommand.hpp"

namespace teamscan::tool {
namespace {

using namespace std::chrono_literals;

volatile std::sig_atomic_t g_replay_stop = 0;
void on_replay_stop(int) { g_replay_stop = 1; }

struct ReplayOptions {
  std::string file;
  std::string link_path;
  double speed = 1.0;
  double silence_timeout_s = 10.0;
  bool quiet = false;
};

std::string hex_window(const std::vector<std::uint8_t>& bytes, std::size_t from, std::size_t count) {
  std::string s;
  char tmp[4];
  for (std::size_t i = from; i < bytes.size() && i < from + count; ++i) {
    std::snprintf(tmp, sizeof tmp, "%02X", bytes[i]);
    if (!s.empty()) s += ' ';
    s += tmp;
  }
  return s.empty() ? "(end of capture)" : s;
}

bool write_master(int fd, const std::vector<std::uint8_t>& bytes) {
  const Time give_up = now_monotonic() + 2s;
  std::size_t done = 0;
  while (done < bytes.size()) {
    const ssize_t n = ::write(fd, bytes.data() + done, bytes.size() - done);
    if (n > 0) {
      done += static_cast<std::size_t>(n);
      continue;
    }
    if (n < 0 && errno != EAGAIN && errno != EINTR) return false;
    if (now_monotonic() > give_up) return false;
    pollfd pfd{fd, POLLOUT, 0};
    (void)::poll(&pfd, 1, 10);
  }
  return true;
}

// Closing the pty hangs up the host and drops what it has not read yet: wait for it (bounded by
// `limit`). The pty moves written bytes to the host's queue asynchronously, so "nothing unread" must
// hold for a while (50 ms) before it is believed.
void wait_host_drained(serial::PtyPair& pty, Duration limit) {
  const Time give_up = now_monotonic() + limit;
  Time empty_since = now_monotonic();
  for (;;) {
    auto unread = pty.host_unread_bytes();
    const Time t = now_monotonic();
    if (!unread || t > give_up) break;
    if (*unread != 0) empty_since = t;
    else if (t - empty_since >= 50ms) break;
    ::usleep(2000);
  }
}

int run_replay(const ReplayOptions& opt) {
  if (!(opt.speed > 0)) {
    std::fprintf(stderr, "teamscan replay: --speed must be > 0\n");
    return 2;
  }
  auto cap = load_capture(opt.file);
  if (!cap) {
    std::fprintf(stderr, "teamscan replay: %s: line %ld: %s\n", opt.file.c_str(), cap.error().detail, cap.error().what);
    return 1;
  }
  const auto& records = cap->records;
  const std::vector<std::uint8_t> expected_tx = cap->bytes(CaptureDirection::tx);
  // tx_end[i]: how many tx bytes the host must have sent once record i is done.
  // tx_baud: (end offset, rate) of every tx chunk, to tell the host's rate that each tx byte was sent at.
  std::vector<std::size_t> tx_end(records.size());
  std::vector<std::pair<std::size_t, std::uint32_t>> tx_baud;
  std::size_t total = 0;
  std::uint32_t first_baud = 0, baud_in_force = 0;
  for (std::size_t i = 0; i < records.size(); ++i) {
    if (records[i].kind == CaptureRecord::Kind::chunk && records[i].direction == CaptureDirection::tx) {
      total += records[i].bytes.size();
      tx_baud.emplace_back(total, baud_in_force);
    }
    if (records[i].kind == CaptureRecord::Kind::baud) {
      if (first_baud == 0) first_baud = records[i].baud;
      baud_in_force = records[i].baud;
    }
    tx_end[i] = total;
  }
  auto baud_for_tx_offset = [&](std::size_t offset) -> std::uint32_t {
    const auto it = std::upper_bound(tx_baud.begin(), tx_baud.end(), offset,
                                     [](std::size_t o, const auto& e) { return o < e.first; });
    return it == tx_baud.end() ? 0 : it->second;
  };

  auto pty = serial::PtyPair::create();
  if (!pty) {
    std::fprintf(stderr, "teamscan replay: %s (%s)\n", pty.error().what, std::strerror(pty.error().sys_errno));
    return 1;
  }
  if (first_baud != 0) (void)pty->set_slave_baud(first_baud);
  if (auto s = pty->link(opt.link_path); !s) {
    std::fprintf(stderr, "teamscan replay: cannot create link %s: %s (%s)\n", opt.link_path.c_str(), s.error().what,
                 std::strerror(s.error().sys_errno));
    return 1;
  }
  struct sigaction sa {};
  sa.sa_handler = on_replay_stop;
  sigemptyset(&sa.sa_mask);
  ::sigaction(SIGINT, &sa, nullptr);
  ::sigaction(SIGTERM, &sa, nullptr);
  if (!opt.quiet)
    std::fprintf(stderr, "teamscan replay: serving %s (%zu records, %zu tx / %zu rx bytes) on %s\n", opt.file.c_str(),
                 records.size(), expected_tx.size(), cap->bytes(CaptureDirection::rx).size(), opt.link_path.c_str());

  const Duration silence_limit = from_seconds(opt.silence_timeout_s);
  auto scaled = [&](std::int64_t capture_us) { return from_seconds(static_cast<double>(capture_us) * 1e-6 / opt.speed); };
  // The anchor ties capture time to wall time; it moves to "now" when a tx chunk completes.
  std::int64_t anchor_us = 0;
  Time anchor_wall = now_monotonic();
  Time last_activity = anchor_wall;
  std::size_t matched = 0;
  std::size_t next = 0;
  std::uint32_t warned_host_baud = 0;
  std::vector<std::uint8_t> buf(4096);

  while (g_replay_stop == 0) {
    const Time now = now_monotonic();
    // Host -> us: compare every byte with the capture's tx stream as it arrives.
    for (;;) {
      const ssize_t n = ::read(pty->master_fd(), buf.data(), buf.size());
      if (n <= 0) break;
      last_activity = now_monotonic();
      // The host sets its rate before it writes, so its rate now is the rate these bytes went out at.
      const std::uint32_t host_baud = pty->slave_baud();
      const std::uint32_t capture_baud = baud_for_tx_offset(matched);
      if (capture_baud != 0 && host_baud != capture_baud && host_baud != warned_host_baud) {
        std::fprintf(stderr, "teamscan replay: note: host sends at %u baud at tx byte offset %zu where the capture has %u\n",
                     host_baud, matched, capture_baud);
        warned_host_baud = host_baud;
      }
      for (ssize_t k = 0; k < n; ++k) {
        const std::uint8_t got = buf[static_cast<std::size_t>(k)];
        if (matched >= expected_tx.size() || got != expected_tx[matched]) {
          const std::vector<std::uint8_t> actual(buf.begin() + k, buf.begin() + n);
          std::fprintf(stderr,
                       "teamscan replay: divergence at tx byte offset %zu: expected %s, got %02X\n"
                       "  expected next: %s\n  host sent:     %s\n",
                       matched, matched < expected_tx.size() ? hex_window(expected_tx, matched, 1).c_str() : "nothing (capture has no more tx bytes)",
                       got, hex_window(expected_tx, matched, 16).c_str(), hex_window(actual, 0, 16).c_str());
          return 2;
        }
        ++matched;
      }
    }

    // Advance through the capture as far as the host and the clock allow.
    Time wake = now + 5ms;
    while (next < records.size()) {
      const CaptureRecord& r = records[next];
      if (r.kind == CaptureRecord::Kind::baud) {
        ++next;
        continue;
      }
      if (r.direction == CaptureDirection::tx) {
        if (matched < tx_end[next]) break;  // waiting for the host
        anchor_us = r.time_us;
        anchor_wall = now_monotonic();
        ++next;
        continue;
      }
      const Time due = anchor_wall + scaled(r.time_us - anchor_us);
      if (now_monotonic() < due) {
        wake = std::min(wake, due);
        break;
      }
      if (!write_master(pty->master_fd(), r.bytes)) {
        std::fprintf(stderr, "teamscan replay: host is not reading (%zu bytes not delivered)\n", r.bytes.size());
        return 3;
      }
      last_activity = now_monotonic();
      ++next;
    }
    if (next == records.size()) {
      wait_host_drained(*pty, silence_limit);
      if (!opt.quiet)
        std::fprintf(stderr, "teamscan replay: done, %zu tx bytes matched\n", matched);
      return 0;
    }
    const bool waiting_for_host = records[next].kind == CaptureRecord::Kind::chunk &&
                                  records[next].direction == CaptureDirection::tx;
    if (waiting_for_host && now_monotonic() - last_activity > silence_limit) {
      std::fprintf(stderr, "teamscan replay: host silent for %.1f s at tx byte offset %zu; expected next: %s\n",
                   opt.silence_timeout_s, matched, hex_window(expected_tx, matched, 16).c_str());
      return 3;
    }
    const Duration sleep = std::clamp(wake - now_monotonic(), Duration::zero(), Duration{5ms});
    const timespec ts{0, static_cast<long>(sleep.count())};
    pollfd pfd{pty->master_fd(), POLLIN, 0};
    (void)::ppoll(&pfd, 1, &ts, nullptr);
  }
  std::fprintf(stderr, "teamscan replay: stopped by signal at tx byte offset %zu\n", matched);
  return 1;
}

const SubcommandRegistration kReplay{
    {"replay", "Serve a recorded capture's device side on a pty and check the host's bytes against it",
     [](CLI::App& app) {
       auto opt = std::make_shared<ReplayOptions>();
       app.add_option("file", opt->file, "Capture file (.cap)")->required()->check(CLI::ExistingFile);
       app.add_option("--link", opt->link_path, "Symlink to create for the host program")->required();
       app.add_option("--speed", opt->speed, "Time scale: 2 = twice as fast")->capture_default_str();
       app.add_option("--timeout", opt->silence_timeout_s, "Fail (exit 3) when the host is silent this long (s)")
           ->capture_default_str();
       app.add_flag("--quiet", opt->quiet, "Only report failures");
       return [opt] { return run_replay(*opt); };
     }}};

}  // namespace
}  // namespace teamscan::tool
