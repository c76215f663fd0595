// The serial capture format: writer and parser (see capture.hpp for the grammar).
#include "common/capture.hpp"

#include <cerrno>
#include <charconv>
#include <cstring>

namespace teamscan {

const char* to_string(DeviceKind kind) {
  switch (kind) {
    case DeviceKind::arcos: return "arcos";
    case DeviceKind::lms200: return "lms200";
    case DeviceKind::unknown: break;
  }
  return "unknown";
}

DeviceKind device_kind_from_string(std::string_view s) {
  if (s == "arcos") return DeviceKind::arcos;
  if (s == "lms200") return DeviceKind::lms200;
  return DeviceKind::unknown;
}

std::vector<std::uint8_t> Capture::bytes(CaptureDirection direction) const {
  std::vector<std::uint8_t> out;
  for (const auto& r : records)
    if (r.kind == CaptureRecord::Kind::chunk && r.direction == direction) out.insert(out.end(), r.bytes.begin(), r.bytes.end());
  return out;
}

CaptureWriter::CaptureWriter(CaptureWriter&& o) noexcept : file_{o.file_} { o.file_ = nullptr; }
CaptureWriter& CaptureWriter::operator=(CaptureWriter&& o) noexcept {
  if (this != &o) {
    if (file_ != nullptr) std::fclose(file_);
    file_ = o.file_;
    o.file_ = nullptr;
  }
  return *this;
}
CaptureWriter::~CaptureWriter() {
  if (file_ != nullptr) std::fclose(file_);
}

Result<CaptureWriter> CaptureWriter::create(const std::string& path, DeviceKind device, std::uint32_t initial_baud) {
  CaptureWriter w;
  w.file_ = std::fopen(path.c_str(), "w");
  if (w.file_ == nullptr) return Error{"cannot create capture file", errno};
  if (std::fprintf(w.file_, "#teamscan-capture 1\n#device %s\n", to_string(device)) < 0) return Error{"write failed", errno};
  if (initial_baud != 0) {
    if (std::fprintf(w.file_, "#baud 0 %u\n", initial_baud) < 0) return Error{"write failed", errno};
  }
  if (std::fflush(w.file_) != 0) return Error{"flush failed", errno};
  return w;
}

Status CaptureWriter::chunk(std::int64_t time_us, CaptureDirection direction, std::span<const std::uint8_t> bytes) {
  if (file_ == nullptr) return Error{"capture writer is closed"};
  if (bytes.empty()) return ok_status();
  static constexpr char kHex[] = "0123456789ABCDEF";
  std::string line = std::to_string(time_us);
  line += direction == CaptureDirection::rx ? " rx" : " tx";
  line.reserve(line.size() + bytes.size() * 3 + 1);
  for (std::uint8_t b : bytes) {
    line += ' ';
    line += kHex[b >> 4];
    line += kHex[b & 0xF];
  }
  line += '\n';
  if (std::fwrite(line.data(), 1, line.size(), file_) != line.size()) return Error{"write failed", errno};
  if (std::fflush(file_) != 0) return Error{"flush failed", errno};
  return ok_status();
}

Status CaptureWriter::baud(std::int64_t time_us, std::uint32_t rate) {
  if (file_ == nullptr) return Error{"capture writer is closed"};
  if (std::fprintf(file_, "#baud %lld %u\n", static_cast<long long>(time_us), rate) < 0) return Error{"write failed", errno};
  if (std::fflush(file_) != 0) return Error{"flush failed", errno};
  return ok_status();
}

Status CaptureWriter::close() {
  if (file_ == nullptr) return ok_status();
  const int rc = std::fclose(file_);
  file_ = nullptr;
  if (rc != 0) return Error{"close failed", errno};
  return ok_status();
}

namespace {

std::string_view next_token(std::string_view& s) {
  std::size_t i = 0;
  while (i < s.size() && (s[i] == ' ' || s[i] == '\t')) ++i;
  std::size_t j = i;
  while (j < s.size() && s[j] != ' ' && s[j] != '\t') ++j;
  std::string_view tok = s.substr(i, j - i);
  s.remove_prefix(j);
  return tok;
}

template <class Int>
bool parse_int(std::string_view tok, Int& out) {
  if (tok.empty()) return false;
  auto [ptr, ec] = std::from_chars(tok.data(), tok.data() + tok.size(), out);
  return ec == std::errc{} && ptr == tok.data() + tok.size();
}

int hex_value(char c) {
  if (c >= '0' && c <= '9') return c - '0';
  if (c >= 'a' && c <= 'f') return c - 'a' + 10;
  if (c >= 'A' && c <= 'F') return c - 'A' + 10;
  return -1;
}

}  // namespace

Result<Capture> parse_capture(std::string_view text) {
  Capture cap;
  long line_no = 0;
  bool saw_magic = false;
  while (!text.empty()) {
    const std::size_t nl = text.find('\n');
    std::string_view line = text.substr(0, nl);
    text.remove_prefix(nl == std::string_view::npos ? text.size() : nl + 1);
    ++line_no;
    if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
    if (line.find_first_not_of(" \t") == std::string_view::npos) continue;
    if (line[0] == '#') {
      if (line.size() >= 2 && line[1] == ' ') continue;  // comment
      std::string_view rest = line.substr(1);
      const std::string_view key = next_token(rest);
      if (key == "teamscan-capture") {
        const std::string_view version = next_token(rest);
        if (version != "1") return Error{"unsupported capture version", 0, line_no};
        saw_magic = true;
      } else if (key == "device") {
        const std::string_view kind = next_token(rest);
        cap.device = device_kind_from_string(kind);
        // `unknown` is what format_capture writes for a capture of an unnamed device: accept it.
        if (cap.device == DeviceKind::unknown && kind != "unknown")
          return Error{"unknown device kind in capture header", 0, line_no};
      } else if (key == "baud") {
        CaptureRecord r;
        r.kind = CaptureRecord::Kind::baud;
        if (!parse_int(next_token(rest), r.time_us) || !parse_int(next_token(rest), r.baud) || r.baud == 0)
          return Error{"malformed #baud header (want: #baud TIME_US RATE)", 0, line_no};
        cap.records.push_back(std::move(r));
      } else {
        return Error{"unknown capture header keyword", 0, line_no};
      }
      continue;
    }
    if (!saw_magic) return Error{"not a teamscan capture (missing #teamscan-capture 1)", 0, line_no};
    CaptureRecord r;
    if (!parse_int(next_token(line), r.time_us)) return Error{"malformed time stamp in capture", 0, line_no};
    const std::string_view dir = next_token(line);
    if (dir == "rx") r.direction = CaptureDirection::rx;
    else if (dir == "tx") r.direction = CaptureDirection::tx;
    else return Error{"direction must be rx or tx", 0, line_no};
    for (std::string_view tok = next_token(line); !tok.empty(); tok = next_token(line)) {
      if (tok.size() != 2) return Error{"malformed hex byte in capture", 0, line_no};
      const int hi = hex_value(tok[0]), lo = hex_value(tok[1]);
      if (hi < 0 || lo < 0) return Error{"malformed hex byte in capture", 0, line_no};
      r.bytes.push_back(static_cast<std::uint8_t>(hi * 16 + lo));
    }
    if (r.bytes.empty()) return Error{"capture chunk without bytes", 0, line_no};
    cap.records.push_back(std::move(r));
  }
  if (!saw_magic) return Error{"not a teamscan capture (missing #teamscan-capture 1)", 0, line_no};
  return cap;
}

Result<Capture> load_capture(const std::string& path) {
  std::FILE* f = std::fopen(path.c_str(), "rb");
  if (f == nullptr) return Error{"cannot open capture file", errno};
  std::string text;
  char buf[65536];
  std::size_t n = 0;
  while ((n = std::fread(buf, 1, sizeof buf, f)) > 0) text.append(buf, n);
  const bool failed = std::ferror(f) != 0;
  std::fclose(f);
  if (failed) return Error{"read error on capture file", errno};
  return parse_capture(text);
}

std::string format_capture(const Capture& capture) {
  static constexpr char kHex[] = "0123456789ABCDEF";
  std::string out = "#teamscan-capture 1\n#device ";
  out += to_string(capture.device);
  out += '\n';
  for (const auto& r : capture.records) {
    if (r.kind == CaptureRecord::Kind::baud) {
      out += "#baud " + std::to_string(r.time_us) + " " + std::to_string(r.baud) + "\n";
      continue;
    }
    out += std::to_string(r.time_us);
    out += r.direction == CaptureDirection::rx ? " rx" : " tx";
    for (std::uint8_t b : r.bytes) {
      out += ' ';
      out += kHex[b >> 4];
      out += kHex[b & 0xF];
    }
    out += '\n';
  }
  return out;
}

}  // namespace teamscan
