// `teamscan decode --device lms200`: every LMS 2xx telegram, ACK and NAK of a capture in both
// directions as one JSON object per line with its decoded fields (PROTOCOLS.md §2.4–§2.9), bad
// input as {"error": ...}, and a summary line. The measuring mode used to split 0xB0 value words is
// taken from the last configuration seen in the stream (0xF4 reply or 0x77 write), default mode 0.
#include <array>
#include <cstdio>
#include <string_view>

#include "drivers/lms200/codec.hpp"
#include "drivers/lms200/parser.hpp"
#include "drivers/lms200/scan.hpp"
#include "tools/teamscan/decode.hpp"

namespace teamscan::tool {
namespace {

using namespace teamscan::lms200;

const char* mode_name(std::uint8_t m) {
  switch (m) {
    case 0x00: return "setup";
    case 0x10: return "diagnostic";
    case 0x24: return "continuous";
    case 0x25: return "polled";
    case 0x26: return "continuous_mean";
    case 0x27: return "continuous_subrange";
    case 0x40: return "baud_38400";
    case 0x41: return "baud_19200";
    case 0x42: return "baud_9600";
    case 0x48: return "baud_500000";
    default: return "unknown";
  }
}

std::string_view ascii(std::span<const std::uint8_t> d) {
  std::size_t n = d.size();
  while (n > 0 && (d[n - 1] == ' ' || d[n - 1] == 0)) --n;
  return {reinterpret_cast<const char*>(d.data()), n};
}

class Lms200Decoder {
 public:
  explicit Lms200Decoder(std::FILE* out) : out_{out} {}

  void chunk(const DecodeChunk& c) {
    Side& side = c.direction == CaptureDirection::rx ? rx_ : tx_;
    if (side.baud != 0 && c.baud != side.baud) flush(side, c.time_us, "baud_change");
    side.baud = c.baud;
    std::span<const std::uint8_t> in{c.bytes};
    while (!in.empty()) {
      in = in.subspan(side.parser.feed(in));
      LmsEvent e;
      while (side.parser.next(e)) event(side, e, c.time_us);
    }
  }

  void finish() {
    flush(rx_, last_time_us_, "truncated");
    flush(tx_, last_time_us_, "truncated");
    const auto& r = rx_.parser.statistics();
    const auto& t = tx_.parser.statistics();
    JsonLine j{out_};
    j.begin_object("summary")
        .field("packets", r.telegrams + t.telegrams + r.acks + r.naks)
        .field("telegrams", r.telegrams + t.telegrams)
        .field("acks", r.acks)
        .field("naks", r.naks)
        .field("bad_crc", r.bad_crc + t.bad_crc)
        .field("bad_length", r.bad_length + t.bad_length)
        .field("discarded_bytes", r.discarded_bytes + t.discarded_bytes)
        .field("resyncs", r.resyncs + t.resyncs)
        .field("decode_errors", decode_errors_)
        .end_object();
  }

 private:
  struct Side {
    explicit Side(StreamDirection d) : parser{d} {}
    LmsParser parser;
    std::uint32_t baud = 0;
    const char* name() const { return parser.direction() == StreamDirection::from_device ? "rx" : "tx"; }
  };

  void flush(Side& side, std::int64_t time_us, const char* why) {
    if (side.parser.buffered() == 0) return;
    JsonLine j{out_};
    j.field("error", "garbage").field("reason", why).field("dir", side.name()).field("t_us", time_us)
        .field("byte_count", static_cast<std::uint64_t>(side.parser.buffered()));
    side.parser.reset();
  }

  void head(JsonLine& j, const Side& side, std::int64_t time_us) {
    j.field("dir", side.name()).field("t_us", time_us).field("baud", side.baud);
  }

  void event(Side& side, const LmsEvent& e, std::int64_t time_us) {
    last_time_us_ = time_us;
    JsonLine j{out_};
    switch (e.kind) {
      case LmsEvent::Kind::ack:
      case LmsEvent::Kind::nak:
        j.field("type", e.kind == LmsEvent::Kind::ack ? "ack" : "nak");
        head(j, side, time_us);
        return;
      case LmsEvent::Kind::bad_crc:
      case LmsEvent::Kind::bad_length:
      case LmsEvent::Kind::garbage:
        j.field("error", to_string(e.kind));
        head(j, side, time_us);
        j.hex("bytes", e.bytes);
        return;
      case LmsEvent::Kind::telegram: break;
    }
    const TelegramView t{e.bytes};
    const auto data = t.data();
    if (!t.from_device()) {
      j.field("type", "command").field("code", static_cast<unsigned>(t.code())).field("name", command_name(t.code()));
      head(j, side, time_us);
      command_fields(j, t.code(), data);
      return;
    }
    j.field("type", "reply").field("code", static_cast<unsigned>(t.code())).field("name", reply_name(t.code()));
    head(j, side, time_us);
    reply_fields(j, t, data);
    const StatusByte st{t.status()};
    j.field("status", static_cast<unsigned>(st.raw))
        .field("status_class", static_cast<unsigned>(st.error_class()))
        .field("implausible", st.implausible())
        .field("pollution", st.pollution());
  }

  void config_fields(JsonLine& j, std::span<const std::uint8_t> cfg) {
    j.hex("config", cfg);
    if (cfg.size() >= 7) {
      j.field("availability", static_cast<unsigned>(cfg[4]))
          .field("measuring_mode", static_cast<unsigned>(cfg[5]))
          .field("units", cfg[6] <= 2 ? to_string(static_cast<Unit>(cfg[6])) : "invalid");
      if (is_known_measuring_mode(cfg[5])) mode_ = static_cast<MeasuringMode>(cfg[5]);
    }
  }

  void command_fields(JsonLine& j, std::uint8_t code, std::span<const std::uint8_t> d) {
    switch (static_cast<Command>(code)) {
      case Command::change_mode:
        if (!d.empty()) {
          j.field("mode", static_cast<unsigned>(d[0])).field("mode_name", mode_name(d[0]));
          if (baud_of_mode(static_cast<OperatingMode>(d[0])) != 0)
            j.field("new_baud", baud_of_mode(static_cast<OperatingMode>(d[0])));
          if (d[0] == 0x00 && d.size() == 9) j.field("password", ascii(d.subspan(1)));
        }
        break;
      case Command::variant:
        if (d.size() == 4)
          j.field("fov_deg", static_cast<unsigned>(d[0] | (d[1] << 8)))
              .field("resolution_cdeg", static_cast<unsigned>(d[2] | (d[3] << 8)));
        break;
      case Command::write_config: config_fields(j, d); break;
      case Command::store_permanent:
      case Command::poll_values:
        if (!d.empty()) j.field("argument", static_cast<unsigned>(d[0]));
        break;
      default:
        if (!d.empty()) j.hex("data", d);
        break;
    }
  }

  void reply_fields(JsonLine& j, const TelegramView& t, std::span<const std::uint8_t> d) {
    switch (static_cast<Reply>(t.code())) {
      case Reply::measured_values: {
        if (!decode_scan(t.bytes, mode_, scan_).ok()) {
          ++decode_errors_;
          j.field("decode_error", true).hex("data", d);
          return;
        }
        const std::size_t n = scan_.count;
        j.field("count", static_cast<unsigned>(scan_.count))
            .field("unit", to_string(scan_.unit))
            .field("measuring_mode", static_cast<unsigned>(scan_.mode))
            .field("partial", scan_.partial)
            .field("partial_index", static_cast<unsigned>(scan_.partial_index));
        if (scan_.realtime_index) j.field("realtime_index", static_cast<unsigned>(*scan_.realtime_index));
        j.array("ranges_mm", std::span<const std::uint32_t>{scan_.ranges_mm.data(), n})
            .array("flags", std::span<const std::uint8_t>{scan_.flags.data(), n});
        std::array<const char*, kMaxBeams> reasons{};
        for (std::size_t i = 0; i < n; ++i) reasons[i] = to_string(scan_.invalid[i]);
        j.array("invalid", std::span<const char* const>{reasons.data(), n})
            .field("valid", static_cast<unsigned>(scan_.valid_count()));
        return;
      }
      case Reply::change_mode:
        if (!d.empty())
          j.field("result", d[0] == 0 ? "done" : d[0] == 1 ? "bad_password" : d[0] == 2 ? "lms_fault" : "unknown");
        return;
      case Reply::variant:
        if (d.size() == 5)
          j.field("accepted", d[0] == 1)
              .field("fov_deg", static_cast<unsigned>(d[1] | (d[2] << 8)))
              .field("resolution_cdeg", static_cast<unsigned>(d[3] | (d[4] << 8)));
        return;
      case Reply::status:
        if (const auto s = parse_status_data(d)) {
          j.field("software_version", s->software_version)
              .field("operating_mode", static_cast<unsigned>(s->operating_mode))
              .field("operating_mode_name", mode_name(s->operating_mode))
              .field("fov_deg", static_cast<unsigned>(s->variant.fov_deg))
              .field("resolution_cdeg", static_cast<unsigned>(s->variant.resolution_cdeg))
              .field("baud_rate", s->baud)
              .field("measuring_mode", static_cast<unsigned>(s->measuring_mode))
              .field("units", static_cast<unsigned>(s->units));
        }
        return;
      case Reply::read_config: config_fields(j, d); return;
      case Reply::write_config:
        if (!d.empty()) {
          j.field("accepted", d[0] == 1);
          if (d[0] == 1) config_fields(j, d.subspan(1));
        }
        return;
      case Reply::power_on:
      case Reply::lms_type: j.field("text", ascii(d)); return;
      case Reply::store_permanent:
        if (!d.empty()) j.field("accepted", d[0] == 1);
        return;
      default:
        if (!d.empty()) j.hex("data", d);
        return;
    }
  }

  std::FILE* out_;
  Side rx_{StreamDirection::from_device};
  Side tx_{StreamDirection::to_device};
  MeasuringMode mode_ = MeasuringMode::m8_fields_dazzle;
  ScanTelegram scan_{};
  std::uint64_t decode_errors_ = 0;
  std::int64_t last_time_us_ = 0;
};

}  // namespace

int decode_lms200(const DecodeInput& in, std::FILE* out) {
  Lms200Decoder d{out};
  for (const auto& c : in.chunks) d.chunk(c);
  d.finish();
  return 0;
}

}  // namespace teamscan::tool
