// LmsParser: framing, bounds, statistics, and a corrupted stream (flips, drops, insertions at 1 % and
// 10 %, seeded): no corrupted telegram is accepted and every telegram whose bytes survived is found.
#include "drivers/lms200/parser.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <random>
#include <vector>

#include "drivers/lms200/scan.hpp"
#include "tests/unit/lms200/test_util.hpp"

namespace teamscan::lms200 {
namespace {

using test::hex;

struct Collected {
  std::vector<std::vector<std::uint8_t>> telegrams;
  std::vector<LmsEvent::Kind> kinds;
};

// Feeds `bytes` in chunks of `chunk` and collects every event.
Collected run(LmsParser& p, std::span<const std::uint8_t> bytes, std::size_t chunk = 4096) {
  Collected c;
  while (!bytes.empty()) {
    auto piece = bytes.first(std::min(chunk, bytes.size()));
    bytes = bytes.subspan(piece.size());
    while (!piece.empty()) {
      piece = piece.subspan(p.feed(piece));
      LmsEvent e;
      while (p.next(e)) {
        c.kinds.push_back(e.kind);
        if (e.kind == LmsEvent::Kind::telegram) c.telegrams.emplace_back(e.bytes.begin(), e.bytes.end());
      }
    }
  }
  return c;
}

TEST(LmsParser, OneTelegramAnyChunking) {
  const auto l17 = hex("02 80 03 00 A0 00 10 16 0A");
  for (std::size_t chunk = 1; chunk <= l17.size(); ++chunk) {
    LmsParser p;
    const auto c = run(p, l17, chunk);
    ASSERT_EQ(c.telegrams.size(), 1u) << chunk;
    EXPECT_EQ(c.telegrams[0], l17);
    EXPECT_EQ(p.statistics().telegrams, 1u);
    EXPECT_EQ(p.statistics().discarded_bytes, 0u);
  }
}

TEST(LmsParser, HostDirectionHuntsTwoZero) {
  const auto l1 = hex("02 00 01 00 31 15 12");
  LmsParser host{StreamDirection::to_device};
  EXPECT_EQ(run(host, l1).telegrams.size(), 1u);
  LmsParser device{StreamDirection::from_device};
  EXPECT_EQ(run(device, l1).telegrams.size(), 0u);  // 02 00 is not a reply header
  // Its CRC byte 0x15 is followed by 0x12, so it is no lone NAK either: all seven are discarded.
  EXPECT_EQ(device.statistics().discarded_bytes, l1.size());
  EXPECT_EQ(device.statistics().naks, 0u);
}

TEST(LmsParser, GarbageBeforeAndBetweenIsCountedAsOneRun) {
  auto bytes = hex("FF 02 02 77 01");
  const auto l20 = hex("02 80 02 00 92 10 7F 33");
  bytes.insert(bytes.end(), l20.begin(), l20.end());
  LmsParser p;
  const auto c = run(p, bytes);
  ASSERT_EQ(c.telegrams.size(), 1u);
  EXPECT_EQ(c.telegrams[0], l20);
  EXPECT_EQ(p.statistics().discarded_bytes, 5u);
}

TEST(LmsParser, BadCrcIsRescannedFromTheNextByte) {
  // A telegram with a broken CRC whose body hides a complete valid telegram.
  const auto l18 = hex("02 80 03 00 A0 01 10 14 0B");
  std::vector<std::uint8_t> bytes = {0x02, 0x80, 0x0C, 0x00};  // claims L = 12 -> 18 bytes total
  bytes.insert(bytes.end(), l18.begin(), l18.end());           // 9 bytes inside
  bytes.insert(bytes.end(), {0x00, 0x00, 0x00, 0x00, 0x00});    // 18 bytes, CRC wrong
  LmsParser p;
  const auto c = run(p, bytes);
  ASSERT_EQ(c.telegrams.size(), 1u);
  EXPECT_EQ(c.telegrams[0], l18);
  EXPECT_EQ(p.statistics().bad_crc, 1u);
  EXPECT_EQ(p.statistics().resyncs, 1u);
}

TEST(LmsParser, LengthBoundsAreEnforced) {
  LmsParser p;
  // L = 1 is too short for a reply (code + status), L = 0xFFFF exceeds the capacity.
  const auto c = run(p, hex("02 80 01 00 A0 00 00 02 80 FF FF"));
  EXPECT_EQ(p.statistics().bad_length, 2u);
  EXPECT_TRUE(c.telegrams.empty());
  LmsParser h{StreamDirection::to_device};
  (void)run(h, hex("02 00 00 00"));
  EXPECT_EQ(h.statistics().bad_length, 1u);
}

TEST(LmsParser, LoneAckAndNakBetweenTelegrams) {
  LmsParser p;
  const auto c = run(p, hex("06 02 80 03 00 A0 00 10 16 0A 15 06"));
  EXPECT_EQ(c.kinds, (std::vector<LmsEvent::Kind>{LmsEvent::Kind::ack, LmsEvent::Kind::telegram,
                                                  LmsEvent::Kind::nak, LmsEvent::Kind::ack}));
  EXPECT_EQ(p.statistics().acks, 2u);
  EXPECT_EQ(p.statistics().naks, 1u);
}

TEST(LmsParser, HandshakeBytesInsideGarbageAreNotAcks) {
  LmsParser p;
  const auto c = run(p, hex("77 06 77 15 33 06 02 80 03 00 A0 00 10 16 0A"));
  EXPECT_EQ(c.kinds, (std::vector<LmsEvent::Kind>{LmsEvent::Kind::garbage, LmsEvent::Kind::ack, LmsEvent::Kind::telegram}));
  EXPECT_EQ(p.statistics().acks, 1u);
  EXPECT_EQ(p.statistics().naks, 0u);
  EXPECT_EQ(p.statistics().discarded_bytes, 5u);
}

TEST(LmsParser, MaximalScanTelegramFitsAfterAPartialOne) {
  // A 401-value scan with the real-time index (813 bytes) behind a half-received one.
  std::array<std::uint16_t, 401> words{};
  for (std::size_t i = 0; i < words.size(); ++i) words[i] = static_cast<std::uint16_t>(i);
  std::array<std::uint8_t, kMaxLmsTelegram> t{};
  const std::size_t n = build_scan_reply(t, CountWord{401, 0, false, 1}.encode(), words, std::uint8_t{7});
  ASSERT_EQ(n, 813u);
  std::vector<std::uint8_t> bytes(t.begin(), t.begin() + 400);
  for (int k = 0; k < 3; ++k) bytes.insert(bytes.end(), t.begin(), t.begin() + static_cast<std::ptrdiff_t>(n));
  LmsParser p;
  const auto c = run(p, bytes, 1000);
  EXPECT_EQ(c.telegrams.size(), 3u);
  ScanTelegram s;
  ASSERT_TRUE(decode_scan(c.telegrams.back(), MeasuringMode::m8_fields_dazzle, s).ok());
  EXPECT_EQ(s.count, 401);
  EXPECT_EQ(s.realtime_index, std::optional<std::uint8_t>{7});
  EXPECT_EQ(s.ranges_mm[400], 400u);
}

// A long stream of device traffic: ACKs, mode/variant replies, 181- and 361-value scans.
std::vector<std::vector<std::uint8_t>> device_traffic(std::mt19937& rng, int count) {
  std::vector<std::vector<std::uint8_t>> out;
  std::array<std::uint8_t, kMaxLmsTelegram> b{};
  std::array<std::uint16_t, 361> words{};
  for (int k = 0; k < count; ++k) {
    std::size_t n = 0;
    switch (rng() % 4) {
      case 0: n = build_mode_reply(b, ModeResult::done); break;
      case 1: n = build_variant_reply(b, true, {180, 50}); break;
      default: {
        const std::uint16_t values = rng() % 2 ? 181 : 361;
        for (std::size_t i = 0; i < values; ++i) words[i] = static_cast<std::uint16_t>(rng() & 0x1FFF);
        n = build_scan_reply(b, CountWord{values, 0, false, 1}.encode(), std::span{words}.first(values), std::nullopt);
      }
    }
    out.emplace_back(b.begin(), b.begin() + static_cast<std::ptrdiff_t>(n));
  }
  return out;
}

void corruption_run(double rate, std::uint32_t seed) {
  std::mt19937 rng{seed};
  const auto originals = device_traffic(rng, 1500);
  std::vector<std::uint8_t> stream;
  std::vector<bool> intact;  // per original telegram: all its bytes passed unchanged
  std::uniform_real_distribution<double> u{0.0, 1.0};
  std::size_t acks_sent = 0;
  for (const auto& t : originals) {
    if (rng() % 3 == 0) {
      stream.push_back(kAck);  // lone ACK between telegrams (not checked: a single byte)
      ++acks_sent;
    }
    bool ok = true;
    for (const std::uint8_t byte : t) {
      const double r = u(rng);
      if (r < rate / 3) {  // flip
        stream.push_back(static_cast<std::uint8_t>(byte ^ (1u << (rng() % 8))));
        ok = false;
      } else if (r < 2 * rate / 3) {  // drop
        ok = false;
      } else if (r < rate) {  // insert a random byte before this one
        stream.push_back(static_cast<std::uint8_t>(rng()));
        stream.push_back(byte);
        ok = false;
      } else {
        stream.push_back(byte);
      }
    }
    intact.push_back(ok);
  }
  LmsParser p;
  const auto c = run(p, stream, 777);
  // Nothing accepted that is not one of the originals byte for byte.
  // (A linear search: a std::map keyed by the byte vectors trips GCC 12's -O3 -Wstringop-overread.)
  std::size_t foreign = 0;
  for (const auto& t : c.telegrams)
    if (std::find(originals.begin(), originals.end(), t) == originals.end()) ++foreign;
  EXPECT_EQ(foreign, 0u) << "rate " << rate;
  // Every intact original recovered: found telegrams, in order, cover every intact one.
  std::size_t next = 0;
  std::size_t recovered_intact = 0;
  std::size_t expected_intact = static_cast<std::size_t>(std::count(intact.begin(), intact.end(), true));
  for (std::size_t i = 0; i < originals.size(); ++i) {
    if (!intact[i]) continue;
    while (next < c.telegrams.size() && c.telegrams[next] != originals[i]) ++next;
    if (next < c.telegrams.size()) {
      ++recovered_intact;
      ++next;
    }
  }
  EXPECT_EQ(recovered_intact, expected_intact) << "rate " << rate;
  EXPECT_GT(expected_intact, 0u);
  EXPECT_GT(p.statistics().discarded_bytes, 0u);
  EXPECT_GT(p.statistics().resyncs, 0u);
  std::printf("rate %.2f: %zu telegrams, %zu intact, %zu accepted, bad_crc %llu bad_length %llu discarded %llu, acks %llu/%zu\n",
              rate, originals.size(), expected_intact, c.telegrams.size(),
              static_cast<unsigned long long>(p.statistics().bad_crc),
              static_cast<unsigned long long>(p.statistics().bad_length),
              static_cast<unsigned long long>(p.statistics().discarded_bytes),
              static_cast<unsigned long long>(p.statistics().acks), acks_sent);
}

TEST(LmsParser, CorruptionOnePercent) { corruption_run(0.01, 1); }
TEST(LmsParser, CorruptionOnePercentPerByteSecondSeed) { corruption_run(0.01, 2); }
TEST(LmsParser, CorruptionTenPercent) { corruption_run(0.10, 3); }

TEST(LmsParser, ResetDiscardsBufferedBytes) {
  LmsParser p;
  const auto half = hex("02 80 03 00 A0");
  (void)run(p, half);
  EXPECT_EQ(p.buffered(), half.size());
  p.reset();
  EXPECT_EQ(p.buffered(), 0u);
  EXPECT_EQ(p.statistics().discarded_bytes, half.size());
}

}  // namespace
}  // namespace teamscan::lms200
