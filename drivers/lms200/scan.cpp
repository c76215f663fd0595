// 0xB0 measured values (PROTOCOLS.md §2.7) and status byte (§2.9).
#include "drivers/lms200/scan.hpp"

#include "drivers/lms200/codec.hpp"

namespace teamscan::lms200 {

const char* to_string(Unit u) {
  switch (u) {
    case Unit::cm: return "cm";
    case Unit::mm: return "mm";
    case Unit::dm: return "dm";
  }
  return "?";
}

bool is_known_measuring_mode(std::uint8_t mode) {
  return mode <= 0x06 || mode == 0x0F || mode == 0x3F;
}

unsigned distance_bits(MeasuringMode mode) {
  switch (mode) {
    case MeasuringMode::m8_fields_dazzle:
    case MeasuringMode::m8_reflectivity:
    case MeasuringMode::m8_fields_abc: return 13;
    case MeasuringMode::m16_reflectivity:
    case MeasuringMode::m16_fields_ab: return 14;
    case MeasuringMode::m32_reflector:
    case MeasuringMode::m32_field_a:
    case MeasuringMode::m32_immediate: return 15;
    case MeasuringMode::energy: return 16;
  }
  return 13;
}

const char* to_string(BeamInvalid r) {
  switch (r) {
    case BeamInvalid::none: return "none";
    case BeamInvalid::not_valid: return "not_valid";
    case BeamInvalid::dazzled: return "dazzled";
    case BeamInvalid::overflow: return "overflow";
    case BeamInvalid::low_signal: return "low_signal";
    case BeamInvalid::channel_error: return "channel_error";
    case BeamInvalid::over_range: return "over_range";
    case BeamInvalid::reserved: return "reserved";
  }
  return "?";
}

std::uint16_t reserved_code(BeamInvalid reason, unsigned bits) {
  const auto top = static_cast<std::uint16_t>((1u << bits) - 1u);  // 0x1FFF, 0x3FFF, 0x7FFF
  switch (reason) {
    case BeamInvalid::none: return 0;
    case BeamInvalid::not_valid: return top;
    case BeamInvalid::dazzled: return static_cast<std::uint16_t>(top - 1);
    case BeamInvalid::overflow: return static_cast<std::uint16_t>(top - 2);
    case BeamInvalid::low_signal: return static_cast<std::uint16_t>(top - 4);
    case BeamInvalid::channel_error: return static_cast<std::uint16_t>(top - 5);
    case BeamInvalid::over_range: return static_cast<std::uint16_t>(top - 8);
    case BeamInvalid::reserved: return static_cast<std::uint16_t>(top - 7);  // 0x1FF8: unassigned
  }
  return top;
}

namespace {
BeamInvalid classify(std::uint16_t distance, unsigned bits) {
  if (bits >= 16) return BeamInvalid::none;  // energy values: no reserved codes
  const std::uint16_t top = static_cast<std::uint16_t>((1u << bits) - 1u);
  if (distance <= max_distance(bits)) return BeamInvalid::none;
  switch (top - distance) {
    case 0: return BeamInvalid::not_valid;
    case 1: return BeamInvalid::dazzled;
    case 2: return BeamInvalid::overflow;
    case 4: return BeamInvalid::low_signal;
    case 5: return BeamInvalid::channel_error;
    case 8: return BeamInvalid::over_range;
    default: return BeamInvalid::reserved;
  }
}
}  // namespace

std::uint16_t CountWord::encode() const {
  return static_cast<std::uint16_t>((values & 0x3FFu) | ((partial_index & 3u) << 11) | (partial ? 0x2000u : 0u) |
                                    ((unit_bits & 3u) << 14));
}

CountWord CountWord::decode(std::uint16_t w) {
  CountWord c;
  c.values = static_cast<std::uint16_t>(w & 0x3FFu);  // 10 bits (ARIA, sicktoolbox), not 0x1FF/0x3FFF
  c.partial_index = static_cast<std::uint8_t>((w >> 11) & 3u);
  c.partial = (w & 0x2000u) != 0;
  c.unit_bits = static_cast<std::uint8_t>(w >> 14);
  return c;
}

std::uint16_t ScanTelegram::valid_count() const {
  std::uint16_t n = 0;
  for (std::size_t i = 0; i < count; ++i)
    if (invalid[i] == BeamInvalid::none) ++n;
  return n;
}

bool field_a(MeasuringMode mode, std::uint8_t flags) {
  switch (mode) {
    case MeasuringMode::m8_fields_dazzle:
    case MeasuringMode::m8_fields_abc:
    case MeasuringMode::m16_fields_ab:
    case MeasuringMode::m32_field_a: return (flags & 1u) != 0;
    default: return false;
  }
}
bool field_b(MeasuringMode mode, std::uint8_t flags) {
  switch (mode) {
    case MeasuringMode::m8_fields_dazzle:
    case MeasuringMode::m8_fields_abc:
    case MeasuringMode::m16_fields_ab: return (flags & 2u) != 0;
    default: return false;
  }
}
bool field_c(MeasuringMode mode, std::uint8_t flags) {
  return mode == MeasuringMode::m8_fields_abc && (flags & 4u) != 0;
}
bool dazzle(MeasuringMode mode, std::uint8_t flags) {
  return mode == MeasuringMode::m8_fields_dazzle && (flags & 4u) != 0;
}
std::uint8_t beam_flags(const ScanTelegram& t, std::size_t i) {
  const BeamInvalid why = t.invalid[i];
  std::uint8_t f = 0;
  if (why == BeamInvalid::dazzled || dazzle(t.mode, t.flags[i])) f |= kBeamDazzled;
  if (why != BeamInvalid::none) f |= kBeamInvalid;
  return f;
}

std::uint8_t reflectivity(MeasuringMode mode, std::uint8_t flags) {
  switch (mode) {
    case MeasuringMode::m8_reflectivity:
    case MeasuringMode::m16_reflectivity:
    case MeasuringMode::m32_reflector: return flags;
    default: return 0;
  }
}

Status decode_scan(std::span<const std::uint8_t> telegram, MeasuringMode mode, ScanTelegram& out) {
  if (telegram.size() < kFrameOverhead + 4 || telegram[4] != static_cast<std::uint8_t>(Reply::measured_values))
    return Error{"not a 0xB0 measured-values telegram"};
  const TelegramView view{telegram};
  if (view.length() + kFrameOverhead != telegram.size()) return Error{"0xB0 length does not match the telegram"};
  const auto data = view.data();  // count word, values, [real-time index]
  const CountWord cw = CountWord::decode(static_cast<std::uint16_t>(data[0] | (data[1] << 8)));
  if (cw.unit_bits == 3) return Error{"0xB0 unit bits 11 (invalid)"};
  if (cw.values > kMaxBeams) return Error{"0xB0 count above the beam capacity", 0, cw.values};
  const std::size_t words_end = 2u + 2u * cw.values;
  if (data.size() != words_end && data.size() != words_end + 1)
    return Error{"0xB0 length does not match its count word", 0, static_cast<long>(data.size())};

  out.count = cw.values;
  out.unit = static_cast<Unit>(cw.unit_bits);
  out.mode = mode;
  out.partial = cw.partial;
  out.partial_index = cw.partial_index;
  out.realtime_index = data.size() == words_end + 1 ? std::optional<std::uint8_t>{data[words_end]} : std::nullopt;
  out.status = StatusByte{view.status()};
  const unsigned bits = distance_bits(mode);
  const std::uint32_t mask = bits >= 16 ? 0xFFFFu : (1u << bits) - 1u;
  const std::uint32_t scale = unit_mm(out.unit);
  for (std::size_t i = 0; i < cw.values; ++i) {
    const std::uint32_t word = static_cast<std::uint32_t>(data[2 + 2 * i] | (data[3 + 2 * i] << 8));
    const auto distance = static_cast<std::uint16_t>(word & mask);
    out.flags[i] = static_cast<std::uint8_t>(bits >= 16 ? 0u : word >> bits);
    out.invalid[i] = classify(distance, bits);
    // Energy values are not distances: keep them unscaled. Largest product: 0x7FFF × 100 fits u32.
    out.ranges_mm[i] = mode == MeasuringMode::energy ? distance : distance * scale;
    out.beam_flags[i] = beam_flags(out, i);
  }
  return ok_status();
}

std::uint16_t encode_value_word(std::uint32_t range_mm, std::uint8_t flags, BeamInvalid reason, Unit unit,
                                MeasuringMode mode) {
  const unsigned bits = distance_bits(mode);
  if (bits >= 16) return static_cast<std::uint16_t>(range_mm > 0xFFFFu ? 0xFFFFu : range_mm);
  const std::uint32_t scale = unit_mm(unit);
  std::uint32_t distance = 0;
  if (reason != BeamInvalid::none) {
    distance = reserved_code(reason, bits);
  } else {
    const std::uint64_t rounded = (static_cast<std::uint64_t>(range_mm) + scale / 2) / scale;  // half up
    distance = rounded > max_distance(bits) ? reserved_code(BeamInvalid::over_range, bits)
                                            : static_cast<std::uint32_t>(rounded);
  }
  const std::uint32_t flag_mask = (1u << (16 - bits)) - 1u;
  return static_cast<std::uint16_t>(distance | ((flags & flag_mask) << bits));
}

}  // namespace teamscan::lms200
