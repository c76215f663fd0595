// One side of a serial link as a sans-I/O state machine (STYLE.md 1: no fd, no clock inside).
// Host clients (ArcosClient, LmsClient) and device emulators (PioneerEmulator, LmsEmulator) implement
// it; the I/O lives elsewhere: a SerialPort loop on the robot, a PtyRunner for emulated devices on
// pseudo-terminals, a VirtualLink for in-process simulation with byte timing.
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>

#include "common/time.hpp"

namespace teamscan::serial {

class SerialEndpoint {
 public:
  virtual ~SerialEndpoint() = default;
  // Bytes received from the other side (already at this side's line rate).
  virtual void on_rx(std::span<const std::uint8_t> bytes, Time now) = 0;
  // Time passed; run timers (keep-alive, timeouts, SIP cycle, scan cycle).
  virtual void on_tick(Time now) = 0;
  // Moves bytes this side wants to send now into `out`; returns how many (0 = nothing pending).
  virtual std::size_t take_tx(std::span<std::uint8_t> out) = 0;
  // The line rate this side's UART is set to now (a client changes it after a baud switch).
  [[nodiscard]] virtual std::uint32_t baud() const = 0;
  // The next time on_tick must be called at the latest (for event loops with timers).
  [[nodiscard]] virtual Time next_deadline() const = 0;
};

}  // namespace teamscan::serial
