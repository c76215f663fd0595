// Helpers for the ARCOS tests: hex vectors (PROTOCOLS.md §3.1 notation) and an in-process link that
// steps two SerialEndpoints in simulated time (bytes only cross when both sides use the same rate).
#pragma once

#include <cstdint>
#include <random>
#include <span>
#include <string_view>
#include <vector>

#include "common/time.hpp"
#include "drivers/arcos/codec.hpp"
#include "drivers/serial/endpoint.hpp"

namespace teamscan::arcos::test {

inline std::vector<std::uint8_t> hex(std::string_view s) {
  std::vector<std::uint8_t> out;
  int hi = -1;
  for (char c : s) {
    int v = -1;
    if (c >= '0' && c <= '9') v = c - '0';
    else if (c >= 'A' && c <= 'F') v = c - 'A' + 10;
    else if (c >= 'a' && c <= 'f') v = c - 'a' + 10;
    if (v < 0) continue;
    if (hi < 0) {
      hi = v;
    } else {
      out.push_back(static_cast<std::uint8_t>(hi * 16 + v));
      hi = -1;
    }
  }
  return out;
}

inline std::vector<std::uint8_t> bytes_of(const PacketBuffer& p) { return {p.bytes.begin(), p.bytes.begin() + static_cast<std::ptrdiff_t>(p.size)}; }

inline std::vector<std::uint8_t> bytes_of_packet(const PacketBuffer& p) { return bytes_of(p); }

// Frames `body` (type byte + data) as a packet with a correct checksum.
inline std::vector<std::uint8_t> frame(std::span<const std::uint8_t> body) {
  std::vector<std::uint8_t> out;
  out.reserve(body.size() + 5);
  out.push_back(kHeader0);
  out.push_back(kHeader1);
  out.push_back(static_cast<std::uint8_t>(body.size() + 2));
  for (auto b : body) out.push_back(b);
  const std::uint16_t c = checksum(body);
  out.push_back(static_cast<std::uint8_t>(c >> 8));
  out.push_back(static_cast<std::uint8_t>(c & 0xFF));
  return out;
}

// Steps a host and a device endpoint every `step` of simulated time; bytes cross the link at once
// when the link direction is up and both sides use the same rate (otherwise they are lost, as
// a UART at the wrong rate would garble them).
struct Loop {
  Loop(serial::SerialEndpoint& h, serial::SerialEndpoint& d) : host{h}, device{d} {}
  serial::SerialEndpoint& host;
  serial::SerialEndpoint& device;
  Time now = Time::from_seconds(1000.0);
  bool host_to_device_up = true;
  bool device_to_host_up = true;
  std::vector<Time> host_tx_times;                   // when host bytes were delivered
  std::vector<std::uint8_t> host_tx_bytes;           // everything the host sent (any rate)
  std::vector<std::uint8_t> device_tx_bytes;         // everything the device sent, before corruption
  std::vector<std::uint32_t> host_tx_bauds;          // the host's rate for each delivery
  double corruption = 0.0;                           // per byte: probability of a flipped byte
  std::mt19937 rng{99};
  std::uint64_t corrupted_bytes = 0;

  void corrupt(std::uint8_t* b, std::size_t n) {
    if (corruption <= 0.0) return;
    std::uniform_real_distribution<double> u{0.0, 1.0};
    for (std::size_t i = 0; i < n; ++i) {
      if (u(rng) < corruption) {
        b[i] = static_cast<std::uint8_t>(b[i] ^ static_cast<std::uint8_t>(1 + rng() % 255));
        ++corrupted_bytes;
      }
    }
  }

  void step_once(Duration step) {
    now += step;
    host.on_tick(now);
    device.on_tick(now);
    std::uint8_t buf[4096];
    const std::size_t n = host.take_tx(buf);
    if (n > 0) {
      host_tx_times.push_back(now);
      host_tx_bauds.push_back(host.baud());
      host_tx_bytes.insert(host_tx_bytes.end(), buf, buf + n);
      corrupt(buf, n);
      if (host_to_device_up && host.baud() == device.baud()) device.on_rx({buf, n}, now);
    }
    const std::size_t m = device.take_tx(buf);
    if (m > 0) device_tx_bytes.insert(device_tx_bytes.end(), buf, buf + m);
    corrupt(buf, m);
    if (m > 0 && device_to_host_up && host.baud() == device.baud()) host.on_rx({buf, m}, now);
  }
  void run_for(Duration d, Duration step = 1ms) {
    const Time end = now + d;
    while (now < end) step_once(step);
  }
  template <class Pred>
  bool run_until(Pred pred, Duration limit, Duration step = 1ms) {
    const Time end = now + limit;
    while (now < end) {
      step_once(step);
      if (pred()) return true;
    }
    return false;
  }
};

}  // namespace teamscan::arcos::test
