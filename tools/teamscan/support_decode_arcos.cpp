// `teamscan decode --device arcos`: ARCOS packets of both directions as JSON lines (decode.hpp
// contract). Commands (tx) with their arguments, robot packets (rx) with decoded fields: SYNC echoes,
// the SYNC2 identity, SIPs (converted with the subclass seen in the SYNC2 reply, else p3at-sh),
// CONFIGpac, ENCODERpac. Bad input: {"error":"bad_crc"|"bad_length"|"garbage",...}; then a summary.
#include <array>
#include <memory>
#include <cstdio>
#include <string>
#include <vector>

#include "drivers/arcos/codec.hpp"
#include "drivers/arcos/odometry.hpp"
#include "drivers/arcos/parser.hpp"
#include "tools/teamscan/decode.hpp"

namespace teamscan::tool {
namespace {

using namespace teamscan::arcos;

const char* command_name(std::uint8_t c) {
  switch (c) {
    case 0: return "SYNC0/PULSE";
    case 1: return "SYNC1/OPEN";
    case 2: return "SYNC2/CLOSE";
    case 3: return "POLLING";
    case 4: return "ENABLE";
    case 5: return "SETA";
    case 6: return "SETV";
    case 7: return "SETO";
    case 8: return "MOVE";
    case 9: return "ROTATE";
    case 10: return "SETRV";
    case 11: return "VEL";
    case 12: return "HEAD";
    case 13: return "DHEAD";
    case 15: return "SAY";
    case 17: return "JOYINFO";
    case 18: return "CONFIG";
    case 19: return "ENCODER";
    case 21: return "RVEL";
    case 23: return "SETRA";
    case 28: return "SONAR";
    case 29: return "STOP";
    case 30: return "DIGOUT";
    case 32: return "VEL2";
    case 33: return "GRIPPER";
    case 40: return "IOREQUEST";
    case 44: return "BUMPSTALL";
    case 47: return "JOYDRIVE";
    case 48: return "SONARCYCLE";
    case 50: return "HOSTBAUD";
    case 55: return "ESTOP";
    case 58: return "GYRO";
    case 62: return "BATTERYINFO";
    case 88: return "REVCOUNT";
    case 89: return "DRIFTFACTOR";
    case 93: return "TICKSMM";
    default: return "unknown";
  }
}

struct Direction {
  explicit Direction(const char* n) : name{n} {}
  const char* name;
  ArcosParser parser;
  // A run of garbage is reported once, when it ends.
  bool in_garbage = false;
  std::uint64_t garbage_offset = 0;
  std::int64_t garbage_t_us = 0;
  std::vector<std::uint8_t> garbage;  // first bytes of the run (up to 64), for the report
  std::uint64_t garbage_bytes = 0;
};

struct Decoder {
  std::FILE* out;
  Direction rx{"rx"}, tx{"tx"};
  RobotParams params = fallback_params("p3at-sh");
  std::string subclass = "";

  void flush_garbage(Direction& d) {
    if (!d.in_garbage) return;
    JsonLine j{out};
    j.field("error", "garbage").field("dir", d.name).field("t_us", d.garbage_t_us)
        .field("offset", static_cast<unsigned long long>(d.garbage_offset))
        .field("bytes", static_cast<unsigned long long>(d.garbage_bytes))
        .hex("hex", d.garbage);
    j.end();
    d.in_garbage = false;
    d.garbage.clear();
    d.garbage_bytes = 0;
  }

  void command(JsonLine& j, const PacketView& p) {
    j.field("cmd", static_cast<int>(p.type)).field("name", command_name(p.type));
    auto c = decode_command(p);
    if (!c.ok()) {
      j.field("arg_error", c.error().what).hex("data", p.data);
      return;
    }
    switch (c->arg) {
      case CommandPacket::Arg::kNone: break;
      case CommandPacket::Arg::kTypeOnly: j.field("arg_type_only", static_cast<int>(c->arg_type)); break;
      case CommandPacket::Arg::kInt:
        j.field("arg", static_cast<std::int64_t>(c->value));
        if (p.type == static_cast<std::uint8_t>(Command::kVel2)) {
          double l = 0, r = 0;
          vel2_split(c->value, params.vel2_divisor_mm_s, l, r);
          j.field("left_mm_s", l).field("right_mm_s", r);
        }
        break;
      case CommandPacket::Arg::kString: j.hex("arg_string", c->string); break;
    }
  }

  void sip(JsonLine& j, const PacketView& p) {
    auto r = decode_sip(p);
    if (!r.ok()) {
      j.field("decode_error", r.error().what).hex("data", p.data);
      return;
    }
    const SipPacket& s = r.value();
    j.field("x_raw", static_cast<unsigned>(s.x_raw & 0x7FFFU)).field("y_raw", static_cast<unsigned>(s.y_raw & 0x7FFFU))
        .field("th_raw", static_cast<int>(s.th_raw))
        .field("x", static_cast<double>(s.x_raw & 0x7FFFU) * params.dist_conv_mm)
        .field("y", static_cast<double>(s.y_raw & 0x7FFFU) * params.dist_conv_mm)
        .field("th", rad_to_deg(static_cast<double>(s.th_raw) * params.angle_conv_rad))
        .field("dist_conv_mm", params.dist_conv_mm)
        .field("left_vel_mm_s", static_cast<double>(s.left_vel) * params.vel_conv_mm_s)
        .field("right_vel_mm_s", static_cast<double>(s.right_vel) * params.vel_conv_mm_s)
        .field("battery_v", static_cast<double>(s.battery_dv) / 10.0)
        .field("left_stall", s.left_stall()).field("right_stall", s.right_stall())
        .field("front_bumpers", static_cast<int>(s.front_bumpers())).field("rear_bumpers", static_cast<int>(s.rear_bumpers()))
        .field("control", static_cast<int>(s.control)).field("flags", static_cast<unsigned>(s.flags))
        .field("motors_enabled", s.motors_enabled()).field("estop", s.estop())
        .field("compass_deg", static_cast<int>(s.compass) * 2);
    std::vector<unsigned> numbers, ranges;
    for (std::size_t i = 0; i < s.sonar_count; ++i) {
      numbers.push_back(s.sonar[i].number);
      ranges.push_back(s.sonar[i].range);
    }
    j.array("sonar_numbers", numbers).array("sonar_ranges_mm", ranges);
    j.field("tail_fields", static_cast<int>(s.tail_fields));
    if (s.has(SipField::kGripState)) j.field("grip_state", static_cast<int>(s.grip_state));
    if (s.has(SipField::kAnPort)) j.field("anport", static_cast<int>(s.an_port));
    if (s.has(SipField::kAnalog)) j.field("analog", static_cast<int>(s.analog));
    if (s.has(SipField::kDigIn)) j.field("digin", static_cast<int>(s.dig_in));
    if (s.has(SipField::kDigOut)) j.field("digout", static_cast<int>(s.dig_out));
    if (s.has(SipField::kBatteryX10)) j.field("battery_x10_v", static_cast<double>(s.battery_x10) / 10.0);
    if (s.has(SipField::kChargeState)) j.field("charge_state", static_cast<int>(s.charge_state));
    if (s.has(SipField::kRotVel)) j.field("rot_vel_deg_s", static_cast<double>(s.rot_vel) / 10.0);
    if (s.has(SipField::kFaultFlags)) j.field("fault_flags", static_cast<unsigned>(s.fault_flags));
    if (s.has(SipField::kLatVel)) j.field("lat_vel_mm_s", static_cast<int>(s.lat_vel));
    if (s.has(SipField::kTemperature)) j.field("temperature_c", static_cast<int>(s.temperature_c));
    if (s.has(SipField::kStateOfCharge)) j.field("state_of_charge", static_cast<int>(s.state_of_charge));
    if (s.has(SipField::kMicroTime)) j.field("uc_time_us", static_cast<unsigned long long>(s.micro_time_us));
    if (s.has(SipField::kFlags3)) j.field("flags3", static_cast<unsigned long long>(s.flags3));
    if (s.trailing_bytes > 0) j.field("trailing_bytes", static_cast<int>(s.trailing_bytes));
  }

  void robot_packet(JsonLine& j, const PacketView& p) {
    j.field("type", static_cast<int>(p.type));
    if (is_sip_type(p.type)) {
      j.field("name", "SIP");
      sip(j, p);
      return;
    }
    switch (static_cast<PacketType>(p.type)) {
      case PacketType::kSync0:
      case PacketType::kSync1: j.field("name", p.type == 0 ? "SYNC0" : "SYNC1"); return;
      case PacketType::kSync2: {
        j.field("name", "SYNC2");
        if (p.data.empty()) return;
        auto r = decode_sync2_reply(p);
        if (!r.ok()) return;
        j.field("robot_name", r->name.view()).field("robot_class", r->robot_class.view())
            .field("subclass", r->subclass.view());
        subclass = std::string{r->subclass.view()};
        auto known = params_for_subclass(subclass);
        params = known.ok() ? known.value() : fallback_params(subclass);
        params.subclass = subclass;  // the view must point at our copy
        if (!known.ok()) j.field("warning", "unknown subclass: p3at-sh conversion factors used");
        return;
      }
      case PacketType::kConfig: {
        j.field("name", "CONFIGpac");
        auto c = decode_config(p);
        if (!c.ok()) return;
        j.field("robot_class", c->robot_class.view()).field("subclass", c->subclass.view())
            .field("serial", c->serial_number.view()).field("robot_name", c->name.view())
            .field("sip_cycle_ms", static_cast<int>(c->sip_cycle_ms)).field("host_baud", static_cast<int>(c->host_baud))
            .field("watchdog_ms", static_cast<int>(c->watchdog_ms)).field("trans_vel_max", static_cast<int>(c->trans_vel_max))
            .field("rot_vel_max", static_cast<int>(c->rot_vel_max)).field("autobaud", static_cast<int>(c->autobaud))
            .field("firmware", c->firmware_version.view())
            .field("fields_present", static_cast<int>(c->fields_present)).field("complete", c->complete());
        return;
      }
      case PacketType::kEncoder: {
        j.field("name", "ENCODERpac");
        auto e = decode_encoder(p);
        if (e.ok()) j.field("left", static_cast<std::int64_t>(e->left)).field("right", static_cast<std::int64_t>(e->right));
        else j.field("decode_error", e.error().what);
        return;
      }
      default:
        j.field("name", "other").hex("data", p.data);
        return;
    }
  }

  void drain(Direction& d, std::int64_t t_us) {
    for (auto e = d.parser.poll(); e.kind != ArcosParser::EventKind::kNeedMore; e = d.parser.poll()) {
      if (e.kind == ArcosParser::EventKind::kGarbage) {
        if (!d.in_garbage) {
          d.in_garbage = true;
          d.garbage_offset = e.stream_offset;
          d.garbage_t_us = t_us;
        }
        d.garbage_bytes += e.bytes.size();
        for (auto b : e.bytes) {
          if (d.garbage.size() < 64) d.garbage.push_back(b);
        }
        continue;
      }
      flush_garbage(d);
      JsonLine j{out};
      if (e.kind == ArcosParser::EventKind::kBadChecksum || e.kind == ArcosParser::EventKind::kBadLength) {
        // The header byte is dropped; the bytes after it are searched again (they appear as their own lines).
        j.field("error", e.kind == ArcosParser::EventKind::kBadChecksum ? "bad_crc" : "bad_length")
            .field("dir", d.name).field("t_us", t_us).field("offset", static_cast<unsigned long long>(e.stream_offset))
            .hex("hex", e.bytes);
        j.end();
        continue;
      }
      j.field("dir", d.name).field("t_us", t_us).field("offset", static_cast<unsigned long long>(e.stream_offset));
      if (&d == &tx) command(j, e.packet);
      else robot_packet(j, e.packet);
      j.end();
    }
  }

  void chunk(const DecodeChunk& c) {
    Direction& d = c.direction == CaptureDirection::rx ? rx : tx;
    std::span<const std::uint8_t> rest{c.bytes};
    while (!rest.empty()) {
      const std::size_t n = d.parser.feed(rest);
      rest = rest.subspan(n);
      drain(d, c.time_us);
    }
  }

  void finish(std::int64_t t_us) {
    ArcosParserStatistics total;
    for (Direction* dp : {&rx, &tx}) {
      Direction& d = *dp;
      d.parser.finish();
      drain(d, t_us);
      flush_garbage(d);
      const auto& s = d.parser.statistics();
      total.packets += s.packets;
      total.bad_checksum += s.bad_checksum;
      total.bad_length += s.bad_length;
      total.discarded_bytes += s.discarded_bytes;
      total.resyncs += s.resyncs;
    }
    JsonLine j{out};
    j.begin_object("summary")
        .field("packets", static_cast<unsigned long long>(total.packets))
        .field("bad_crc", static_cast<unsigned long long>(total.bad_checksum))
        .field("bad_length", static_cast<unsigned long long>(total.bad_length))
        .field("discarded_bytes", static_cast<unsigned long long>(total.discarded_bytes))
        .field("resyncs", static_cast<unsigned long long>(total.resyncs))
        .end_object();
    j.end();
  }
};

}  // namespace

int decode_arcos(const DecodeInput& in, std::FILE* out) {
  auto d = std::make_unique<Decoder>();
  d->out = out;
  std::int64_t last_t_us = 0;
  for (const auto& c : in.chunks) {
    d->chunk(c);
    last_t_us = c.time_us;
  }
  d->finish(last_t_us);
  return 0;
}

}  // namespace teamscan::tool
