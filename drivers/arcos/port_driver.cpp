// ArcosPortDriver and the pty entry point of the emulated Pioneer; see port_driver.hpp.
#include "drivers/arcos/port_driver.hpp"

#include <time.h>

#include <algorithm>
#include <cstring>

#include "common/clock.hpp"

namespace teamscan::arcos {

ArcosPortDriver::ArcosPortDriver(ArcosClient& client, const char* path, Duration reopen_period)
    : client_{client}, reopen_period_{reopen_period} {
  std::strncpy(path_.data(), path, path_.size() - 1);
}

void ArcosPortDriver::lose(Time now, const Error& e) {
  last_error_ = e;
  ++stats_.losses;
  port_.close();
  lost_ = true;
  next_open_ = now + reopen_period_;
  client_.on_device_lost(now);
}

void ArcosPortDriver::step(Duration max_wait) {
  Time now = now_monotonic();
  if (!port_.is_open()) {
    if (now >= next_open_) {
      auto p = serial::SerialPort::open(path_.data(), client_.baud());
      if (p.ok()) {
        port_ = std::move(p.value());
        ++stats_.opens;
        if (lost_) client_.on_device_back(now);
        lost_ = false;
      } else {
        ++stats_.open_failures;
        last_error_ = p.error();
        next_open_ = now + reopen_period_;
      }
    }
    if (!port_.is_open()) {
      const Duration wait = std::min(max_wait, next_open_ - now);
      if (wait > 0ns) {
        const timespec ts{static_cast<time_t>(wait.count() / 1'000'000'000), static_cast<long>(wait.count() % 1'000'000'000)};
        ::nanosleep(&ts, nullptr);
      }
      return;
    }
  }
  client_.on_tick(now);
  // The client's rate applies to the bytes it queued in this state (ARIA's CLOSE cycle, §1.4).
  if (port_.baud() != client_.baud()) {
    if (auto s = port_.set_baud(client_.baud()); !s.ok()) return lose(now, s.error());
  }
  const std::size_t n = client_.take_tx(buf_);
  if (n > 0) {
    if (auto s = port_.write_all({buf_.data(), n}, 200ms); !s.ok()) return lose(now, s.error());
    stats_.bytes_written += n;
  }
  now = now_monotonic();
  const Duration wait = std::clamp(client_.next_deadline() - now, Duration{0}, max_wait);
  auto r = port_.read(buf_, wait);
  if (!r.ok()) return lose(now_monotonic(), r.error());
  if (r.value() > 0) {
    stats_.bytes_read += r.value();
    client_.on_rx({buf_.data(), r.value()}, now_monotonic());
  }
}

void ArcosPortDriver::run_until(Time stop_at, Duration max_wait) {
  while (now_monotonic() < stop_at) step(max_wait);
}

Result<std::unique_ptr<serial::PtyRunner>> run_pioneer_on_pty(PioneerEmulator& robot, const std::string& link_path) {
  serial::PtyRunnerOptions o;
  o.link_path = link_path;
  auto runner = serial::PtyRunner::create(robot, o);
  if (!runner.ok()) return runner.error();
  if (auto s = runner.value()->start(); !s.ok()) return s.error();
  return std::move(runner.value());
}

}  // namespace teamscan::arcos
