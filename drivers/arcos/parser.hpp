// ArcosParser: pure stream parser for ARCOS packets (PROTOCOLS.md §1.2). Bytes in, verified packets
// and bad-input events out; no fd, no clock, no allocation (STYLE.md 1, 2). Unlike ARIA it re-scans
// the bytes after a rejected header for a new FA FB (§1.12 item 5), and it rejects count < 3 (§1.12 item 3).
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>

#include "drivers/arcos/codec.hpp"

namespace teamscan::arcos {

struct ArcosParserStatistics {
  std::uint64_t packets = 0;          // verified packets delivered
  std::uint64_t bad_checksum = 0;     // candidates (FA FB count ...) whose checksum failed
  std::uint64_t bad_length = 0;       // candidates with count < 3, or cut off by finish()
  std::uint64_t discarded_bytes = 0;  // bytes that ended up in no packet
  std::uint64_t resyncs = 0;          // packets found after bytes had been discarded (sync re-acquired)
};

class ArcosParser {
 public:
  enum class EventKind : std::uint8_t {
    kNeedMore,     // nothing more to report until more bytes are pushed
    kPacket,       // `packet` is a verified packet
    kBadChecksum,  // `bytes` is the rejected candidate; only its first byte is discarded, the rest re-scanned
    kBadLength,    // `bytes` is the rejected header (count < 3, or truncated at finish()); ditto
    kGarbage,      // `bytes` were skipped while hunting for FA FB
  };
  struct Event {
    EventKind kind = EventKind::kNeedMore;
    PacketView packet;                   // kPacket
    std::span<const std::uint8_t> bytes;  // the bytes concerned (all kinds but kNeedMore)
    std::uint64_t stream_offset = 0;      // offset of bytes[0] in the whole input stream
  };

  // Copies as many bytes as fit into the internal buffer; returns how many were taken. Call poll()
  // until kNeedMore, then feed the rest. Views of earlier events become invalid.
  std::size_t feed(std::span<const std::uint8_t> bytes);
  // Next event from the buffered bytes. Views stay valid until the next feed().
  Event poll();
  // End of input: a candidate still waiting for bytes is rejected (kBadLength) and the bytes after
  // its header re-scanned, so that nothing buffered is held back. Then poll() as usual.
  void finish() { finishing_ = true; }

  // Convenience: feed everything, calling on_packet(const PacketView&) for each verified packet.
  template <class OnPacket>
  void push(std::span<const std::uint8_t> bytes, OnPacket&& on_packet) {
    while (true) {
      const std::size_t n = feed(bytes);
      bytes = bytes.subspan(n);
      for (Event e = poll(); e.kind != EventKind::kNeedMore; e = poll()) {
        if (e.kind == EventKind::kPacket) on_packet(e.packet);
      }
      if (bytes.empty()) return;
    }
  }

  void reset();  // drop buffered bytes (e.g. after a device loss); statistics are kept
  [[nodiscard]] const ArcosParserStatistics& statistics() const { return stats_; }
  [[nodiscard]] std::size_t buffered() const { return end_ - head_; }

 private:
  Event discard(EventKind kind, std::size_t n);

  // Twice the largest packet, so a full candidate always fits after compaction.
  std::array<std::uint8_t, 2 * kMaxArcosPacket> buf_{};
  std::size_t head_ = 0, end_ = 0;
  std::uint64_t head_offset_ = 0;  // stream offset of buf_[head_]
  bool discarded_since_packet_ = false;
  bool finishing_ = false;
  ArcosParserStatistics stats_{};
};

}  // namespace teamscan::arcos
