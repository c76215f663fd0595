// SICK LMS 2xx telegram codec: CRC (PROTOCOLS.md §2.3) and the builders of §2.4–§2.8.
#include "drivers/lms200/codec.hpp"

#include <algorithm>
#include <array>

namespace teamscan::lms200 {
namespace {

// Appends bytes into a fixed span; remembers overflow so one check at the end suffices.
class ByteWriter {
 public:
  explicit ByteWriter(std::span<std::uint8_t> out) : out_{out} {}
  void u8(std::uint8_t b) {
    if (size_ < out_.size()) out_[size_] = b; else overflow_ = true;
    ++size_;
  }
  void u16(std::uint16_t v) {
    u8(static_cast<std::uint8_t>(v & 0xFF));
    u8(static_cast<std::uint8_t>(v >> 8));
  }
  void bytes(std::span<const std::uint8_t> b) { for (auto x : b) u8(x); }
  void text(std::string_view s, std::size_t width) {  // cut or space-padded to `width`
    for (std::size_t i = 0; i < width; ++i) u8(i < s.size() ? static_cast<std::uint8_t>(s[i]) : std::uint8_t{' '});
  }
  [[nodiscard]] std::size_t size() const { return overflow_ ? 0 : size_; }

 private:
  std::span<std::uint8_t> out_;
  std::size_t size_ = 0;
  bool overflow_ = false;
};

// Body scratch large enough for any telegram body (L <= kMaxLength).
using Body = std::array<std::uint8_t, kMaxLength>;

std::size_t host_telegram(std::span<std::uint8_t> out, std::span<const std::uint8_t> body) {
  return build_telegram(out, kAddressToLms, body);
}

}  // namespace

std::optional<OperatingMode> baud_mode(std::uint32_t baud) {
  switch (baud) {
    case 9600: return OperatingMode::baud_9600;
    case 19200: return OperatingMode::baud_19200;
    case 38400: return OperatingMode::baud_38400;
    case 500000: return OperatingMode::baud_500000;
    default: return std::nullopt;
  }
}

std::uint32_t baud_of_mode(OperatingMode mode) {
  switch (mode) {
    case OperatingMode::baud_9600: return 9600;
    case OperatingMode::baud_19200: return 19200;
    case OperatingMode::baud_38400: return 38400;
    case OperatingMode::baud_500000: return 500000;
    default: return 0;
  }
}

std::uint16_t status_baud_code(std::uint32_t baud) {
  switch (baud) {
    case 9600: return 0x0067;
    case 19200: return 0x0033;
    case 38400: return 0x0019;
    case 500000: return 0x0001;
    default: return 0;
  }
}

std::uint32_t baud_from_status_code(std::uint16_t code) {
  switch (code) {
    case 0x0067: return 9600;
    case 0x0033: return 19200;
    case 0x0019: return 38400;
    case 0x0001: return 500000;
    default: return 0;
  }
}

std::uint16_t sick_crc16(std::span<const std::uint8_t> bytes) {
  std::uint16_t crc = 0;
  std::uint8_t previous = 0;
  for (const std::uint8_t b : bytes) {
    const bool carry = (crc & 0x8000u) != 0;
    crc = static_cast<std::uint16_t>(crc << 1);
    if (carry) crc = static_cast<std::uint16_t>(crc ^ 0x8005u);
    crc = static_cast<std::uint16_t>(crc ^ ((previous << 8) | b));
    previous = b;
  }
  return crc;
}

std::size_t build_telegram(std::span<std::uint8_t> out, std::uint8_t address, std::span<const std::uint8_t> body) {
  if (body.empty() || body.size() > kMaxLength) return 0;
  const std::size_t total = body.size() + kFrameOverhead;
  if (out.size() < total) return 0;
  out[0] = kStx;
  out[1] = address;
  out[2] = static_cast<std::uint8_t>(body.size() & 0xFF);
  out[3] = static_cast<std::uint8_t>(body.size() >> 8);
  std::copy(body.begin(), body.end(), out.begin() + kHeaderBytes);
  const std::uint16_t crc = sick_crc16(out.first(kHeaderBytes + body.size()));
  out[total - 2] = static_cast<std::uint8_t>(crc & 0xFF);
  out[total - 1] = static_cast<std::uint8_t>(crc >> 8);
  return total;
}

std::size_t build_status_request(std::span<std::uint8_t> out) {
  const std::uint8_t body[] = {static_cast<std::uint8_t>(Command::status)};
  return host_telegram(out, body);
}

std::size_t build_mode(std::span<std::uint8_t> out, OperatingMode mode) {
  const std::uint8_t body[] = {static_cast<std::uint8_t>(Command::change_mode), static_cast<std::uint8_t>(mode)};
  return host_telegram(out, body);
}

std::size_t build_setup_mode(std::span<std::uint8_t> out, std::string_view password) {
  Body body{};
  ByteWriter w{body};
  w.u8(static_cast<std::uint8_t>(Command::change_mode));
  w.u8(static_cast<std::uint8_t>(OperatingMode::setup));
  w.text(password, 8);  // the LMS expects exactly 8 password bytes
  return host_telegram(out, std::span{body}.first(w.size()));
}

std::size_t build_baud_switch(std::span<std::uint8_t> out, std::uint32_t baud) {
  const auto mode = baud_mode(baud);
  if (!mode) return 0;
  return build_mode(out, *mode);
}

std::size_t build_start_continuous(std::span<std::uint8_t> out) { return build_mode(out, OperatingMode::continuous); }
std::size_t build_stop_continuous(std::span<std::uint8_t> out) { return build_mode(out, OperatingMode::polled); }

std::size_t build_poll_scan(std::span<std::uint8_t> out) {
  const std::uint8_t body[] = {static_cast<std::uint8_t>(Command::poll_values), 0x01};
  return host_telegram(out, body);
}

bool is_supported_variant(LaserVariant v) {
  if (v.fov_deg == 180) return v.resolution_cdeg == 100 || v.resolution_cdeg == 50;
  if (v.fov_deg == 100) return v.resolution_cdeg == 100 || v.resolution_cdeg == 50 || v.resolution_cdeg == 25;
  return false;
}

std::size_t build_variant(std::span<std::uint8_t> out, LaserVariant variant) {
  Body body{};
  ByteWriter w{body};
  w.u8(static_cast<std::uint8_t>(Command::variant));
  w.u16(variant.fov_deg);
  w.u16(variant.resolution_cdeg);
  return host_telegram(out, std::span{body}.first(w.size()));
}

std::size_t build_read_config(std::span<std::uint8_t> out) {
  const std::uint8_t body[] = {static_cast<std::uint8_t>(Command::read_config)};
  return host_telegram(out, body);
}

std::size_t build_write_config(std::span<std::uint8_t> out, std::span<const std::uint8_t> config) {
  if (config.empty() || config.size() > kMaxConfigBytes) return 0;
  Body body{};
  ByteWriter w{body};
  w.u8(static_cast<std::uint8_t>(Command::write_config));
  w.bytes(config);
  return host_telegram(out, std::span{body}.first(w.size()));
}

std::size_t build_reset(std::span<std::uint8_t> out) {
  const std::uint8_t body[] = {static_cast<std::uint8_t>(Command::reset)};
  return host_telegram(out, body);
}

std::size_t build_store_permanent(std::span<std::uint8_t> out, std::uint8_t what) {
  const std::uint8_t body[] = {static_cast<std::uint8_t>(Command::store_permanent), what};
  return host_telegram(out, body);
}

std::size_t build_lms_type_request(std::span<std::uint8_t> out) {
  const std::uint8_t body[] = {static_cast<std::uint8_t>(Command::lms_type)};
  return host_telegram(out, body);
}

std::size_t build_reply(std::span<std::uint8_t> out, std::uint8_t code, std::span<const std::uint8_t> data,
                        std::uint8_t status) {
  if (data.size() + 2 > kMaxLength) return 0;
  Body body{};
  ByteWriter w{body};
  w.u8(code);
  w.bytes(data);
  w.u8(status);
  return build_telegram(out, kAddressToHost, std::span{body}.first(w.size()));
}

std::size_t build_mode_reply(std::span<std::uint8_t> out, ModeResult result, std::uint8_t status) {
  const std::uint8_t data[] = {static_cast<std::uint8_t>(result)};
  return build_reply(out, static_cast<std::uint8_t>(Reply::change_mode), data, status);
}

std::size_t build_variant_reply(std::span<std::uint8_t> out, bool accepted, LaserVariant variant, std::uint8_t status) {
  std::array<std::uint8_t, 5> data{};
  ByteWriter w{data};
  w.u8(accepted ? 0x01 : 0x00);
  w.u16(variant.fov_deg);
  w.u16(variant.resolution_cdeg);
  return build_reply(out, static_cast<std::uint8_t>(Reply::variant), data, status);
}

std::size_t build_power_on(std::span<std::uint8_t> out, std::string_view text, std::uint8_t status) {
  std::array<std::uint8_t, 21> data{};
  ByteWriter w{data};
  w.text(text, data.size());
  return build_reply(out, static_cast<std::uint8_t>(Reply::power_on), data, status);
}

std::size_t build_reset_ack(std::span<std::uint8_t> out, std::uint8_t status) {
  return build_reply(out, static_cast<std::uint8_t>(Reply::reset_ack), {}, status);
}

std::size_t build_incorrect_command(std::span<std::uint8_t> out, std::uint8_t status) {
  return build_reply(out, static_cast<std::uint8_t>(Reply::incorrect_command), {}, status);
}

std::size_t build_lms_type_reply(std::span<std::uint8_t> out, std::string_view type, std::uint8_t status) {
  std::array<std::uint8_t, 20> data{};
  ByteWriter w{data};
  w.text(type, data.size());
  return build_reply(out, static_cast<std::uint8_t>(Reply::lms_type), data, status);
}

std::size_t build_config_reply(std::span<std::uint8_t> out, std::span<const std::uint8_t> config, std::uint8_t status) {
  if (config.size() > kMaxConfigBytes) return 0;
  return build_reply(out, static_cast<std::uint8_t>(Reply::read_config), config, status);
}

std::size_t build_write_config_reply(std::span<std::uint8_t> out, bool accepted, std::span<const std::uint8_t> config,
                                     std::uint8_t status) {
  if (config.size() > kMaxConfigBytes) return 0;
  std::array<std::uint8_t, 1 + kMaxConfigBytes> data{};
  ByteWriter w{data};
  w.u8(accepted ? 0x01 : 0x00);
  w.bytes(config);
  return build_reply(out, static_cast<std::uint8_t>(Reply::write_config), std::span{data}.first(w.size()), status);
}

std::size_t build_store_reply(std::span<std::uint8_t> out, bool accepted, std::uint8_t status) {
  const std::uint8_t data[] = {static_cast<std::uint8_t>(accepted ? 0x01 : 0x00)};
  return build_reply(out, static_cast<std::uint8_t>(Reply::store_permanent), data, status);
}

namespace {
// Offsets of §2.8 are counted from the reply code at 0; in the data they are one less.
constexpr std::size_t kStVersion = 0, kStMode = 7, kStDevice = 8, kStVariantType = 17, kStMeasMode = 101,
                      kStAngle = 106, kStResolution = 108, kStBaud = 115, kStPermBaud = 118, kStAddress = 119,
                      kStUnits = 121;
std::uint16_t rd16(std::span<const std::uint8_t> d, std::size_t off) {
  return static_cast<std::uint16_t>(d[off] | (d[off + 1] << 8));
}
void wr16(std::span<std::uint8_t> d, std::size_t off, std::uint16_t v) {
  d[off] = static_cast<std::uint8_t>(v & 0xFF);
  d[off + 1] = static_cast<std::uint8_t>(v >> 8);
}
}  // namespace

std::size_t build_status_reply(std::span<std::uint8_t> out, const StatusInfo& info, std::uint8_t status) {
  std::array<std::uint8_t, kStatusDataBytes> data{};
  for (std::size_t i = 0; i < 7; ++i)
    data[kStVersion + i] = i < info.software_version.size() ? static_cast<std::uint8_t>(info.software_version[i]) : ' ';
  data[kStMode] = info.operating_mode;
  data[kStDevice] = info.device_status;
  // Variant type byte (sicktoolbox): 0 = 180°, 1 = 100°.
  data[kStVariantType] = info.variant.fov_deg == 100 ? 1 : 0;
  data[kStMeasMode] = info.measuring_mode;
  wr16(data, kStAngle, info.variant.fov_deg);
  wr16(data, kStResolution, info.variant.resolution_cdeg);
  wr16(data, kStBaud, status_baud_code(info.baud));
  data[kStPermBaud] = info.permanent_baud ? 1 : 0;
  data[kStAddress] = info.unit_address;
  data[kStUnits] = info.units;
  return build_reply(out, static_cast<std::uint8_t>(Reply::status), data, status);
}

std::optional<StatusInfo> parse_status_data(std::span<const std::uint8_t> data) {
  if (data.size() < kStatusDataBytes) return std::nullopt;
  StatusInfo info;
  info.software_version = std::string_view{reinterpret_cast<const char*>(data.data()) + kStVersion, 7};
  info.operating_mode = data[kStMode];
  info.device_status = data[kStDevice];
  info.measuring_mode = data[kStMeasMode];
  info.variant.fov_deg = rd16(data, kStAngle);
  info.variant.resolution_cdeg = rd16(data, kStResolution);
  info.baud = baud_from_status_code(rd16(data, kStBaud));
  info.permanent_baud = data[kStPermBaud] != 0;
  info.unit_address = data[kStAddress];
  info.units = data[kStUnits];
  return info;
}

std::size_t build_scan_reply(std::span<std::uint8_t> out, std::uint16_t count_word,
                             std::span<const std::uint16_t> value_words, std::optional<std::uint8_t> realtime_index,
                             std::uint8_t status) {
  if (value_words.size() > kMaxBeams) return 0;
  std::array<std::uint8_t, 2 + 2 * kMaxBeams + 1> data{};
  ByteWriter w{data};
  w.u16(count_word);
  for (const auto v : value_words) w.u16(v);
  if (realtime_index) w.u8(*realtime_index);
  return build_reply(out, static_cast<std::uint8_t>(Reply::measured_values), std::span{data}.first(w.size()), status);
}

bool verify_telegram(std::span<const std::uint8_t> bytes) {
  if (bytes.size() < kFrameOverhead + 1 || bytes[0] != kStx) return false;
  const std::size_t length = static_cast<std::size_t>(bytes[2] | (bytes[3] << 8));
  if (length == 0 || bytes.size() != length + kFrameOverhead) return false;
  const std::uint16_t crc = static_cast<std::uint16_t>(bytes[bytes.size() - 2] | (bytes[bytes.size() - 1] << 8));
  return sick_crc16(bytes.first(bytes.size() - 2)) == crc;
}

const char* command_name(std::uint8_t code) {
  switch (code) {
    case 0x10: return "reset";
    case 0x20: return "change_mode";
    case 0x30: return "poll_values";
    case 0x31: return "status";
    case 0x32: return "error_telegram";
    case 0x3A: return "lms_type";
    case 0x3B: return "variant";
    case 0x66: return "store_permanent";
    case 0x74: return "read_config";
    case 0x77: return "write_config";
    default: return "unknown";
  }
}

const char* reply_name(std::uint8_t code) {
  switch (code) {
    case 0x90: return "power_on";
    case 0x91: return "reset_ack";
    case 0x92: return "incorrect_command";
    case 0xA0: return "change_mode";
    case 0xB0: return "measured_values";
    case 0xB1: return "status";
    case 0xB2: return "error_telegram";
    case 0xBA: return "lms_type";
    case 0xBB: return "variant";
    case 0xE6: return "store_permanent";
    case 0xF4: return "read_config";
    case 0xF7: return "write_config";
    default: return "unknown";
  }
}

}  // namespace teamscan::lms200
