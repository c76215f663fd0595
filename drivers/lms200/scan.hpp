// Measured-value telegrams 0xB0 (PROTOCOLS.md §2.7) and the status byte (§2.9): decoding into a
// fixed-capacity ScanTelegram, and the inverse encoding used by the emulator and the tests.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <span>

#include "common/capacities.hpp"
#include "common/laser_geometry.hpp"
#include "common/point_flags.hpp"
#include "common/result.hpp"

namespace teamscan::lms200 {

// Count word bits 14–15 (§2.7).
enum class Unit : std::uint8_t { cm = 0, mm = 1, dm = 2 };
[[nodiscard]] constexpr std::uint32_t unit_mm(Unit u) { return u == Unit::cm ? 10u : u == Unit::dm ? 100u : 1u; }
[[nodiscard]] const char* to_string(Unit u);

// Config block D (§2.6, §2.7): how many bits of a value word are distance and what the rest mean.
enum class MeasuringMode : std::uint8_t {
  m8_fields_dazzle = 0x00,  // 13 bits; 13 field A, 14 field B, 15 dazzle (default)
  m8_reflectivity = 0x01,   // 13 bits; 13–15 reflectivity (8 levels)
  m8_fields_abc = 0x02,     // 13 bits; 13 field A, 14 field B, 15 field C
  m16_reflectivity = 0x03,  // 14 bits; 14–15 reflectivity (4 levels)
  m16_fields_ab = 0x04,     // 14 bits; 14 field A, 15 field B
  m32_reflector = 0x05,     // 15 bits; 15 reflector
  m32_field_a = 0x06,       // 15 bits; 15 field A
  m32_immediate = 0x0F,     // 15 bits; no flags
  energy = 0x3F,            // 16-bit energy/reflectivity values instead of ranges (no reserved codes)
};
[[nodiscard]] bool is_known_measuring_mode(std::uint8_t mode);
// Distance bits of a value word: 13, 14, 15 (16 for `energy`).
[[nodiscard]] unsigned distance_bits(MeasuringMode mode);

// Why a beam carries no usable distance: the reserved codes at the top of each range (§2.7, rl).
// For 14/15-bit modes the codes are 0x3F.. / 0x7F.. with the same low bits.
enum class BeamInvalid : std::uint8_t {
  none = 0,
  not_valid,         // 0x1FFF
  dazzled,           // 0x1FFE
  overflow,          // 0x1FFD operation overflow
  low_signal,        // 0x1FFB signal/noise too small
  channel_error,     // 0x1FFA error reading channel 1
  over_range,        // 0x1FF7 value > maximum: the "no return" of an open direction
  reserved,          // any other code above the maximum (0x1FF8.., unassigned)
};
[[nodiscard]] const char* to_string(BeamInvalid r);
// The reserved code for `reason` in a mode with `bits` distance bits (none -> 0).
[[nodiscard]] std::uint16_t reserved_code(BeamInvalid reason, unsigned bits);
// Largest valid distance in a mode: code 0x..F7 − 1 (8182 in the 13-bit modes; §2.7 "useful maxima").
[[nodiscard]] constexpr std::uint16_t max_distance(unsigned bits) {
  return static_cast<std::uint16_t>((1u << bits) - 10u);
}

// Status byte (§2.9): class in bits 0–2, implausible values bit 6, pollution bit 7; bits 3–5 vary
// with the firmware (0x10 on healthy devices) and are ignored.
struct StatusByte {
  std::uint8_t raw = 0;
  [[nodiscard]] std::uint8_t error_class() const { return raw & 0x07u; }  // 0 ok .. 4 fatal
  [[nodiscard]] bool implausible() const { return (raw & 0x40u) != 0; }
  [[nodiscard]] bool pollution() const { return (raw & 0x80u) != 0; }
  // §2.9: class >= 3 (error, fatal) or implausible values -> drop the scan; pollution only warns.
  [[nodiscard]] bool drop_scan() const { return error_class() >= 3 || implausible(); }
};

// Count word (§2.7).
struct CountWord {
  std::uint16_t values = 0;          // bits 0–9
  std::uint8_t partial_index = 0;    // bits 11–12: +0, 0.25, 0.5, 0.75°
  bool partial = false;              // bit 13
  std::uint8_t unit_bits = 0;        // bits 14–15 (3 = invalid)
  [[nodiscard]] std::uint16_t encode() const;
  [[nodiscard]] static CountWord decode(std::uint16_t w);
};

// One measured-values telegram, decoded: the scan's first form, for the robot daemon and the
// simulator's receiver alike. `flags`: the bits of one beam as sent, above the distance (mode 0 gives
// field A = 1, field B = 2, dazzle = 4; L21: bit 13 -> 1, bit 15 -> 4), interpreted with the helpers
// below and the scan's mode; `beam_flags`: the same beam as the geometry reads it (beam_flags() below,
// filled by decode_scan).
struct ScanTelegram {
  std::uint16_t count = 0;
  Unit unit = Unit::mm;
  MeasuringMode mode = MeasuringMode::m8_fields_dazzle;
  bool partial = false;
  std::uint8_t partial_index = 0;
  std::optional<std::uint8_t> realtime_index;
  StatusByte status{};
  std::array<std::uint32_t, kMaxBeams> ranges_mm{};  // distance × unit (cm ×10, dm ×100); raw code for reserved
  std::array<std::uint8_t, kMaxBeams> flags{};       // value word >> distance bits
  std::array<BeamInvalid, kMaxBeams> invalid{};       // none for a usable distance
  std::array<std::uint8_t, kMaxBeams> beam_flags{};   // kBeam* (common/point_flags.hpp), from invalid and flags
  [[nodiscard]] std::uint16_t valid_count() const;
  // The geometry's input (common/scan_points.hpp ScanProjector): ranges and beam flags of beams
  // [0, count), viewed in place; empty for a partial scan (its beams are not those of one sweep).
  [[nodiscard]] BeamSpans sweep() const {
    if (partial || count > kMaxBeams) return {};
    return {std::span<const std::uint32_t>(ranges_mm.data(), count), std::span<const std::uint8_t>(beam_flags.data(), count)};
  }
};

// Flag meaning per mode (§2.7 table); false where the mode has no such bit.
[[nodiscard]] bool field_a(MeasuringMode mode, std::uint8_t flags);
[[nodiscard]] bool field_b(MeasuringMode mode, std::uint8_t flags);
[[nodiscard]] bool field_c(MeasuringMode mode, std::uint8_t flags);
[[nodiscard]] bool dazzle(MeasuringMode mode, std::uint8_t flags);
[[nodiscard]] std::uint8_t reflectivity(MeasuringMode mode, std::uint8_t flags);

// The geometry's flags (common/point_flags.hpp kBeam*) of beam `i` of `t` (what decode_scan stores in
// beam_flags): a reserved distance code is invalid (the dazzle code 0x1FFE also dazzled); the dazzle
// bit on a distance is dazzled.
[[nodiscard]] std::uint8_t beam_flags(const ScanTelegram& t, std::size_t i);

// Decodes a verified 0xB0 telegram (whole telegram, STX..CRC, as the parser yields it). The measuring
// mode comes from the configuration the client set (the telegram does not carry it). The real-time
// index is present iff the length has one byte more than count and words need (config block C 0x02).
// Errors: not 0xB0, unit bits 11, count above kMaxBeams, length not matching the count.
[[nodiscard]] Status decode_scan(std::span<const std::uint8_t> telegram, MeasuringMode mode, ScanTelegram& out);

// One value word from a range: distance = round(range_mm / unit), values above the mode's maximum
// become the over-range code (an open direction), `reason` != none gives that reserved code.
[[nodiscard]] std::uint16_t encode_value_word(std::uint32_t range_mm, std::uint8_t flags, BeamInvalid reason,
                                              Unit unit, MeasuringMode mode);

}  // namespace teamscan::lms200
