// VirtualLink: event-by-event simulation of an 8N1 cable between two SerialEndpoints (see header).
#include "drivers/serial/virtual_link.hpp"

#include <algorithm>
#include <array>

#include "common/result.hpp"

namespace teamscan::serial {

VirtualLink::VirtualLink(SerialEndpoint& host, SerialEndpoint& device, VirtualLinkOptions options)
    : options_{options}, host_{&host, options.start}, device_{&device, options.start}, now_{options.start} {
  TEAMSCAN_EXPECTS(options_.idle_tick > Duration::zero());
  capture_.device = options_.device;
  to_device_.free_at = now_;
  to_host_.free_at = now_;
  note_host_baud();
}

Time VirtualLink::effective_deadline(const Side& side) const {
  const Time deadline = side.endpoint->next_deadline();
  if (side.ticked && deadline <= side.last_tick) return side.last_tick + options_.idle_tick;
  return deadline;
}

void VirtualLink::note_host_baud() {
  const std::uint32_t baud = host_.endpoint->baud();
  if (baud == recorded_host_baud_) return;
  recorded_host_baud_ = baud;
  if (!options_.record) return;
  CaptureRecord r;
  r.kind = CaptureRecord::Kind::baud;
  r.time_us = capture_us(now_);
  r.baud = baud;
  capture_.records.push_back(std::move(r));
}

// Moves what `from` wants to send onto the wire: the bytes queue behind those still in flight and
// each piece arrives when its last bit has, at the sender's current rate (10 bits per byte).
void VirtualLink::pump(Side& from, Line& line) {
  std::array<std::uint8_t, 4096> buf{};
  for (int round = 0; round < 64; ++round) {
    // The rate in force when the bytes are handed over is the rate they go out at: a device that
    // switches rate after queueing its ACK still sends that ACK at the old rate.
    const std::uint32_t baud = from.endpoint->baud();
    const std::size_t n = from.endpoint->take_tx(buf);
    if (n == 0) break;
    TEAMSCAN_EXPECTS(n <= buf.size());
    TEAMSCAN_EXPECTS(baud > 0);
    const Time start = std::max(now_, line.free_at);
    const auto piece_bytes = static_cast<std::size_t>(std::max<std::int64_t>(1, bytes_in(options_.max_piece_time, baud)));
    for (std::size_t off = 0; off < n; off += piece_bytes) {
      const std::size_t end = std::min(n, off + piece_bytes);
      Piece p;
      p.arrival = start + serial_transmission_time(static_cast<std::int64_t>(end), baud);
      p.baud = baud;
      p.bytes.assign(buf.begin() + static_cast<std::ptrdiff_t>(off), buf.begin() + static_cast<std::ptrdiff_t>(end));
      line.pieces.push_back(std::move(p));
    }
    line.free_at = start + serial_transmission_time(static_cast<std::int64_t>(n), baud);
  }
}

void VirtualLink::deliver(Line& line, Side& to, CaptureDirection direction) {
  Piece p = std::move(line.pieces.front());
  line.pieces.pop_front();
  std::vector<std::uint8_t> bytes = p.bytes;
  if (p.baud != to.endpoint->baud()) {
    line.garbler.garble(bytes);
    stats_.garbled_bytes += bytes.size();
  }
  if (direction == CaptureDirection::tx) stats_.bytes_to_device += bytes.size();
  else stats_.bytes_to_host += bytes.size();
  if (options_.record) {
    // The capture is what a recorder beside the host sees: tx as the host sent it, rx as it arrived.
    CaptureRecord r;
    r.kind = CaptureRecord::Kind::chunk;
    r.time_us = capture_us(now_);
    r.direction = direction;
    r.bytes = direction == CaptureDirection::tx ? std::move(p.bytes) : bytes;
    capture_.records.push_back(std::move(r));
  }
  to.endpoint->on_rx(bytes, now_);
}

void VirtualLink::run_until(Time t) {
  for (;;) {
    pump(host_, to_device_);
    pump(device_, to_host_);
    note_host_baud();

    Time next = std::min(effective_deadline(host_), effective_deadline(device_));
    if (!to_device_.pieces.empty()) next = std::min(next, to_device_.pieces.front().arrival);
    if (!to_host_.pieces.empty()) next = std::min(next, to_host_.pieces.front().arrival);
    if (next > t) break;
    now_ = std::max(now_, next);
    ++stats_.events;

    // Everything due now, in arrival order; on a tie the device's bytes first (a fixed rule keeps
    // the run deterministic).
    for (;;) {
      const bool host_due = !to_host_.pieces.empty() && to_host_.pieces.front().arrival <= now_;
      const bool device_due = !to_device_.pieces.empty() && to_device_.pieces.front().arrival <= now_;
      if (!host_due && !device_due) break;
      if (host_due && (!device_due || to_host_.pieces.front().arrival <= to_device_.pieces.front().arrival))
        deliver(to_host_, host_, CaptureDirection::rx);
      else
        deliver(to_device_, device_, CaptureDirection::tx);
    }
    if (effective_deadline(device_) <= now_) {
      device_.endpoint->on_tick(now_);
      device_.last_tick = now_;
      device_.ticked = true;
    }
    if (effective_deadline(host_) <= now_) {
      host_.endpoint->on_tick(now_);
      host_.last_tick = now_;
      host_.ticked = true;
    }
  }
  now_ = std::max(now_, t);
}

}  // namespace teamscan::serial
