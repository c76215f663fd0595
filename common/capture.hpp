// The serial capture format (*.cap), shared by the recorder, the replayer, the simulator and the tests.
//
//   #teamscan-capture 1
//   #device lms200
//   #baud 0 9600
//   1234 tx 02 00 01 00 31 15 12
//   1301 rx 06
//   #baud 250000 500000
//
// One chunk per line: time in microseconds, direction (`rx` = from the device, `tx` = to the device),
// the bytes in hex. Lines starting with `#` and a keyword are headers: the device kind (once, first)
// and every baud change (time in µs, rate). Lines starting with `# ` (hash, space) are comments.
#pragma once

#include <cstdint>
#include <cstdio>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "common/result.hpp"

namespace teamscan {

enum class DeviceKind : std::uint8_t { unknown, arcos, lms200 };
enum class CaptureDirection : std::uint8_t { rx, tx };  // rx: device -> host, tx: host -> device

[[nodiscard]] const char* to_string(DeviceKind kind);
[[nodiscard]] DeviceKind device_kind_from_string(std::string_view s);

struct CaptureRecord {
  enum class Kind : std::uint8_t { chunk, baud };
  Kind kind = Kind::chunk;
  std::int64_t time_us = 0;
  CaptureDirection direction = CaptureDirection::rx;  // chunk only
  std::uint32_t baud = 0;                             // baud only
  std::vector<std::uint8_t> bytes;                    // chunk only
};

struct Capture {
  DeviceKind device = DeviceKind::unknown;
  std::vector<CaptureRecord> records;
  // The concatenated bytes of one direction, in order.
  [[nodiscard]] std::vector<std::uint8_t> bytes(CaptureDirection direction) const;
};

// Appends records to a capture file; every line is flushed so that a crash loses nothing written.
class CaptureWriter {
 public:
  CaptureWriter() = default;
  CaptureWriter(const CaptureWriter&) = delete;
  CaptureWriter& operator=(const CaptureWriter&) = delete;
  CaptureWriter(CaptureWriter&& o) noexcept;
  CaptureWriter& operator=(CaptureWriter&& o) noexcept;
  ~CaptureWriter();

  // Creates (truncates) `path` and writes the header. `initial_baud` 0 = no baud header.
  [[nodiscard]] static Result<CaptureWriter> create(const std::string& path, DeviceKind device,
                                                    std::uint32_t initial_baud);
  [[nodiscard]] Status chunk(std::int64_t time_us, CaptureDirection direction, std::span<const std::uint8_t> bytes);
  [[nodiscard]] Status baud(std::int64_t time_us, std::uint32_t baud);
  [[nodiscard]] Status close();
  [[nodiscard]] bool is_open() const { return file_ != nullptr; }

 private:
  std::FILE* file_ = nullptr;
};

// Parses a whole capture. Malformed input gives an Error whose `detail` is the 1-based line number.
[[nodiscard]] Result<Capture> parse_capture(std::string_view text);
[[nodiscard]] Result<Capture> load_capture(const std::string& path);
// Renders a capture in the text format (inverse of parse_capture).
[[nodiscard]] std::string format_capture(const Capture& capture);

}  // namespace teamscan
