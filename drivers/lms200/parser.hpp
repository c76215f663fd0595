// Stream parser for LMS 2xx telegrams (PROTOCOLS.md §2.2): hunts STX + address, bounds the length,
// checks the CRC and re-scans from the byte after a rejected STX, passes lone ACK/NAK bytes through,
// and counts everything it drops (STYLE.md 1–2: pure, no fd, no clock, no allocation).
//
// Use: feed() copies as many bytes as fit into the parser's fixed buffer and returns how many;
// next() then yields events until it returns false; feed the rest.
//     while (!in.empty()) { in = in.subspan(p.feed(in)); LmsEvent e; while (p.next(e)) handle(e); }
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>

#include "common/capacities.hpp"
#include "drivers/lms200/codec.hpp"

namespace teamscan::lms200 {

// Which side wrote the bytes: device replies start `02 80`, host telegrams `02 00` (§2.2).
enum class StreamDirection : std::uint8_t { from_device, to_device };

struct LmsParserStatistics {
  std::uint64_t telegrams = 0;        // accepted: framing and CRC good
  std::uint64_t bad_crc = 0;          // candidate telegrams whose CRC failed
  std::uint64_t bad_length = 0;       // candidate headers with a length outside the bounds
  std::uint64_t discarded_bytes = 0;  // bytes that belonged to no accepted telegram / ACK / NAK
  std::uint64_t resyncs = 0;          // times the parser went back to hunting after a rejected header
  std::uint64_t acks = 0;
  std::uint64_t naks = 0;
};

struct LmsEvent {
  enum class Kind : std::uint8_t { telegram, ack, nak, bad_crc, bad_length, garbage };
  Kind kind = Kind::garbage;
  // telegram: the whole verified telegram; ack/nak: the byte; bad_crc/bad_length: the rejected header
  // byte (STX) only — the rest is re-scanned; garbage: a run of discarded bytes. Valid until the next
  // feed()/next() call.
  std::span<const std::uint8_t> bytes;
};

[[nodiscard]] const char* to_string(LmsEvent::Kind kind);

class LmsParser {
 public:
  explicit LmsParser(StreamDirection direction = StreamDirection::from_device) : direction_{direction} {}

  // Copies up to the free space of the buffer; returns the number of bytes taken.
  std::size_t feed(std::span<const std::uint8_t> bytes);
  // The next event, if the buffered bytes decide one. False: more bytes needed.
  [[nodiscard]] bool next(LmsEvent& event);
  // Drops buffered bytes (counted as discarded), e.g. after the host changed its baud rate.
  void reset();

  [[nodiscard]] const LmsParserStatistics& statistics() const { return stats_; }
  [[nodiscard]] std::size_t buffered() const { return end_ - begin_; }
  [[nodiscard]] StreamDirection direction() const { return direction_; }

  // Smallest L: a host telegram has at least the command byte, a reply code + status byte.
  [[nodiscard]] std::size_t min_length() const { return direction_ == StreamDirection::from_device ? 2 : 1; }

 private:
  void compact();
  [[nodiscard]] std::uint8_t address() const {
    return direction_ == StreamDirection::from_device ? kAddressToHost : kAddressToLms;
  }
  [[nodiscard]] bool may_start_telegram(std::size_t at) const;
  [[nodiscard]] bool is_handshake_at(std::size_t at) const;
  [[nodiscard]] bool is_handshake(std::uint8_t b) const {
    return direction_ == StreamDirection::from_device && (b == kAck || b == kNak);
  }

  StreamDirection direction_;
  // Two telegrams' worth, so a maximal telegram always fits behind a partly consumed one.
  std::array<std::uint8_t, 2 * kMaxLmsTelegram> buffer_{};
  std::size_t begin_ = 0;
  std::size_t end_ = 0;
  LmsParserStatistics stats_;
};

}  // namespace teamscan::lms200
