// LMS 2xx stream parser (PROTOCOLS.md §2.2): header hunt, length bounds, CRC check, re-scan.
#include "drivers/lms200/parser.hpp"

#include <algorithm>
#include <cstring>

namespace teamscan::lms200 {

const char* to_string(LmsEvent::Kind kind) {
  switch (kind) {
    case LmsEvent::Kind::telegram: return "telegram";
    case LmsEvent::Kind::ack: return "ack";
    case LmsEvent::Kind::nak: return "nak";
    case LmsEvent::Kind::bad_crc: return "bad_crc";
    case LmsEvent::Kind::bad_length: return "bad_length";
    case LmsEvent::Kind::garbage: return "garbage";
  }
  return "unknown";
}

void LmsParser::compact() {
  if (begin_ == 0) return;
  const std::size_t n = end_ - begin_;
  if (n > 0) std::memmove(buffer_.data(), buffer_.data() + begin_, n);
  begin_ = 0;
  end_ = n;
}

std::size_t LmsParser::feed(std::span<const std::uint8_t> bytes) {
  if (buffer_.size() - end_ < bytes.size()) compact();
  const std::size_t n = std::min(bytes.size(), buffer_.size() - end_);
  std::copy_n(bytes.begin(), n, buffer_.begin() + static_cast<std::ptrdiff_t>(end_));
  end_ += n;
  return n;
}

void LmsParser::reset() {
  stats_.discarded_bytes += end_ - begin_;
  begin_ = end_ = 0;
}

// An ACK/NAK is a lone byte between telegrams: accepted when it is the last byte so far or is
// followed by STX or another ACK/NAK. A 0x06/0x15 inside the remains of a broken telegram is
// followed by anything else and counts as discarded, so corruption does not inflate the ACK count.
bool LmsParser::is_handshake_at(std::size_t at) const {
  if (!is_handshake(buffer_[at])) return false;
  if (at + 1 >= end_) return true;
  const std::uint8_t next = buffer_[at + 1];
  return next == kStx || is_handshake(next);
}

// A byte at `at` can begin a telegram if it is STX and the next byte (if already here) is the address.
bool LmsParser::may_start_telegram(std::size_t at) const {
  if (buffer_[at] != kStx) return false;
  return at + 1 >= end_ || buffer_[at + 1] == address();
}

bool LmsParser::next(LmsEvent& event) {
  while (begin_ < end_) {
    const std::uint8_t* p = buffer_.data() + begin_;
    const std::size_t avail = end_ - begin_;

    if (is_handshake_at(begin_)) {
      // ACK/NAK are single bytes between telegrams (§2.2); they cannot be checked further.
      event.kind = p[0] == kAck ? LmsEvent::Kind::ack : LmsEvent::Kind::nak;
      event.bytes = std::span{p, 1};
      (p[0] == kAck ? stats_.acks : stats_.naks) += 1;
      ++begin_;
      return true;
    }

    if (!may_start_telegram(begin_)) {
      // A run of bytes that cannot start anything: one garbage event for the run.
      std::size_t n = 1;
      while (begin_ + n < end_ && !may_start_telegram(begin_ + n) && !is_handshake_at(begin_ + n)) ++n;
      event.kind = LmsEvent::Kind::garbage;
      event.bytes = std::span{p, n};
      stats_.discarded_bytes += n;
      begin_ += n;
      return true;
    }

    if (avail < kHeaderBytes) return false;  // STX (+ address) seen, length still to come
    const std::size_t length = static_cast<std::size_t>(p[2] | (p[3] << 8));
    if (length < min_length() || length > kMaxLength) {
      // Impossible length: this STX was not a header. Drop it alone and hunt again from the next byte.
      event.kind = LmsEvent::Kind::bad_length;
      event.bytes = std::span{p, 1};
      ++stats_.bad_length;
      ++stats_.resyncs;
      ++stats_.discarded_bytes;
      ++begin_;
      return true;
    }
    const std::size_t total = length + kFrameOverhead;
    if (avail < total) return false;
    const std::uint16_t crc = static_cast<std::uint16_t>(p[total - 2] | (p[total - 1] << 8));
    if (sick_crc16(std::span{p, total - 2}) != crc) {
      // Do not drop the whole candidate (a real telegram may start inside it): re-scan from STX + 1.
      event.kind = LmsEvent::Kind::bad_crc;
      event.bytes = std::span{p, 1};
      ++stats_.bad_crc;
      ++stats_.resyncs;
      ++stats_.discarded_bytes;
      ++begin_;
      return true;
    }
    event.kind = LmsEvent::Kind::telegram;
    event.bytes = std::span{p, total};
    ++stats_.telegrams;
    begin_ += total;
    return true;
  }
  return false;
}

}  // namespace teamscan::lms200
