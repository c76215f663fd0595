// teamscan-groundstation's long start-up and shutdown work asking systemd for more time as it goes
// (EXTEND_TIMEOUT_USEC, DDS_SYSTEMD.md): TimeoutStartSec and TimeoutStopSec are sized for a station with
// little to do, while reading a long session back at a restart or deciding it again at the stop takes
// time that grows with the session.
#pragma once

#include <chrono>
#include <functional>

#include "common/clock.hpp"
#include "dds/notify.hpp"

namespace teamscan::station::daemon {

// Each step says what it does (STATUS) and asks for kGrace more; within one, progressing() asks again
// at most once a second. A step that stops progressing is still killed when its grace runs out.
class TimeoutProgress {
 public:
  static constexpr Duration kGrace = std::chrono::seconds(30);
  void step(const char* what) {
    dds::notify_status(what);
    extend();
  }
  void progressing() {
    if (now_monotonic() - last_ >= std::chrono::seconds(1)) extend();
  }
  // progressing() as a progress callback (the fraction done is not needed).
  [[nodiscard]] std::function<void(double)> progress() {
    return [this](double) { progressing(); };
  }

 private:
  void extend() {
    dds::notify_extend_timeout(kGrace);
    last_ = now_monotonic();
  }
  Time last_ = now_monotonic();
};

}  // namespace teamscan::station::daemon
