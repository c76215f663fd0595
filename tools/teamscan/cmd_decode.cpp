// `teamscan decode --device arcos|lms200 [--baud N] FILE`: reads a .cap or raw bytes into chunks and
// hands them to the device's decoder (decode.hpp), which prints one JSON object per line.
#include <cstdio>
#include <string>
#include <vector>

#include "common/capture.hpp"
#include "tools/teamscan/decode.hpp"
#include "tools/teamscan/subcommand.hpp"

namespace teamscan::tool {

// Weak defaults so the tool links before the device decoders land; a strong definition in
// support_decode_arcos.cpp / support_decode_lms200.cpp replaces them at link time.
__attribute__((weak)) int decode_arcos(const DecodeInput&, std::FILE* out) {
  std::fputs("{\"error\":\"decoder not built\"}\n", out);
  return 3;
}
__attribute__((weak)) int decode_lms200(const DecodeInput&, std::FILE* out) {
  std::fputs("{\"error\":\"decoder not built\"}\n", out);
  return 3;
}

namespace {

struct DecodeOptions {
  std::string device;
  std::string file;
  std::uint32_t baud = 9600;
  std::string direction = "rx";
};

bool read_all(const std::string& path, std::string& out) {
  std::FILE* f = path == "-" ? stdin : std::fopen(path.c_str(), "rb");
  if (f == nullptr) return false;
  char buf[65536];
  std::size_t n = 0;
  while ((n = std::fread(buf, 1, sizeof buf, f)) > 0) out.append(buf, n);
  const bool ok = std::ferror(f) == 0;
  if (f != stdin) std::fclose(f);
  return ok;
}

int run_decode(const DecodeOptions& opt) {
  std::string data;
  if (!read_all(opt.file, data)) {
    std::fprintf(stderr, "teamscan decode: cannot read %s\n", opt.file.c_str());
    return 1;
  }
  auto in = make_decode_input(data, opt.baud, opt.direction == "tx" ? CaptureDirection::tx : CaptureDirection::rx);
  if (!in) {
    std::fprintf(stderr, "teamscan decode: %s: line %ld: %s\n", opt.file.c_str(), in.error().detail, in.error().what);
    return 1;
  }
  if (in->device != DeviceKind::unknown && std::string{to_string(in->device)} != opt.device)
    std::fprintf(stderr, "teamscan decode: warning: capture is from a %s, decoding as %s\n", to_string(in->device),
                 opt.device.c_str());
  const int rc = opt.device == "arcos" ? decode_arcos(*in, stdout) : decode_lms200(*in, stdout);
  std::fflush(stdout);
  return rc;
}

const SubcommandRegistration kDecode{
    {"decode", "Decode a serial capture (.cap) or raw bytes as JSON lines, one object per packet",
     [](CLI::App& app) {
       auto opt = std::make_shared<DecodeOptions>();
       app.add_option("--device", opt->device, "Protocol: arcos (Pioneer) or lms200 (SICK LMS 2xx)")
           ->required()
           ->check(CLI::IsMember({"arcos", "lms200"}));
       app.add_option("--baud", opt->baud, "Line rate for raw input, or before a capture's first #baud header")
           ->capture_default_str();
       app.add_option("--direction", opt->direction, "Direction of raw input: rx (from the device) or tx (to it)")
           ->capture_default_str()
           ->check(CLI::IsMember({"rx", "tx"}));
       app.add_option("file", opt->file, "A .cap file (starts with #teamscan-capture) or raw bytes; - for stdin")
           ->required();
       return [opt] { return run_decode(*opt); };
     }}};

}  // namespace
}  // namespace teamscan::tool
