// SICK LMS 2xx binary telegrams (PROTOCOLS.md §2.2–§2.8): the SICK "CRC16", builders for every host
// command and every device reply, written into caller-owned fixed buffers (no allocation).
//
// A telegram on the wire: STX, address (0x00 host->LMS, 0x80 LMS->host), length L (u16 LE, command
// byte up to the status byte), command/reply code, data, [status byte: replies only], CRC (u16 LE).
// Every builder returns the number of bytes written, or 0 when `out` is too small or an argument
// cannot be encoded (a runtime fault the caller handles; nothing is written past `out`).
#pragma once

#include <cstddef>
#include <cstdint>
#include <optional>
#include <span>
#include <string_view>

#include "common/capacities.hpp"
#include "common/laser_geometry.hpp"

namespace teamscan::lms200 {

inline constexpr std::uint8_t kStx = 0x02;
inline constexpr std::uint8_t kAddressToLms = 0x00;   // host -> LMS (default unit 0), §2.2
inline constexpr std::uint8_t kAddressToHost = 0x80;  // LMS -> host: 0x80 + unit address
inline constexpr std::uint8_t kAck = 0x06;            // lone byte after an accepted host telegram
inline constexpr std::uint8_t kNak = 0x15;            // lone byte after a rejected one (bad CRC/format)
inline constexpr std::size_t kHeaderBytes = 4;        // STX, address, length
inline constexpr std::size_t kFrameOverhead = 6;      // header + CRC: total = L + 6
inline constexpr std::size_t kMaxLength = kMaxLmsTelegram - kFrameOverhead;  // largest L accepted
inline constexpr std::uint8_t kHealthyStatus = 0x10;  // status byte of every public capture (§2.9)
inline constexpr std::string_view kSetupPassword = "SICK_LMS";  // §2.4, mode 0x00
inline constexpr std::size_t kConfigBytes = 32;        // 0x74/0x77 block of older firmware (§2.6)
inline constexpr std::size_t kMaxConfigBytes = 34;     // newer firmware adds block A4

// Host command codes (§2.4).
enum class Command : std::uint8_t {
  reset = 0x10,
  change_mode = 0x20,
  poll_values = 0x30,
  status = 0x31,
  error_telegram = 0x32,
  lms_type = 0x3A,
  variant = 0x3B,
  store_permanent = 0x66,
  read_config = 0x74,
  write_config = 0x77,
};

// Reply codes: command + 0x80, plus the unsolicited telegrams (§2.4, §2.2).
enum class Reply : std::uint8_t {
  power_on = 0x90,           // 21 bytes of type/firmware text, sent at the power-up rate
  reset_ack = 0x91,          // reset acknowledged; 0x90 follows at 9600
  incorrect_command = 0x92,  // syntactically valid but illegal/unsupported command
  change_mode = 0xA0,
  measured_values = 0xB0,
  status = 0xB1,
  error_telegram = 0xB2,
  lms_type = 0xBA,
  variant = 0xBB,
  store_permanent = 0xE6,
  read_config = 0xF4,
  write_config = 0xF7,
};

[[nodiscard]] constexpr std::uint8_t reply_code_for(Command c) {
  return static_cast<std::uint8_t>(static_cast<std::uint8_t>(c) + 0x80);
}

// Operating-mode byte of command 0x20 (§2.4).
enum class OperatingMode : std::uint8_t {
  setup = 0x00,  // followed by the 8-byte password
  diagnostic = 0x10,
  continuous = 0x24,  // continuous output of all measured values (0xB0 stream)
  polled = 0x25,      // values on request only: stops the stream
  baud_38400 = 0x40,
  baud_19200 = 0x41,
  baud_9600 = 0x42,
  baud_500000 = 0x48,
};

// Result byte of the 0xA0 reply (§2.4).
enum class ModeResult : std::uint8_t { done = 0x00, bad_password = 0x01, lms_fault = 0x02 };

// The four line rates of the LMS (§2.1) and their mode bytes; nullopt for any other rate.
[[nodiscard]] std::optional<OperatingMode> baud_mode(std::uint32_t baud);
[[nodiscard]] std::uint32_t baud_of_mode(OperatingMode mode);  // 0 if `mode` is no baud switch
// Baud code of the status reply offsets 116..117 (§2.8); 0 for an unknown rate.
[[nodiscard]] std::uint16_t status_baud_code(std::uint32_t baud);
[[nodiscard]] std::uint32_t baud_from_status_code(std::uint16_t code);

// The SICK CRC of §2.3 exactly: register R and previous byte P start at 0; per byte D: shift R left
// (XOR 0x8005 if the old bit 15 was set), XOR with (P << 8 | D), P = D. Sent low byte first.
[[nodiscard]] std::uint16_t sick_crc16(std::span<const std::uint8_t> bytes);

// A complete telegram: header, `body` (command or reply code, data, and for replies the status
// byte), CRC. Returns body.size() + 6, or 0 if it does not fit or L would exceed kMaxLength.
[[nodiscard]] std::size_t build_telegram(std::span<std::uint8_t> out, std::uint8_t address,
                                         std::span<const std::uint8_t> body);

// ---- host -> LMS (§2.4) ----
[[nodiscard]] std::size_t build_status_request(std::span<std::uint8_t> out);                    // 0x31
[[nodiscard]] std::size_t build_mode(std::span<std::uint8_t> out, OperatingMode mode);          // 0x20 m
[[nodiscard]] std::size_t build_setup_mode(std::span<std::uint8_t> out,
                                           std::string_view password = kSetupPassword);         // 0x20 00 pw
[[nodiscard]] std::size_t build_baud_switch(std::span<std::uint8_t> out, std::uint32_t baud);   // 0x20 4x
[[nodiscard]] std::size_t build_start_continuous(std::span<std::uint8_t> out);                  // 0x20 24
[[nodiscard]] std::size_t build_stop_continuous(std::span<std::uint8_t> out);                   // 0x20 25
[[nodiscard]] std::size_t build_poll_scan(std::span<std::uint8_t> out);                         // 0x30 01
[[nodiscard]] std::size_t build_variant(std::span<std::uint8_t> out, LaserVariant variant);      // 0x3B
[[nodiscard]] std::size_t build_read_config(std::span<std::uint8_t> out);                       // 0x74
[[nodiscard]] std::size_t build_write_config(std::span<std::uint8_t> out,
                                             std::span<const std::uint8_t> config);             // 0x77
[[nodiscard]] std::size_t build_reset(std::span<std::uint8_t> out);                             // 0x10
// 0x66: what = 0x01 the current baud rate, 0x02 the configuration.
[[nodiscard]] std::size_t build_store_permanent(std::span<std::uint8_t> out, std::uint8_t what);
[[nodiscard]] std::size_t build_lms_type_request(std::span<std::uint8_t> out);                  // 0x3A

// The variants of §2.5 (180°/0.25° is not one); the 0x3B arguments are degrees and 1/100 degree.
[[nodiscard]] bool is_supported_variant(LaserVariant variant);

// ---- LMS -> host (§2.4, §2.8) ----
// A reply telegram: code, data, status byte.
[[nodiscard]] std::size_t build_reply(std::span<std::uint8_t> out, std::uint8_t code,
                                      std::span<const std::uint8_t> data, std::uint8_t status = kHealthyStatus);
[[nodiscard]] std::size_t build_mode_reply(std::span<std::uint8_t> out, ModeResult result,
                                           std::uint8_t status = kHealthyStatus);          // 0xA0
[[nodiscard]] std::size_t build_variant_reply(std::span<std::uint8_t> out, bool accepted, LaserVariant variant,
                                              std::uint8_t status = kHealthyStatus);       // 0xBB
// 0x90 carries 21 bytes of text (29 bytes on the wire, §2.1); `text` is cut or space-padded to 21.
[[nodiscard]] std::size_t build_power_on(std::span<std::uint8_t> out, std::string_view text,
                                         std::uint8_t status = kHealthyStatus);
[[nodiscard]] std::size_t build_reset_ack(std::span<std::uint8_t> out, std::uint8_t status = kHealthyStatus);
[[nodiscard]] std::size_t build_incorrect_command(std::span<std::uint8_t> out,
                                                  std::uint8_t status = kHealthyStatus);   // 0x92
// 0xBA: the type string, cut or space-padded to 20 bytes (rl reads 21 incl. the status byte).
[[nodiscard]] std::size_t build_lms_type_reply(std::span<std::uint8_t> out, std::string_view type,
                                               std::uint8_t status = kHealthyStatus);
[[nodiscard]] std::size_t build_config_reply(std::span<std::uint8_t> out, std::span<const std::uint8_t> config,
                                             std::uint8_t status = kHealthyStatus);        // 0xF4
[[nodiscard]] std::size_t build_write_config_reply(std::span<std::uint8_t> out, bool accepted,
                                                   std::span<const std::uint8_t> config,
                                                   std::uint8_t status = kHealthyStatus);  // 0xF7
[[nodiscard]] std::size_t build_store_reply(std::span<std::uint8_t> out, bool accepted,
                                            std::uint8_t status = kHealthyStatus);         // 0xE6

// Fields of the 152-byte 0xB1 status data this project reads or writes (§2.8).
struct StatusInfo {
  std::string_view software_version = "V02.10 ";  // 7 ASCII bytes, offsets 1..7
  std::uint8_t operating_mode = static_cast<std::uint8_t>(OperatingMode::polled);
  std::uint8_t device_status = 0;
  std::uint8_t measuring_mode = 0;
  LaserVariant variant{};
  std::uint32_t baud = 9600;
  bool permanent_baud = false;
  std::uint8_t unit_address = 0;
  std::uint8_t units = 0;  // config block E: 0 cm, 1 mm, 2 dm
};
inline constexpr std::size_t kStatusDataBytes = 152;
[[nodiscard]] std::size_t build_status_reply(std::span<std::uint8_t> out, const StatusInfo& info,
                                             std::uint8_t status = kHealthyStatus);        // 0xB1
// Reads the fields back from a status telegram's data (the bytes after the reply code, before status).
[[nodiscard]] std::optional<StatusInfo> parse_status_data(std::span<const std::uint8_t> data);

// 0xB0: count word, value words, optional real-time scan index, status (§2.7). Encoding of the
// words themselves is in scan.hpp.
[[nodiscard]] std::size_t build_scan_reply(std::span<std::uint8_t> out, std::uint16_t count_word,
                                           std::span<const std::uint16_t> value_words,
                                           std::optional<std::uint8_t> realtime_index,
                                           std::uint8_t status = kHealthyStatus);

// ---- reading a verified telegram (the parser has checked framing and CRC) ----
struct TelegramView {
  std::span<const std::uint8_t> bytes;  // the whole telegram, STX .. CRC
  [[nodiscard]] std::uint8_t address() const { return bytes[1]; }
  [[nodiscard]] std::uint16_t length() const {
    return static_cast<std::uint16_t>(bytes[2] | (bytes[3] << 8));
  }
  [[nodiscard]] std::uint8_t code() const { return bytes[4]; }
  [[nodiscard]] bool from_device() const { return (bytes[1] & 0x80) != 0; }
  // Data after the code; for replies without the status byte.
  [[nodiscard]] std::span<const std::uint8_t> data() const {
    const std::size_t n = length() - 1u - (from_device() ? 1u : 0u);
    return bytes.subspan(5, n);
  }
  // The status byte of a reply (§2.9).
  [[nodiscard]] std::uint8_t status() const { return bytes[kHeaderBytes + length() - 1u]; }
};

// Checks framing and CRC of one complete telegram (exact size). Used by tests and tools.
[[nodiscard]] bool verify_telegram(std::span<const std::uint8_t> bytes);

[[nodiscard]] const char* command_name(std::uint8_t code);  // host command names, "unknown" otherwise
[[nodiscard]] const char* reply_name(std::uint8_t code);    // reply names, "unknown" otherwise

}  // namespace teamscan::lms200
