// ArcosParser: see parser.hpp. Hunting, count check, checksum check, re-scan on failure.
#include "drivers/arcos/parser.hpp"

#include <algorithm>
#include <cstring>

namespace teamscan::arcos {

std::size_t ArcosParser::feed(std::span<const std::uint8_t> bytes) {
  if (head_ > 0) {  // compact: the live bytes move to the front
    std::memmove(buf_.data(), buf_.data() + head_, end_ - head_);
    end_ -= head_;
    head_ = 0;
  }
  const std::size_t n = std::min(bytes.size(), buf_.size() - end_);
  if (n > 0) std::memcpy(buf_.data() + end_, bytes.data(), n);
  end_ += n;
  if (n > 0) finishing_ = false;
  return n;
}

void ArcosParser::reset() {
  head_offset_ += end_ - head_;
  head_ = end_ = 0;
  discarded_since_packet_ = false;
  finishing_ = false;
}

ArcosParser::Event ArcosParser::discard(EventKind kind, std::size_t n) {
  Event e;
  e.kind = kind;
  e.bytes = {buf_.data() + head_, n};
  e.stream_offset = head_offset_;
  stats_.discarded_bytes += n;
  discarded_since_packet_ = true;
  head_ += n;
  head_offset_ += n;
  return e;
}

ArcosParser::Event ArcosParser::poll() {
  const std::size_t avail = end_ - head_;
  if (avail == 0) return {};
  const std::uint8_t* p = buf_.data() + head_;

  // Hunt: skip everything before the next FA that could start FA FB.
  std::size_t skip = 0;
  while (skip < avail) {
    if (p[skip] == kHeader0 && (skip + 1 == avail || p[skip + 1] == kHeader1)) break;
    ++skip;
  }
  if (skip > 0) return discard(EventKind::kGarbage, skip);
  if (avail < 3) {
    if (!finishing_) return {};
    return discard(EventKind::kGarbage, avail);  // a lone FA or FA FB at the end of input
  }

  const std::size_t count = p[2];
  if (count < kMinCount) {  // §1.12 item 3: count 0/1/2 would wrap ARIA's body length
    ++stats_.bad_length;
    Event e = discard(EventKind::kBadLength, 1);
    e.bytes = {p, 3};
    return e;
  }
  const std::size_t total = count + 3;
  if (avail < total) {
    if (!finishing_) return {};
    ++stats_.bad_length;  // truncated by the end of input
    Event e = discard(EventKind::kBadLength, 1);
    e.bytes = {p, avail};
    return e;
  }
  const auto candidate = std::span<const std::uint8_t>{p, total};
  auto view = verify_packet(candidate);
  if (!view.ok()) {
    // §1.12 item 5: drop only the FA; the bytes after it are hunted again, so a good packet hidden
    // behind a corrupted header (e.g. an inflated count) is still found.
    ++stats_.bad_checksum;
    Event e = discard(EventKind::kBadChecksum, 1);
    e.bytes = candidate;
    return e;
  }
  Event e;
  e.kind = EventKind::kPacket;
  e.packet = view.value();
  e.bytes = candidate;
  e.stream_offset = head_offset_;
  ++stats_.packets;
  if (discarded_since_packet_) ++stats_.resyncs;
  discarded_since_packet_ = false;
  head_ += total;
  head_offset_ += total;
  return e;
}

}  // namespace teamscan::arcos
