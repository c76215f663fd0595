// VirtualLink: a host SerialEndpoint and a device SerialEndpoint joined by a simulated 8N1 cable, in
// simulated time (no threads, no sleeping). Bytes arrive when their last bit would have, at the
// sender's rate; a receiver at another rate gets garbage. Both directions and the host's rate
// changes are recorded as a common::Capture, so the simulator produces byte-exact captures of a
// whole session including the bring-up. Deterministic: the same endpoints give the same capture.
#pragma once

#include <cstddef>
#include <cstdint>
#include <deque>
#include <vector>

#include "common/capture.hpp"
#include "common/time.hpp"
#include "drivers/serial/endpoint.hpp"
#include "drivers/serial/line_model.hpp"

namespace teamscan::serial {

struct VirtualLinkOptions {
  DeviceKind device = DeviceKind::unknown;  // the capture's #device header
  Time start{};                             // simulated time at which the link starts
  // Bytes in flight are delivered in pieces of at most this much line time (at least one byte), so
  // a receiver sees a long telegram arrive progressively, as from a UART FIFO.
  Duration max_piece_time = 1ms;
  // When an endpoint's next_deadline() is not after the time it was last ticked, it is ticked again
  // this much later (an endpoint with no timer pending still gets called regularly).
  Duration idle_tick = 1ms;
  bool record = true;  // keep a Capture of the session
};

struct VirtualLinkStats {
  std::uint64_t bytes_to_device = 0;
  std::uint64_t bytes_to_host = 0;
  std::uint64_t garbled_bytes = 0;  // delivered to a receiver whose rate differed from the sender's
  std::uint64_t events = 0;         // loop steps (deliveries and ticks)
};

class VirtualLink {
 public:
  VirtualLink(SerialEndpoint& host, SerialEndpoint& device, VirtualLinkOptions options = {});

  // Advances simulated time event by event up to and including `t`; afterwards now() == t.
  void run_until(Time t);
  void run_for(Duration d) { run_until(now_ + d); }
  [[nodiscard]] Time now() const { return now_; }

  // The recorded session: times in µs since options.start; rx = device -> host as the host received it
  // (garbled on a rate mismatch), tx = host -> device as the host sent it; #baud = the host's rate.
  [[nodiscard]] const Capture& capture() const { return capture_; }
  [[nodiscard]] Capture take_capture() { return std::move(capture_); }
  [[nodiscard]] const VirtualLinkStats& stats() const { return stats_; }

 private:
  struct Piece {
    Time arrival;
    std::uint32_t baud = 0;  // the sender's rate when the bytes left
    std::vector<std::uint8_t> bytes;
  };
  struct Line {
    Time free_at;               // when the last byte queued on this wire has arrived
    std::deque<Piece> pieces;   // in arrival order
    BaudMismatchGarbler garbler;
    explicit Line(std::uint32_t seed) : garbler{seed} {}
  };
  struct Side {
    SerialEndpoint* endpoint;
    Time last_tick;
    bool ticked = false;
  };

  void pump(Side& from, Line& line);
  void deliver(Line& line, Side& to, CaptureDirection direction);
  void note_host_baud();
  [[nodiscard]] Time effective_deadline(const Side& side) const;
  [[nodiscard]] std::int64_t capture_us(Time t) const { return (t - options_.start).count() / 1000; }

  VirtualLinkOptions options_;
  Side host_;
  Side device_;
  Line to_device_{0x1234567u};
  Line to_host_{0x89ABCDEu};
  Time now_;
  std::uint32_t recorded_host_baud_ = 0;
  Capture capture_;
  VirtualLinkStats stats_;
};

}  // namespace teamscan::serial
