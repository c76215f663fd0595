// The `teamscan decode` inspector framework: input chunks (from a .cap or raw bytes) handed to the
// per-device decoders, and the tiny JSON-lines writer they share (one object per line).
#pragma once

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <span>
#include <string_view>
#include <type_traits>
#include <vector>

#include <nlohmann/json.hpp>

#include "common/capture.hpp"
#include "common/result.hpp"

namespace teamscan::tool {

// One run of bytes in one direction, as read from the capture or the raw file.
struct DecodeChunk {
  std::int64_t time_us = 0;                           // capture time; 0 for raw input
  CaptureDirection direction = CaptureDirection::rx;  // rx: device -> host, tx: host -> device
  std::uint32_t baud = 0;                             // the line rate in force (from #baud or --baud)
  std::vector<std::uint8_t> bytes;
};

struct DecodeInput {
  std::vector<DecodeChunk> chunks;
  DeviceKind device = DeviceKind::unknown;  // from the capture's #device header; unknown for raw input
};

// True if `data` is a capture: "#teamscan-capture" first, after any "# " comment or blank lines.
[[nodiscard]] inline bool looks_like_capture(std::string_view data) {
  while (!data.empty()) {
    if (data.rfind("#teamscan-capture", 0) == 0) return true;
    const bool skippable = data.rfind("# ", 0) == 0 || data[0] == '\n' || data.rfind("\r\n", 0) == 0;
    if (!skippable) return false;
    const std::size_t nl = data.find('\n');
    if (nl == std::string_view::npos) return false;
    data.remove_prefix(nl + 1);
  }
  return false;
}

// Builds the decoder input from a whole file: a capture gives one chunk per record, each with the
// rate of the last #baud before it (`baud` until the first); raw bytes give one chunk in
// `raw_direction` at `baud`. A malformed capture is an Error whose detail is the line number.
[[nodiscard]] inline Result<DecodeInput> make_decode_input(std::string_view data, std::uint32_t baud,
                                                           CaptureDirection raw_direction = CaptureDirection::rx) {
  DecodeInput in;
  if (!looks_like_capture(data)) {
    if (!data.empty()) {
      DecodeChunk c;
      c.direction = raw_direction;
      c.baud = baud;
      c.bytes.assign(data.begin(), data.end());
      in.chunks.push_back(std::move(c));
    }
    return in;
  }
  auto cap = parse_capture(data);
  if (!cap) return cap.error();
  in.device = cap->device;
  for (auto& r : cap->records) {
    if (r.kind == CaptureRecord::Kind::baud) {
      baud = r.baud;
      continue;
    }
    in.chunks.push_back(DecodeChunk{r.time_us, r.direction, baud, std::move(r.bytes)});
  }
  return in;
}

// Implemented by the device engineers in tools/teamscan/support_decode_arcos.cpp and
// support_decode_lms200.cpp. Print one JSON object per packet/telegram/ACK/NAK and per bad input
// ({"error": "bad_crc"|"bad_length"|"garbage"...}), in both directions, then a summary object:
// {"summary": {"packets": N, "bad_crc": N, "discarded_bytes": N, "resyncs": N}}.
// Return 0 when the input was read (bad bytes in it are reported, not failures), non-zero otherwise.
// Until they land, cmd_decode.cpp provides weak definitions that print {"error":"decoder not built"}.
int decode_arcos(const DecodeInput& in, std::FILE* out);
int decode_lms200(const DecodeInput& in, std::FILE* out);

// Writes one JSON object on one line:
//   JsonLine j{out}; j.field("type", "sip").field("x_mm", 12).array("ranges_mm", ranges); j.end();
//   -> {"type":"sip","x_mm":12,"ranges_mm":[1,2,3]}
// Nested objects: j.begin_object("summary") ... j.end_object(). end() closes every open object and
// writes the newline. Non-finite doubles are written as null (JSON has no NaN/Inf).
class JsonLine {
 public:
  explicit JsonLine(std::FILE* out) : out_{out} { std::fputc('{', out_); }
  JsonLine(const JsonLine&) = delete;
  JsonLine& operator=(const JsonLine&) = delete;
  ~JsonLine() {
    if (!ended_) end();
  }

  JsonLine& field(std::string_view key, std::string_view value) {
    write_key(key);
    write_string(out_, value);
    return *this;
  }
  JsonLine& field(std::string_view key, const char* value) { return field(key, std::string_view{value}); }
  JsonLine& field(std::string_view key, bool value) {
    write_key(key);
    std::fputs(value ? "true" : "false", out_);
    return *this;
  }
  JsonLine& field(std::string_view key, std::int64_t value) {
    write_key(key);
    std::fprintf(out_, "%lld", static_cast<long long>(value));
    return *this;
  }
  JsonLine& field(std::string_view key, int value) { return field(key, static_cast<std::int64_t>(value)); }
  JsonLine& field(std::string_view key, long long value) { return field(key, static_cast<std::int64_t>(value)); }
  JsonLine& field(std::string_view key, unsigned value) { return field(key, static_cast<std::int64_t>(value)); }
  JsonLine& field(std::string_view key, unsigned long value) { return field(key, static_cast<unsigned long long>(value)); }
  JsonLine& field(std::string_view key, unsigned long long value) {
    write_key(key);
    std::fprintf(out_, "%llu", value);
    return *this;
  }
  JsonLine& field(std::string_view key, double value) {
    write_key(key);
    write_number(out_, value);
    return *this;
  }
  // Bytes as a lower-case hex string without separators ("fafb03"): compact and greppable.
  JsonLine& hex(std::string_view key, std::span<const std::uint8_t> bytes) {
    write_key(key);
    static constexpr char kHex[] = "0123456789abcdef";
    std::fputc('"', out_);
    for (std::uint8_t b : bytes) {
      std::fputc(kHex[b >> 4], out_);
      std::fputc(kHex[b & 0xF], out_);
    }
    std::fputc('"', out_);
    return *this;
  }
  template <class T>
  JsonLine& array(std::string_view key, std::span<const T> values) {
    write_key(key);
    std::fputc('[', out_);
    bool first = true;
    for (const T& v : values) {
      if (!first) std::fputc(',', out_);
      first = false;
      write_value(v);
    }
    std::fputc(']', out_);
    return *this;
  }
  template <class T>
  JsonLine& array(std::string_view key, const std::vector<T>& values) {
    return array(key, std::span<const T>{values});
  }
  JsonLine& begin_object(std::string_view key) {
    write_key(key);
    std::fputc('{', out_);
    ++depth_;
    first_ = true;
    return *this;
  }
  JsonLine& end_object() {
    if (depth_ > 0) {
      std::fputc('}', out_);
      --depth_;
      first_ = false;
    }
    return *this;
  }
  void end() {
    if (ended_) return;
    while (depth_ > 0) end_object();
    std::fputs("}\n", out_);
    ended_ = true;
  }

  // JSON string with quotes, escaped by nlohmann-json (invalid UTF-8 replaced, not refused).
  static void write_string(std::FILE* out, std::string_view s) {
    std::fputs(nlohmann::json(std::string{s}).dump(-1, ' ', false, nlohmann::json::error_handler_t::replace).c_str(), out);
  }
  static void write_number(std::FILE* out, double v) {
    if (!std::isfinite(v)) std::fputs("null", out);
    else std::fprintf(out, "%.10g", v);
  }

 private:
  void write_key(std::string_view key) {
    if (!first_) std::fputc(',', out_);
    first_ = false;
    write_string(out_, key);
    std::fputc(':', out_);
  }
  void write_value(std::string_view v) { write_string(out_, v); }
  void write_value(const char* v) { write_string(out_, v); }
  void write_value(bool v) { std::fputs(v ? "true" : "false", out_); }
  void write_value(double v) { write_number(out_, v); }
  void write_value(float v) { write_number(out_, static_cast<double>(v)); }
  template <class I>
  void write_value(I v) {
    static_assert(std::is_integral_v<I>, "JSON arrays hold numbers, strings or bools");
    if constexpr (std::is_signed_v<I>) std::fprintf(out_, "%lld", static_cast<long long>(v));
    else std::fprintf(out_, "%llu", static_cast<unsigned long long>(v));
  }

  std::FILE* out_;
  int depth_ = 0;
  bool first_ = true;
  bool ended_ = false;
};

}  // namespace teamscan::tool
