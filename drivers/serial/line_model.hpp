// What a UART at the wrong rate receives: deterministic garbage (shared by PtyRunner and VirtualLink).
// A receiver sampling at another rate than the sender's sees framing errors and wrong bits; the exact
// pattern depends on the analogue timing, so the model only promises "not the byte that was sent",
// reproducibly, so that a client's rate probing and resynchronisation can be tested.
#pragma once

#include <cstdint>
#include <span>

#include "common/time.hpp"

namespace teamscan::serial {

class BaudMismatchGarbler {
 public:
  explicit BaudMismatchGarbler(std::uint32_t seed = 0x9E3779B9u) : state_{seed == 0 ? 1u : seed} {}

  // A byte the receiver did not send, from a xorshift32 stream mixed with the sent byte.
  [[nodiscard]] std::uint8_t garble(std::uint8_t sent) {
    state_ ^= state_ << 13;
    state_ ^= state_ >> 17;
    state_ ^= state_ << 5;
    auto out = static_cast<std::uint8_t>((state_ >> 24) ^ static_cast<std::uint32_t>(sent));
    if (out == sent) out = static_cast<std::uint8_t>(out ^ 0xA5u);
    return out;
  }
  void garble(std::span<std::uint8_t> bytes) {
    for (auto& b : bytes) b = garble(b);
  }

 private:
  std::uint32_t state_;
};

// Line time of one 8N1 byte (10 bits), and how many whole bytes fit in `elapsed` at `baud`.
[[nodiscard]] constexpr Duration byte_time(std::uint32_t baud) { return serial_transmission_time(1, baud); }
[[nodiscard]] constexpr std::int64_t bytes_in(Duration elapsed, std::uint32_t baud) {
  return elapsed.count() <= 0 ? 0 : elapsed.count() * static_cast<std::int64_t>(baud) / 10'000'000'000;
}

}  // namespace teamscan::serial
