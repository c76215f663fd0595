// LMS 2xx codec: the SICK CRC check values and every vector of PROTOCOLS.md §3.2 (L1–L21) and the
// public anchors of §5, as exact bytes, encoded by the builders and decoded back.
#include "drivers/lms200/codec.hpp"

#include <gtest/gtest.h>

#include <array>
#include <string_view>

#include "drivers/lms200/parser.hpp"
#include "drivers/lms200/scan.hpp"
#include "tests/unit/lms200/test_util.hpp"

namespace teamscan::lms200 {
namespace {

using test::hex;
using Buffer = std::array<std::uint8_t, kMaxLmsTelegram>;

std::span<const std::uint8_t> text(std::string_view s) {
  return {reinterpret_cast<const std::uint8_t*>(s.data()), s.size()};
}

// Builds with `fn` and returns the bytes.
template <class F>
std::vector<std::uint8_t> build(F fn) {
  Buffer b{};
  const std::size_t n = fn(std::span{b});
  EXPECT_GT(n, 0u);
  return test::bytes_of(b, n);
}

TEST(SickCrc, CheckValuesOfSection23) {
  EXPECT_EQ(sick_crc16(text("123456789")), 0xA656);
  EXPECT_EQ(sick_crc16(text(" ")), 0x0020);
  EXPECT_EQ(sick_crc16(text("Lammert Bies")), 0x0811);
  EXPECT_EQ(sick_crc16({}), 0x0000);
}

TEST(SickCrc, WireOrderIsLowByteFirst) {
  // L1 ends 15 12: register 0x1215.
  const auto l1 = hex("02 00 01 00 31");
  EXPECT_EQ(sick_crc16(l1), 0x1215);
}

TEST(LmsCodec, HostCommandVectorsL1ToL16) {
  EXPECT_EQ(build([](auto o) { return build_status_request(o); }), hex("02 00 01 00 31 15 12"));  // L1
  EXPECT_EQ(build([](auto o) { return build_start_continuous(o); }), hex("02 00 02 00 20 24 34 08"));  // L2
  EXPECT_EQ(build([](auto o) { return build_stop_continuous(o); }), hex("02 00 02 00 20 25 35 08"));  // L3
  EXPECT_EQ(build([](auto o) { return build_setup_mode(o); }),
            hex("02 00 0A 00 20 00 53 49 43 4B 5F 4C 4D 53 BE C5"));  // L4
  EXPECT_EQ(build([](auto o) { return build_baud_switch(o, 38400); }), hex("02 00 02 00 20 40 50 08"));   // L5
  EXPECT_EQ(build([](auto o) { return build_baud_switch(o, 19200); }), hex("02 00 02 00 20 41 51 08"));   // L6
  EXPECT_EQ(build([](auto o) { return build_baud_switch(o, 9600); }), hex("02 00 02 00 20 42 52 08"));    // L7
  EXPECT_EQ(build([](auto o) { return build_baud_switch(o, 500000); }), hex("02 00 02 00 20 48 58 08"));  // L8
  EXPECT_EQ(build([](auto o) { return build_poll_scan(o); }), hex("02 00 02 00 30 01 31 18"));  // L9
  EXPECT_EQ(build([](auto o) { return build_variant(o, {180, 100}); }),
            hex("02 00 05 00 3B B4 00 64 00 97 49"));  // L10
  EXPECT_EQ(build([](auto o) { return build_variant(o, {180, 50}); }),
            hex("02 00 05 00 3B B4 00 32 00 3B 1F"));  // L11
  EXPECT_EQ(build([](auto o) { return build_variant(o, {100, 25}); }),
            hex("02 00 05 00 3B 64 00 19 00 E7 72"));  // L12
  EXPECT_EQ(build([](auto o) { return build_reset(o); }), hex("02 00 01 00 10 34 12"));        // L13
  EXPECT_EQ(build([](auto o) { return build_read_config(o); }), hex("02 00 01 00 74 50 12"));  // L14
  EXPECT_EQ(build([](auto o) { return build_store_permanent(o, 0x01); }), hex("02 00 02 00 66 01 9D 4E"));  // L15
  std::array<std::uint8_t, 32> cfg{};
  cfg[6] = 0x01;  // units mm
  cfg[9] = 0x02;  // multiple evaluation 2
  cfg[10] = 0x02; // restart mode 2
  const auto l16 = hex("02 00 21 00 77 00 00 00 00 00 00 01 00 00 02 02"
                       "00 00 00 00 00 00 00 00 00 00 00 00 00 00 00 00 00 00 00 00 00 FC 7E");
  EXPECT_EQ(build([&](auto o) { return build_write_config(o, cfg); }), l16);  // L16
}

TEST(LmsCodec, PublicAnchorsOfSection5) {
  EXPECT_EQ(build([](auto o) { return build_variant(o, {100, 100}); }), hex("020005003B640064001D0F"));
  EXPECT_EQ(build([](auto o) { return build_variant(o, {100, 50}); }), hex("020005003B64003200B159"));
  EXPECT_EQ(build([](auto o) { return build_store_permanent(o, 0x02); }), hex("0200020066029E4E"));
  std::array<std::uint8_t, 32> cm{};
  cm[9] = 0x02;
  cm[10] = 0x02;
  EXPECT_EQ(build([&](auto o) { return build_write_config(o, cm); }),
            hex("02002100770000000000000000000202000000000000000000000000000000000000000000E872"));
  EXPECT_EQ(build([](auto o) { return build_variant_reply(o, true, {100, 100}); }), hex("02800700BB0164006400104FBD"));
  EXPECT_EQ(build([](auto o) { return build_variant_reply(o, true, {100, 50}); }), hex("02800700BB0164003200101710"));
  EXPECT_EQ(build([](auto o) { return build_variant_reply(o, true, {100, 25}); }), hex("02800700BB016400190010BB46"));
  EXPECT_EQ(build([](auto o) { return build_variant_reply(o, true, {180, 50}); }), hex("02800700BB01B400320010039D"));
  // DTU USick hard-coded host telegrams (CRC-verified in §5).
  EXPECT_TRUE(verify_telegram(hex("02 00 03 00 45 01 00 A6 D2")));
  EXPECT_TRUE(verify_telegram(hex("02 00 02 00 41 00 D2 69")));
}

TEST(LmsCodec, ReplyVectorsL17ToL20) {
  EXPECT_EQ(build([](auto o) { return build_mode_reply(o, ModeResult::done); }), hex("02 80 03 00 A0 00 10 16 0A"));  // L17
  EXPECT_EQ(build([](auto o) { return build_mode_reply(o, ModeResult::bad_password); }),
            hex("02 80 03 00 A0 01 10 14 0B"));  // L18
  EXPECT_EQ(build([](auto o) { return build_variant_reply(o, true, {180, 100}); }),
            hex("02 80 07 00 BB 01 B4 00 64 00 10 5B 30"));  // L19
  EXPECT_EQ(build([](auto o) { return build_incorrect_command(o); }), hex("02 80 02 00 92 10 7F 33"));  // L20
}

TEST(LmsCodec, ScanReplyL21EncodesExactly) {
  const CountWord cw{5, 0, false, 1};
  const std::array<std::uint16_t, 5> words{
      encode_value_word(1000, 0, BeamInvalid::none, Unit::mm, MeasuringMode::m8_fields_dazzle),
      encode_value_word(2000, 1, BeamInvalid::none, Unit::mm, MeasuringMode::m8_fields_dazzle),
      encode_value_word(9000, 0, BeamInvalid::none, Unit::mm, MeasuringMode::m8_fields_dazzle),  // > max -> 8183
      encode_value_word(0, 0, BeamInvalid::dazzled, Unit::mm, MeasuringMode::m8_fields_dazzle),
      encode_value_word(500, 4, BeamInvalid::none, Unit::mm, MeasuringMode::m8_fields_dazzle)};
  EXPECT_EQ(cw.encode(), 0x4005);
  EXPECT_EQ(build([&](auto o) { return build_scan_reply(o, cw.encode(), words, std::nullopt); }),
            hex("02 80 0E 00 B0 05 40 E8 03 D0 27 F7 1F FE 1F F4 81 10 0D 0C"));
}

TEST(LmsCodec, ScanReplyL21DecodesToTheDocumentedFields) {
  const auto l21 = hex("02 80 0E 00 B0 05 40 E8 03 D0 27 F7 1F FE 1F F4 81 10 0D 0C");
  ScanTelegram s;
  ASSERT_TRUE(decode_scan(l21, MeasuringMode::m8_fields_dazzle, s).ok());
  EXPECT_EQ(s.count, 5);
  EXPECT_EQ(s.unit, Unit::mm);
  const std::array<std::uint32_t, 5> dist{1000, 2000, 8183, 8190, 500};
  const std::array<std::uint8_t, 5> flags{0, 1, 0, 0, 4};
  for (std::size_t i = 0; i < 5; ++i) {
    EXPECT_EQ(s.ranges_mm[i], dist[i]) << i;
    EXPECT_EQ(s.flags[i], flags[i]) << i;
  }
  EXPECT_EQ(s.status.raw, 0x10);
  EXPECT_FALSE(s.realtime_index.has_value());
  EXPECT_EQ(s.invalid[0], BeamInvalid::none);
  EXPECT_TRUE(field_a(s.mode, s.flags[1]));
  EXPECT_EQ(s.invalid[2], BeamInvalid::over_range);  // 0x1FF7: value > maximum
  EXPECT_EQ(s.invalid[3], BeamInvalid::dazzled);     // 0x1FFE
  EXPECT_TRUE(dazzle(s.mode, s.flags[4]));
  EXPECT_EQ(s.invalid[4], BeamInvalid::none);
  EXPECT_EQ(s.valid_count(), 3);
  EXPECT_FALSE(s.status.drop_scan());
}

TEST(LmsCodec, PublicRepliesWithLeadingAckParse) {
  // §5 CARMEN-style tables: `06 02 80 03 00 A0 00 10 16 0A`, `06 02 80 07 00 BB 01 B4 00 32 00 10 03 9D`.
  const auto bytes = hex("06 02 80 03 00 A0 00 10 16 0A 06 02 80 07 00 BB 01 B4 00 32 00 10 03 9D");
  LmsParser p;
  ASSERT_EQ(p.feed(bytes), bytes.size());
  LmsEvent e;
  std::vector<LmsEvent::Kind> kinds;
  std::vector<std::uint8_t> codes;
  while (p.next(e)) {
    kinds.push_back(e.kind);
    if (e.kind == LmsEvent::Kind::telegram) codes.push_back(e.bytes[4]);
  }
  EXPECT_EQ(kinds, (std::vector<LmsEvent::Kind>{LmsEvent::Kind::ack, LmsEvent::Kind::telegram, LmsEvent::Kind::ack,
                                                LmsEvent::Kind::telegram}));
  EXPECT_EQ(codes, (std::vector<std::uint8_t>{0xA0, 0xBB}));
  EXPECT_EQ(p.statistics().discarded_bytes, 0u);
}

TEST(LmsCodec, DtuCaptureHeaderFacts) {
  // §5: the DTU 361-value capture starts `02 80 D6 02 B0 69 41` and ends `18 05 10 64 47`. The full
  // body is not in the reference; check what the header and trailer fix: L = 726 -> 732 bytes on
  // the wire, count word 0x4169 = 361 values in mm, last word 0x0518, status 0x10, and our encoder
  // produces the same header for a 361-value mm scan.
  const auto head = hex("02 80 D6 02 B0 69 41");
  const TelegramView hv{head};
  EXPECT_EQ(hv.length() + kFrameOverhead, 732u);
  const CountWord cw = CountWord::decode(static_cast<std::uint16_t>(head[5] | (head[6] << 8)));
  EXPECT_EQ(cw.values, 361);
  EXPECT_EQ(cw.unit_bits, 1);
  EXPECT_FALSE(cw.partial);
  std::array<std::uint16_t, 361> words{};
  words[360] = 0x0518;
  Buffer b{};
  const std::size_t n = build_scan_reply(b, cw.encode(), words, std::nullopt, 0x10);
  ASSERT_EQ(n, 732u);
  EXPECT_EQ(test::bytes_of(b, 7), head);
  EXPECT_EQ(b[n - 5], 0x18);
  EXPECT_EQ(b[n - 4], 0x05);
  EXPECT_EQ(b[n - 3], 0x10);
  ScanTelegram s;
  ASSERT_TRUE(decode_scan(std::span{b}.first(n), MeasuringMode::m8_fields_dazzle, s).ok());
  EXPECT_EQ(s.count, 361);
  EXPECT_EQ(s.ranges_mm[360], 1304u);  // 0x0518
  EXPECT_EQ(s.status.raw, 0x10);
}

TEST(LmsCodec, StatusReplyIs160BytesAndRoundTrips) {
  StatusInfo info;
  info.operating_mode = 0x24;
  info.variant = {100, 25};
  info.baud = 500000;
  info.units = 1;
  info.measuring_mode = 0x00;
  Buffer b{};
  const std::size_t n = build_status_reply(b, info);
  ASSERT_EQ(n, 160u);  // §2.8: 152 data + code + status + 6
  ASSERT_TRUE(verify_telegram(std::span{b}.first(n)));
  const TelegramView v{std::span{b}.first(n)};
  EXPECT_EQ(v.code(), 0xB1);
  EXPECT_EQ(b[4 + 116], 0x01);  // offset 116 from the reply code: baud code 0x0001 = 500k
  EXPECT_EQ(b[4 + 107], 100);   // offset 107: scan angle
  EXPECT_EQ(b[4 + 109], 25);    // offset 109: resolution
  const auto back = parse_status_data(v.data());
  ASSERT_TRUE(back.has_value());
  EXPECT_EQ(back->baud, 500000u);
  EXPECT_EQ(back->variant, (LaserVariant{100, 25}));
  EXPECT_EQ(back->operating_mode, 0x24);
  EXPECT_EQ(back->units, 1);
}

TEST(LmsCodec, PowerOnTelegramIs29Bytes) {
  Buffer b{};
  EXPECT_EQ(build_power_on(b, "LMS200;30106"), 29u);  // §2.1
  EXPECT_EQ(b[4], 0x90);
}

TEST(LmsCodec, BuildersRefuseWhatCannotBeEncoded) {
  Buffer b{};
  EXPECT_EQ(build_baud_switch(b, 115200), 0u);
  std::array<std::uint8_t, 6> small{};
  EXPECT_EQ(build_status_request(small), 0u);  // needs 7
  std::array<std::uint8_t, 7> exact{};
  EXPECT_EQ(build_status_request(exact), 7u);
  std::array<std::uint8_t, 40> too_long{};
  EXPECT_EQ(build_write_config(b, too_long), 0u);
  std::array<std::uint16_t, kMaxBeams + 1> words{};
  EXPECT_EQ(build_scan_reply(b, 0, words, std::nullopt), 0u);
  EXPECT_FALSE(is_supported_variant({180, 25}));
  EXPECT_TRUE(is_supported_variant({100, 25}));
}

TEST(LmsCodec, VerifyRejectsFlippedBitsAndWrongSizes) {
  auto l1 = hex("02 00 01 00 31 15 12");
  EXPECT_TRUE(verify_telegram(l1));
  for (std::size_t i = 0; i < l1.size(); ++i) {
    for (int bit = 0; bit < 8; ++bit) {
      auto c = l1;
      c[i] = static_cast<std::uint8_t>(c[i] ^ (1u << bit));
      EXPECT_FALSE(verify_telegram(c)) << i << ":" << bit;
    }
  }
  l1.push_back(0);
  EXPECT_FALSE(verify_telegram(l1));
}

TEST(LmsCodec, BaudTables) {
  EXPECT_EQ(baud_of_mode(OperatingMode::baud_500000), 500000u);
  EXPECT_EQ(*baud_mode(19200), OperatingMode::baud_19200);
  EXPECT_EQ(baud_from_status_code(status_baud_code(38400)), 38400u);
  EXPECT_EQ(baud_of_mode(OperatingMode::continuous), 0u);
}

}  // namespace
}  // namespace teamscan::lms200
