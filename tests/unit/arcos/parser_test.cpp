// ArcosParser: framing, rejection of bad counts and checksums with re-scan (PROTOCOLS.md §1.2,
// §1.12), statistics, and a long corrupted stream (flips, drops, insertions at 1 % and 10 %).
#include <gtest/gtest.h>

#include <cstdio>
#include <random>
#include <vector>

#include "drivers/arcos/parser.hpp"
#include "tests/unit/arcos/test_support.hpp"

namespace teamscan::arcos {
namespace {

using test::bytes_of;
using test::hex;

std::vector<std::vector<std::uint8_t>> parse_all(ArcosParser& p, std::span<const std::uint8_t> in, bool finish = true) {
  std::vector<std::vector<std::uint8_t>> out;
  p.push(in, [&](const PacketView& v) { out.emplace_back(v.wire.begin(), v.wire.end()); });
  if (finish) {
    p.finish();
    p.push({}, [&](const PacketView& v) { out.emplace_back(v.wire.begin(), v.wire.end()); });
  }
  return out;
}

TEST(ArcosParser, FindsPacketsBetweenGarbage) {
  auto in = hex("00 11 FA 22 FB");
  const auto a7 = hex("FA FB 06 0B 3B C8 00 D3 3B");
  const auto a1 = hex("FA FB 03 00 00 00");
  in.insert(in.end(), a7.begin(), a7.end());
  in.push_back(0x55);
  in.insert(in.end(), a1.begin(), a1.end());
  ArcosParser p;
  const auto got = parse_all(p, in);
  ASSERT_EQ(got.size(), 2U);
  EXPECT_EQ(got[0], a7);
  EXPECT_EQ(got[1], a1);
  EXPECT_EQ(p.statistics().packets, 2U);
  EXPECT_EQ(p.statistics().discarded_bytes, 6U);
  EXPECT_EQ(p.statistics().resyncs, 2U);
  EXPECT_EQ(p.statistics().bad_checksum, 0U);
}

TEST(ArcosParser, ByteAtATimeGivesTheSamePackets) {
  std::vector<std::uint8_t> in;
  for (int i = 0; i < 50; ++i) {
    const auto pk = bytes_of(make_command(Command::kVel, i * 7 - 100));
    in.insert(in.end(), pk.begin(), pk.end());
  }
  ArcosParser whole, bytewise;
  const auto a = parse_all(whole, in);
  std::vector<std::vector<std::uint8_t>> b;
  for (auto byte : in) {
    bytewise.push({&byte, 1}, [&](const PacketView& v) { b.emplace_back(v.wire.begin(), v.wire.end()); });
  }
  EXPECT_EQ(a.size(), 50U);
  EXPECT_EQ(a, b);
}

TEST(ArcosParser, CorruptedVelPacketRejectedAndFollowingPacketFound) {
  // §1.12 item 1 regression: the corrupted VEL packet must not be accepted.
  auto in = hex("FA FB 06 0B 3B 88 00 D3 3B");
  const auto a6 = hex("FA FB 06 04 3B 01 00 05 3B");
  in.insert(in.end(), a6.begin(), a6.end());
  ArcosParser p;
  const auto got = parse_all(p, in);
  ASSERT_EQ(got.size(), 1U);
  EXPECT_EQ(got[0], a6);
  EXPECT_EQ(p.statistics().bad_checksum, 1U);
  EXPECT_EQ(p.statistics().discarded_bytes, 9U);
}

TEST(ArcosParser, CountsBelowThreeAreRejected) {
  for (std::uint8_t count : {0, 1, 2}) {
    SCOPED_TRACE(count);
    std::vector<std::uint8_t> in = {0xFA, 0xFB, count};
    const auto a1 = hex("FA FB 03 00 00 00");
    in.insert(in.end(), a1.begin(), a1.end());
    ArcosParser p;
    const auto got = parse_all(p, in);
    ASSERT_EQ(got.size(), 1U);
    EXPECT_EQ(got[0], a1);
    EXPECT_EQ(p.statistics().bad_length, 1U);
    EXPECT_EQ(p.statistics().discarded_bytes, 3U);
  }
}

TEST(ArcosParser, GoodPacketInsideACorruptedHeaderIsRescanned) {
  // A header whose count was corrupted to 0x40 swallows the next packets; ARIA would drop them all
  // (§1.12 item 5). The re-scan must find every one of them.
  std::vector<std::uint8_t> in = {0xFA, 0xFB, 0x40, 0x0B};
  std::vector<std::vector<std::uint8_t>> expect;
  for (int i = 0; i < 8; ++i) {
    expect.push_back(bytes_of(make_command(Command::kRVel, i)));
    in.insert(in.end(), expect.back().begin(), expect.back().end());
  }
  ArcosParser p;
  EXPECT_EQ(parse_all(p, in), expect);
  EXPECT_EQ(p.statistics().bad_checksum, 1U);
}

TEST(ArcosParser, TruncatedPacketAtEndIsReportedOnFinish) {
  const auto a7 = hex("FA FB 06 0B 3B C8 00 D3");  // last byte missing
  ArcosParser p;
  std::vector<ArcosParser::EventKind> kinds;
  p.feed(a7);
  for (auto e = p.poll(); e.kind != ArcosParser::EventKind::kNeedMore; e = p.poll()) kinds.push_back(e.kind);
  EXPECT_TRUE(kinds.empty());  // waiting for the last byte
  p.finish();
  for (auto e = p.poll(); e.kind != ArcosParser::EventKind::kNeedMore; e = p.poll()) kinds.push_back(e.kind);
  ASSERT_EQ(kinds.size(), 2U);
  EXPECT_EQ(kinds[0], ArcosParser::EventKind::kBadLength);
  EXPECT_EQ(kinds[1], ArcosParser::EventKind::kGarbage);
  EXPECT_EQ(p.statistics().discarded_bytes, a7.size());
  EXPECT_EQ(p.buffered(), 0U);
}

TEST(ArcosParser, EventsCarryStreamOffsets) {
  auto in = hex("01 02 03");
  const auto a1 = hex("FA FB 03 00 00 00");
  in.insert(in.end(), a1.begin(), a1.end());
  ArcosParser p;
  p.feed(in);
  auto g = p.poll();
  EXPECT_EQ(g.kind, ArcosParser::EventKind::kGarbage);
  EXPECT_EQ(g.stream_offset, 0U);
  EXPECT_EQ(g.bytes.size(), 3U);
  auto k = p.poll();
  EXPECT_EQ(k.kind, ArcosParser::EventKind::kPacket);
  EXPECT_EQ(k.stream_offset, 3U);
  EXPECT_EQ(k.packet.type, 0);
}

// ---- corruption ----

struct Corrupted {
  std::vector<std::uint8_t> bytes;
  std::vector<std::vector<std::uint8_t>> intact;  // the packets that survived, in order
  std::size_t packets = 0, modified = 0;
};

// A stream of distinct valid packets (SIPs with a sequence number, commands, CONFIG) with, per byte,
// probability `rate` of a modification: a flipped byte, a dropped byte or an inserted random byte
// (one third each). "Intact" means: none of the packet's own bytes was flipped or dropped and no
// byte was inserted between its first and its last byte. Insertions before its first byte or after
// its last byte leave it intact.
Corrupted make_corrupted_stream(std::size_t n_packets, double rate, std::uint32_t seed) {
  std::mt19937 rng{seed};
  std::uniform_real_distribution<double> u{0.0, 1.0};
  Corrupted c;
  for (std::size_t i = 0; i < n_packets; ++i) {
    PacketBuffer pk;
    switch (i % 4) {
      case 0: case 1: {
        SipPacket s;
        s.x_raw = static_cast<std::uint16_t>(i);
        s.y_raw = static_cast<std::uint16_t>(i * 3);
        s.sonar_count = static_cast<std::uint8_t>(i % 8);
        for (std::size_t k = 0; k < s.sonar_count; ++k) s.sonar[k] = {static_cast<std::uint8_t>(k), static_cast<std::uint16_t>(rng() & 0xFFFF)};
        s.tail_fields = static_cast<std::uint8_t>(i % 15);
        s.type = (i % 2) ? 0x33 : 0x32;
        pk = encode_sip(s);
        break;
      }
      case 2: pk = make_command(Command::kVel, static_cast<std::int32_t>(i % 2000) - 1000); break;
      default: {
        const std::uint8_t say[] = {static_cast<std::uint8_t>(i), static_cast<std::uint8_t>(i >> 8), 0xFA, 0xFB};
        pk = make_command_string(Command::kSay, say);  // FA FB inside the data: a false header
        break;
      }
    }
    bool intact = true;
    for (std::size_t b = 0; b < pk.size; ++b) {
      const double r = u(rng);
      if (r < rate / 3) {  // flip: XOR with a non-zero value
        c.bytes.push_back(static_cast<std::uint8_t>(pk.bytes[b] ^ static_cast<std::uint8_t>(1 + rng() % 255)));
        intact = false;
      } else if (r < 2 * rate / 3) {  // drop
        intact = false;
      } else if (r < rate) {  // insert a random byte before this one
        c.bytes.push_back(static_cast<std::uint8_t>(rng()));
        c.bytes.push_back(pk.bytes[b]);
        if (b > 0) intact = false;
      } else {
        c.bytes.push_back(pk.bytes[b]);
        continue;
      }
      ++c.modified;
    }
    if (intact) c.intact.emplace_back(pk.bytes.begin(), pk.bytes.begin() + static_cast<std::ptrdiff_t>(pk.size));
    ++c.packets;
  }
  return c;
}

void check_corruption(double rate, std::uint32_t seed, double max_false_accepts) {
  const Corrupted c = make_corrupted_stream(20000, rate, seed);
  ASSERT_GT(c.modified, 0U);
  ArcosParser p;
  // Feed in irregular chunks, as reads from a port would come.
  std::vector<std::vector<std::uint8_t>> got;
  std::mt19937 rng{seed + 1};
  std::span<const std::uint8_t> rest{c.bytes};
  while (!rest.empty()) {
    const std::size_t n = std::min<std::size_t>(rest.size(), 1 + rng() % 300);
    p.push(rest.first(n), [&](const PacketView& v) { got.emplace_back(v.wire.begin(), v.wire.end()); });
    rest = rest.subspan(n);
  }
  p.finish();
  p.push({}, [&](const PacketView& v) { got.emplace_back(v.wire.begin(), v.wire.end()); });
  // Every intact packet is recovered, in order; anything else accepted is a corrupted packet.
  std::size_t next_intact = 0, false_accepts = 0;
  for (const auto& g : got) {
    if (next_intact < c.intact.size() && g == c.intact[next_intact]) {
      ++next_intact;
    } else {
      ++false_accepts;
    }
  }
  EXPECT_EQ(next_intact, c.intact.size()) << "intact packets lost";
  // A 16-bit checksum passes a random candidate with probability 2^-16: the floor of any ARCOS
  // receiver. The parser adds nothing to it (no corrupted packet passes a check it should fail);
  // the bound allows that floor for the candidates this stream produced.
  const auto& st = p.statistics();
  const double expected_false = static_cast<double>(st.bad_checksum + 1) / 65536.0;
  std::printf("rate %.2f: %zu packets, %zu modifications, %zu intact, %zu accepted, %zu corrupted accepted "
              "(checksum floor expects %.2f), bad_checksum %llu, bad_length %llu, resyncs %llu\n",
              rate, c.packets, c.modified, c.intact.size(), got.size(), false_accepts, expected_false,
              static_cast<unsigned long long>(st.bad_checksum), static_cast<unsigned long long>(st.bad_length),
              static_cast<unsigned long long>(st.resyncs));
  EXPECT_LE(static_cast<double>(false_accepts), max_false_accepts);
  const auto& s = p.statistics();
  EXPECT_EQ(s.packets, got.size());
  EXPECT_GT(s.bad_checksum + s.bad_length, 0U);
  EXPECT_GT(s.resyncs, 0U);
  // Every byte is either in an accepted packet or counted as discarded.
  std::size_t accepted_bytes = 0;
  for (const auto& g : got) accepted_bytes += g.size();
  EXPECT_EQ(accepted_bytes + s.discarded_bytes, c.bytes.size());
}

TEST(ArcosParserCorruption, OnePercent) { check_corruption(0.01, 20261122, 0); }
TEST(ArcosParserCorruption, TenPercent) { check_corruption(0.10, 4242, 1); }
TEST(ArcosParserCorruption, NoCorruptionRecoversEverything) {
  const Corrupted c = make_corrupted_stream(2000, 0.0, 7);
  ArcosParser p;
  EXPECT_EQ(parse_all(p, c.bytes), c.intact);
  EXPECT_EQ(c.intact.size(), 2000U);
  EXPECT_EQ(p.statistics().discarded_bytes, 0U);
}

}  // namespace
}  // namespace teamscan::arcos
