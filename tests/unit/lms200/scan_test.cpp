// 0xB0 decoding (PROTOCOLS.md §2.7) in every measuring mode, reserved codes, units, partial-scan
// bits, real-time index, status byte (§2.9) and malformed telegrams.
#include "drivers/lms200/scan.hpp"

#include <gtest/gtest.h>

#include <array>
#include <vector>

#include "drivers/lms200/codec.hpp"
#include "tests/unit/lms200/test_util.hpp"

namespace teamscan::lms200 {
namespace {

std::vector<std::uint8_t> scan(std::uint16_t count_word, std::vector<std::uint16_t> words,
                               std::optional<std::uint8_t> rt = std::nullopt, std::uint8_t status = 0x10) {
  std::array<std::uint8_t, kMaxLmsTelegram> b{};
  const std::size_t n = build_scan_reply(b, count_word, words, rt, status);
  return test::bytes_of(b, n);
}

TEST(ScanDecode, CountWordBitsOfSection27) {
  const CountWord c = CountWord::decode(0b10'1'11'0'0101101001);  // dm, partial, index 3, 361
  EXPECT_EQ(c.values, 361);
  EXPECT_EQ(c.partial_index, 3);
  EXPECT_TRUE(c.partial);
  EXPECT_EQ(c.unit_bits, 2);
  EXPECT_EQ(c.encode(), 0b10'1'11'0'0101101001);
  // Bit 10 is unused: a 10-bit count mask, not 0x1FF (MRPT) nor 0x3FFF (Player).
  EXPECT_EQ(CountWord::decode(0x0401).values, 1);
  EXPECT_EQ(CountWord::decode(0x0200 | 0x0191).values, 0x391 & 0x3FF);
}

TEST(ScanDecode, UnitsScaleToMillimetres) {
  ScanTelegram s;
  ASSERT_TRUE(decode_scan(scan(CountWord{1, 0, false, 0}.encode(), {123}), MeasuringMode::m8_fields_dazzle, s).ok());
  EXPECT_EQ(s.unit, Unit::cm);
  EXPECT_EQ(s.ranges_mm[0], 1230u);
  ASSERT_TRUE(decode_scan(scan(CountWord{1, 0, false, 2}.encode(), {123}), MeasuringMode::m8_fields_dazzle, s).ok());
  EXPECT_EQ(s.unit, Unit::dm);
  EXPECT_EQ(s.ranges_mm[0], 12300u);
}

TEST(ScanDecode, FourteenAndFifteenBitModes) {
  ScanTelegram s;
  // 14-bit, fields A/B in bits 14/15: 16000 mm + field B.
  ASSERT_TRUE(decode_scan(scan(0x4001, {static_cast<std::uint16_t>(16000 | 0x8000)}), MeasuringMode::m16_fields_ab, s).ok());
  EXPECT_EQ(s.ranges_mm[0], 16000u);
  EXPECT_EQ(s.flags[0], 2);
  EXPECT_TRUE(field_b(s.mode, s.flags[0]));
  EXPECT_FALSE(field_a(s.mode, s.flags[0]));
  // 15-bit, reflector bit 15: 32000 mm.
  ASSERT_TRUE(decode_scan(scan(0x4001, {static_cast<std::uint16_t>(32000 | 0x8000)}), MeasuringMode::m32_reflector, s).ok());
  EXPECT_EQ(s.ranges_mm[0], 32000u);
  EXPECT_EQ(reflectivity(s.mode, s.flags[0]), 1);
  // 13-bit reflectivity levels in bits 13–15.
  ASSERT_TRUE(decode_scan(scan(0x4001, {static_cast<std::uint16_t>(100 | (5u << 13))}), MeasuringMode::m8_reflectivity, s).ok());
  EXPECT_EQ(reflectivity(s.mode, s.flags[0]), 5);
  EXPECT_FALSE(dazzle(s.mode, s.flags[0]));
}

TEST(ScanDecode, ReservedCodesPerMode) {
  struct Case {
    MeasuringMode mode;
    std::uint16_t base;  // 0x1F.., 0x3F.., 0x7F..
  };
  for (const Case c : {Case{MeasuringMode::m8_fields_dazzle, 0x1F00}, Case{MeasuringMode::m16_fields_ab, 0x3F00},
                       Case{MeasuringMode::m32_immediate, 0x7F00}}) {
    const std::vector<std::uint16_t> w{static_cast<std::uint16_t>(c.base | 0xFF), static_cast<std::uint16_t>(c.base | 0xFE),
                                       static_cast<std::uint16_t>(c.base | 0xFD), static_cast<std::uint16_t>(c.base | 0xFB),
                                       static_cast<std::uint16_t>(c.base | 0xFA), static_cast<std::uint16_t>(c.base | 0xF7),
                                       static_cast<std::uint16_t>(c.base | 0xF6), static_cast<std::uint16_t>(c.base | 0xF9)};
    ScanTelegram s;
    ASSERT_TRUE(decode_scan(scan(static_cast<std::uint16_t>(0x4000 | w.size()), w), c.mode, s).ok());
    EXPECT_EQ(s.invalid[0], BeamInvalid::not_valid);
    EXPECT_EQ(s.invalid[1], BeamInvalid::dazzled);
    EXPECT_EQ(s.invalid[2], BeamInvalid::overflow);
    EXPECT_EQ(s.invalid[3], BeamInvalid::low_signal);
    EXPECT_EQ(s.invalid[4], BeamInvalid::channel_error);
    EXPECT_EQ(s.invalid[5], BeamInvalid::over_range);
    EXPECT_EQ(s.invalid[6], BeamInvalid::none);  // 0x..F6: the maximum valid distance
    EXPECT_EQ(s.invalid[7], BeamInvalid::reserved);
    EXPECT_EQ(s.valid_count(), 1);
  }
  EXPECT_EQ(max_distance(13), 8182);  // §2.7 rl: 8.182 m / 81.82 m
  EXPECT_EQ(max_distance(14), 16374);
  EXPECT_EQ(max_distance(15), 32758);
}

TEST(ScanDecode, EnergyModeHasNoReservedCodes) {
  ScanTelegram s;
  ASSERT_TRUE(decode_scan(scan(0x4001, {0xFFFF}), MeasuringMode::energy, s).ok());
  EXPECT_EQ(s.ranges_mm[0], 0xFFFFu);
  EXPECT_EQ(s.invalid[0], BeamInvalid::none);
}

TEST(ScanDecode, RealtimeIndexFromTheLength) {
  ScanTelegram s;
  ASSERT_TRUE(decode_scan(scan(0x4002, {1, 2}, std::uint8_t{0xAB}), MeasuringMode::m8_fields_dazzle, s).ok());
  EXPECT_EQ(s.realtime_index, std::optional<std::uint8_t>{0xAB});
  EXPECT_EQ(s.ranges_mm[1], 2u);
}

TEST(ScanDecode, StatusByteClasses) {
  EXPECT_FALSE(StatusByte{0x10}.drop_scan());
  EXPECT_FALSE(StatusByte{0x12}.drop_scan());  // warning
  EXPECT_TRUE(StatusByte{0x13}.drop_scan());   // error
  EXPECT_TRUE(StatusByte{0x14}.drop_scan());   // fatal
  EXPECT_TRUE(StatusByte{0x50}.drop_scan());   // implausible (bit 6)
  EXPECT_FALSE(StatusByte{0x90}.drop_scan());  // pollution only warns
  EXPECT_TRUE(StatusByte{0x90}.pollution());
  EXPECT_EQ(StatusByte{0x3C}.error_class(), 4);  // bits 3–5 ignored
}

TEST(ScanDecode, MalformedTelegramsAreErrors) {
  ScanTelegram s;
  EXPECT_FALSE(decode_scan(scan(0xC001, {1}), MeasuringMode::m8_fields_dazzle, s).ok());   // unit bits 11
  EXPECT_FALSE(decode_scan(scan(0x4003, {1, 2}), MeasuringMode::m8_fields_dazzle, s).ok()); // count says 3, 2 words
  EXPECT_FALSE(decode_scan(scan(0x4001, {1, 2, 3}), MeasuringMode::m8_fields_dazzle, s).ok());  // too many words
  EXPECT_FALSE(decode_scan(scan(0x4000 | 402, std::vector<std::uint16_t>(400)), MeasuringMode::m8_fields_dazzle, s).ok());
  const auto l20 = test::hex("02 80 02 00 92 10 7F 33");
  EXPECT_FALSE(decode_scan(l20, MeasuringMode::m8_fields_dazzle, s).ok());  // not 0xB0
  EXPECT_FALSE(decode_scan({}, MeasuringMode::m8_fields_dazzle, s).ok());
}

TEST(ScanEncode, ValueWordsRoundAndSaturate) {
  const auto m0 = MeasuringMode::m8_fields_dazzle;
  EXPECT_EQ(encode_value_word(1234, 0, BeamInvalid::none, Unit::cm, m0), 123);   // 123.4 cm
  EXPECT_EQ(encode_value_word(1235, 0, BeamInvalid::none, Unit::cm, m0), 124);   // half up
  EXPECT_EQ(encode_value_word(8182, 0, BeamInvalid::none, Unit::mm, m0), 8182);  // largest valid
  EXPECT_EQ(encode_value_word(8183, 0, BeamInvalid::none, Unit::mm, m0), 0x1FF7);
  EXPECT_EQ(encode_value_word(0xFFFFFFFFu, 0, BeamInvalid::none, Unit::mm, m0), 0x1FF7);  // no overflow
  EXPECT_EQ(encode_value_word(0, 0, BeamInvalid::not_valid, Unit::mm, m0), 0x1FFF);
  EXPECT_EQ(encode_value_word(100, 0x7, BeamInvalid::none, Unit::mm, m0), 100 | 0xE000);
  EXPECT_EQ(encode_value_word(100, 0x7, BeamInvalid::none, Unit::mm, MeasuringMode::m32_field_a), 100 | 0x8000);
}


// The one beam-flag mapping of the daemon and the simulator (lms200::beam_flags -> kBeam*).
TEST(ScanBeamFlags, EveryReasonAndTheDazzleBit) {
  ScanTelegram s;
  s.mode = MeasuringMode::m8_fields_dazzle;
  s.count = 9;
  const BeamInvalid reasons[] = {BeamInvalid::none,      BeamInvalid::not_valid,     BeamInvalid::dazzled,
                                 BeamInvalid::overflow,  BeamInvalid::low_signal,    BeamInvalid::channel_error,
                                 BeamInvalid::over_range, BeamInvalid::reserved};
  for (std::size_t i = 0; i < 8; ++i) s.invalid[i] = reasons[i];
  EXPECT_EQ(beam_flags(s, 0), 0);
  EXPECT_EQ(beam_flags(s, 1), kBeamInvalid);
  EXPECT_EQ(beam_flags(s, 2), kBeamInvalid | kBeamDazzled);  // 0x1FFE: no distance, and dazzled
  for (std::size_t i = 3; i < 8; ++i) EXPECT_EQ(beam_flags(s, i), kBeamInvalid) << to_string(reasons[i]);
  // A usable distance with the dazzle bit (bit 15 = flags 4 in mode 0x00): dazzled, still a distance.
  s.invalid[8] = BeamInvalid::none;
  s.flags[8] = 4;
  EXPECT_EQ(beam_flags(s, 8), kBeamDazzled);
  // The same bit in a mode without a dazzle bit means something else: no flag.
  s.mode = MeasuringMode::m8_reflectivity;
  EXPECT_EQ(beam_flags(s, 8), 0);
}

// decode_scan stores each beam's geometry flags, and sweep() views ranges and flags in place: what the
// projector (common/scan_points.hpp) reads on the robot and in the simulator.
TEST(ScanBeamFlags, DecodeStoresThemAndTheSweepViewsThem) {
  ScanTelegram s;
  const std::uint16_t dazzle_bit = 0x8000;
  ASSERT_TRUE(decode_scan(scan(CountWord{3, 0, false, 1}.encode(),
                               {1000, reserved_code(BeamInvalid::not_valid, 13), static_cast<std::uint16_t>(2000 | dazzle_bit)}),
                          MeasuringMode::m8_fields_dazzle, s).ok());
  const BeamSpans beams = s.sweep();
  ASSERT_EQ(beams.range_mm.size(), 3u);
  ASSERT_EQ(beams.flags.size(), 3u);
  EXPECT_EQ(beams.range_mm.data(), s.ranges_mm.data());  // a view, not a copy
  EXPECT_EQ(beams.range_mm[0], 1000u);
  EXPECT_EQ(beams.flags[0], 0);
  EXPECT_EQ(beams.flags[1], kBeamInvalid);
  EXPECT_EQ(beams.range_mm[2], 2000u);
  EXPECT_EQ(beams.flags[2], kBeamDazzled);
  // A partial scan's beams are not those of one sweep: nothing to place.
  ASSERT_TRUE(decode_scan(scan(CountWord{3, 1, true, 1}.encode(), {1000, 1000, 1000}), MeasuringMode::m8_fields_dazzle, s).ok());
  EXPECT_TRUE(s.sweep().range_mm.empty());
}

}  // namespace
}  // namespace teamscan::lms200
