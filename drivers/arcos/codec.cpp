// ARCOS packet codec (PROTOCOLS.md §1.2-§1.9); see codec.hpp.
#include "drivers/arcos/codec.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>

namespace teamscan::arcos {

std::uint16_t checksum(std::span<const std::uint8_t> body) {
  // §1.2: first byte of each pair is the high half; keep 16 bits; odd byte XORed into the low half.
  std::uint32_t c = 0;
  std::size_t i = 0;
  for (; i + 1 < body.size(); i += 2) {
    c = (c + ((static_cast<std::uint32_t>(body[i]) << 8) | body[i + 1])) & 0xFFFFU;
  }
  if (i < body.size()) c ^= body[i];
  return static_cast<std::uint16_t>(c);
}

Result<PacketView> verify_packet(std::span<const std::uint8_t> wire) {
  if (wire.size() < 2 || wire[0] != kHeader0 || wire[1] != kHeader1) return Error{"arcos: no FA FB header"};
  if (wire.size() < 3 + kMinCount) return Error{"arcos: packet too short"};
  const std::size_t count = wire[2];
  if (count < kMinCount || wire.size() != count + 3) return Error{"arcos: bad byte count"};
  const auto body = wire.subspan(3, count - 2);
  const auto sent = static_cast<std::uint16_t>((wire[count + 1] << 8) | wire[count + 2]);
  if (checksum(body) != sent) return Error{"arcos: bad checksum"};
  return PacketView{body[0], body.subspan(1), wire};
}

// ---- PacketWriter ----

PacketWriter::PacketWriter(std::uint8_t type) { u8(type); }

void PacketWriter::u8(std::uint8_t v) {
  if (body_size_ >= kMaxBody) {
    overflow_ = true;
    return;
  }
  buf_.bytes[3 + body_size_++] = v;
}
void PacketWriter::u16(std::uint16_t v) {
  u8(static_cast<std::uint8_t>(v & 0xFFU));
  u8(static_cast<std::uint8_t>(v >> 8));
}
void PacketWriter::u32(std::uint32_t v) {
  u16(static_cast<std::uint16_t>(v & 0xFFFFU));
  u16(static_cast<std::uint16_t>(v >> 16));
}
void PacketWriter::bytes(std::span<const std::uint8_t> b) {
  for (auto x : b) u8(x);
}
void PacketWriter::cstr(std::string_view s) {
  for (char ch : s) u8(static_cast<std::uint8_t>(ch));
  u8(0);
}

PacketBuffer PacketWriter::finish() const {
  PacketBuffer out = buf_;
  if (overflow_) {
    out.size = 0;
    return out;
  }
  out.bytes[0] = kHeader0;
  out.bytes[1] = kHeader1;
  out.bytes[2] = static_cast<std::uint8_t>(body_size_ + 2);
  const std::uint16_t c = checksum({out.bytes.data() + 3, body_size_});
  out.bytes[3 + body_size_] = static_cast<std::uint8_t>(c >> 8);  // checksum is big endian (§1.2)
  out.bytes[4 + body_size_] = static_cast<std::uint8_t>(c & 0xFFU);
  out.size = body_size_ + 5;
  return out;
}

// ---- commands ----

PacketBuffer make_command(Command c) { return PacketWriter{static_cast<std::uint8_t>(c)}.finish(); }

PacketBuffer make_command(Command c, std::int32_t value) {
  PacketWriter w{static_cast<std::uint8_t>(c)};
  const std::int32_t magnitude = std::min<std::int32_t>(value < 0 ? -std::max(value, -65535) : value, 65535);
  w.u8(value < 0 ? kArgNegative : kArgPositive);  // sign-magnitude, not two's complement (§1.3)
  w.u16(static_cast<std::uint16_t>(magnitude));
  return w.finish();
}

PacketBuffer make_command_string(Command c, std::span<const std::uint8_t> s) {
  PacketWriter w{static_cast<std::uint8_t>(c)};
  const std::size_t n = std::min<std::size_t>(s.size(), kMaxBody - 3);
  w.u8(kArgString);
  w.u8(static_cast<std::uint8_t>(n));
  w.bytes(s.first(n));
  return w.finish();
}

PacketBuffer make_command_type_only(Command c, std::uint8_t arg_type) {
  PacketWriter w{static_cast<std::uint8_t>(c)};
  w.u8(arg_type);
  return w.finish();
}

namespace {
std::int32_t wheel_units(double mm_s, int divisor) {
  const double u = std::round(mm_s / static_cast<double>(divisor));
  return static_cast<std::int32_t>(std::clamp(u, -128.0, 127.0));
}
}  // namespace

std::int32_t vel2_argument(double left_mm_s, double right_mm_s, int divisor_mm_s) {
  const auto l = static_cast<std::uint32_t>(wheel_units(left_mm_s, divisor_mm_s)) & 0xFFU;
  const auto r = static_cast<std::uint32_t>(wheel_units(right_mm_s, divisor_mm_s)) & 0xFFU;
  const std::uint32_t word = (l << 8) | r;
  // The word as a signed 16-bit int: negative (0x1B form) whenever the left byte is negative (§1.5).
  return static_cast<std::int32_t>(static_cast<std::int16_t>(static_cast<std::uint16_t>(word)));
}

PacketBuffer make_vel2(double left_mm_s, double right_mm_s, int divisor_mm_s) {
  return make_command(Command::kVel2, vel2_argument(left_mm_s, right_mm_s, divisor_mm_s));
}

void vel2_split(std::int32_t argument, int divisor_mm_s, double& left_mm_s, double& right_mm_s) {
  const auto word = static_cast<std::uint16_t>(argument);
  const auto l = static_cast<std::int8_t>(static_cast<std::uint8_t>(word >> 8));
  const auto r = static_cast<std::int8_t>(static_cast<std::uint8_t>(word & 0xFFU));
  left_mm_s = static_cast<double>(l) * divisor_mm_s;
  right_mm_s = static_cast<double>(r) * divisor_mm_s;
}

Result<CommandPacket> decode_command(const PacketView& p) {
  CommandPacket c;
  c.command = p.type;
  const auto d = p.data;
  if (d.empty()) return c;
  c.arg_type = d[0];
  switch (d[0]) {
    case kArgPositive:
    case kArgNegative: {
      if (d.size() == 1) {
        c.arg = CommandPacket::Arg::kTypeOnly;  // e.g. SETO `07 3B` (§1.3)
        return c;
      }
      if (d.size() < 3) return Error{"arcos: truncated int argument"};
      const std::int32_t m = d[1] | (d[2] << 8);
      c.arg = CommandPacket::Arg::kInt;
      c.value = d[0] == kArgNegative ? -m : m;
      return c;
    }
    case kArgString: {
      if (d.size() < 2 || d.size() < 2U + d[1]) return Error{"arcos: truncated string argument"};
      c.arg = CommandPacket::Arg::kString;
      c.string = d.subspan(2, d[1]);
      return c;
    }
    default:
      return Error{"arcos: unknown argument type"};
  }
}

// ---- identity strings ----

void IdString::assign(std::string_view s) {
  chars.fill('\0');
  const std::size_t n = std::min(s.size(), kMaxIdString - 1);
  std::memcpy(chars.data(), s.data(), n);
}
std::string_view IdString::view() const { return {chars.data(), ::strnlen(chars.data(), kMaxIdString)}; }

namespace {

// Reads little-endian fields from a packet's data; a field that does not fit sets `truncated` and
// is left unchanged; strings end at a NUL or at the end of the data.
class FieldReader {
 public:
  explicit FieldReader(std::span<const std::uint8_t> d) : d_{d} {}
  bool truncated = false;
  std::uint16_t complete = 0;
  [[nodiscard]] std::size_t remaining() const { return d_.size() - pos_; }

  void field(std::uint8_t& v) { if (take(1)) v = d_[pos_ - 1]; }
  void field(std::int8_t& v) { if (take(1)) v = static_cast<std::int8_t>(d_[pos_ - 1]); }
  void field(std::uint16_t& v) { if (take(2)) v = static_cast<std::uint16_t>(d_[pos_ - 2] | (d_[pos_ - 1] << 8)); }
  void field(std::int16_t& v) {
    std::uint16_t u = 0;
    if (take(2)) { u = static_cast<std::uint16_t>(d_[pos_ - 2] | (d_[pos_ - 1] << 8)); v = static_cast<std::int16_t>(u); }
  }
  void field(std::uint32_t& v) {
    if (take(4)) {
      v = static_cast<std::uint32_t>(d_[pos_ - 4]) | (static_cast<std::uint32_t>(d_[pos_ - 3]) << 8) |
          (static_cast<std::uint32_t>(d_[pos_ - 2]) << 16) | (static_cast<std::uint32_t>(d_[pos_ - 1]) << 24);
    }
  }
  void field(std::int32_t& v) {
    std::uint32_t u = 0;
    field(u);
    if (!truncated) v = static_cast<std::int32_t>(u);
  }
  // A NUL-terminated string; complete only with its NUL (overlong strings are cut to the capacity).
  void field(IdString& s) {
    if (truncated) return;
    s.chars.fill('\0');
    std::size_t n = 0;
    while (pos_ < d_.size() && d_[pos_] != 0) {
      if (n + 1 < kMaxIdString) s.chars[n++] = static_cast<char>(d_[pos_]);
      ++pos_;
    }
    if (pos_ >= d_.size()) {
      truncated = true;
      return;
    }
    ++pos_;  // the NUL
    ++complete;
  }

 private:
  bool take(std::size_t n) {
    if (truncated || remaining() < n) {
      truncated = true;
      return false;
    }
    pos_ += n;
    ++complete;
    return true;
  }
  std::span<const std::uint8_t> d_;
  std::size_t pos_ = 0;
};

// Writes the same fields in the same order, up to `limit` fields.
class FieldWriter {
 public:
  FieldWriter(PacketWriter& w, std::uint16_t limit) : w_{w}, limit_{limit} {}
  void field(std::uint8_t v) { if (next()) w_.u8(v); }
  void field(std::int8_t v) { if (next()) w_.u8(static_cast<std::uint8_t>(v)); }
  void field(std::uint16_t v) { if (next()) w_.u16(v); }
  void field(std::int16_t v) { if (next()) w_.s16(v); }
  void field(std::uint32_t v) { if (next()) w_.u32(v); }
  void field(std::int32_t v) { if (next()) w_.s32(v); }
  void field(const IdString& s) { if (next()) w_.cstr(s.view()); }

 private:
  bool next() { return written_++ < limit_; }
  PacketWriter& w_;
  std::uint16_t limit_;
  std::uint16_t written_ = 0;
};

// §1.9 field order, shared by reader and writer.
template <class IO, class C>
void visit_config(IO& io, C& c) {
  io.field(c.robot_class); io.field(c.subclass); io.field(c.serial_number); io.field(c.four_mots);
  io.field(c.rot_vel_top); io.field(c.trans_vel_top); io.field(c.rot_acc_top); io.field(c.trans_acc_top);
  io.field(c.pwm_max); io.field(c.name); io.field(c.sip_cycle_ms); io.field(c.host_baud);
  io.field(c.aux1_baud); io.field(c.has_gripper); io.field(c.front_sonar); io.field(c.rear_sonar);
  io.field(c.low_battery); io.field(c.rev_count); io.field(c.watchdog_ms); io.field(c.normal_mpacs);
  io.field(c.stall_val); io.field(c.stall_count); io.field(c.joy_vel); io.field(c.joy_rot_vel);
  io.field(c.rot_vel_max); io.field(c.trans_vel_max); io.field(c.rot_accel); io.field(c.rot_decel);
  io.field(c.rot_kp); io.field(c.rot_kv); io.field(c.rot_ki); io.field(c.trans_accel);
  io.field(c.trans_decel); io.field(c.trans_kp); io.field(c.trans_kv); io.field(c.trans_ki);
  io.field(c.front_bumps); io.field(c.rear_bumps); io.field(c.has_charger); io.field(c.sonar_cycle);
  io.field(c.autobaud); io.field(c.gyro_type); io.field(c.drift_factor); io.field(c.aux2_baud);
  io.field(c.aux3_baud); io.field(c.ticks_mm); io.field(c.shutdown_voltage); io.field(c.firmware_version);
  io.field(c.gyro_cw); io.field(c.gyro_ccw); io.field(c.kinematics_delay); io.field(c.lat_vel_top);
  io.field(c.lat_acc_top); io.field(c.lat_vel_max); io.field(c.lat_accel); io.field(c.lat_decel);
  io.field(c.powerbot_charge_threshold); io.field(c.pdb_port); io.field(c.gyro_rate_limit);
  // 59 fields above; the optional tail (§1.9):
  io.field(c.high_temp_shutdown); io.field(c.power_bits); io.field(c.battery_type); io.field(c.soc_low);
  io.field(c.soc_shutdown); io.field(c.bootloader_version); io.field(c.config_flags);
  io.field(c.gyro_fw_version);
}

// §1.8 tail, in wire order.
template <class IO, class S>
void visit_sip_tail(IO& io, S& s) {
  io.field(s.grip_state); io.field(s.an_port); io.field(s.analog); io.field(s.dig_in); io.field(s.dig_out);
  io.field(s.battery_x10); io.field(s.charge_state); io.field(s.rot_vel); io.field(s.fault_flags);
  io.field(s.lat_vel); io.field(s.temperature_c); io.field(s.state_of_charge); io.field(s.micro_time_us);
  io.field(s.flags3);
}

}  // namespace

// ---- SYNC2 reply ----

PacketBuffer encode_sync2_reply(const Sync2Reply& r) {
  PacketWriter w{static_cast<std::uint8_t>(PacketType::kSync2)};
  w.cstr(r.name.view());
  w.cstr(r.robot_class.view());
  w.cstr(r.subclass.view());
  return w.finish();
}

Result<Sync2Reply> decode_sync2_reply(const PacketView& p) {
  if (p.type != static_cast<std::uint8_t>(PacketType::kSync2)) return Error{"arcos: not a SYNC2 reply"};
  Sync2Reply r;
  // Tolerant: a string cut by the end of the data is kept as far as it goes.
  IdString* fields[3] = {&r.name, &r.robot_class, &r.subclass};
  std::size_t pos = 0;
  for (IdString* f : fields) {
    std::size_t n = 0;
    while (pos < p.data.size() && p.data[pos] != 0) {
      if (n + 1 < kMaxIdString) f->chars[n++] = static_cast<char>(p.data[pos]);
      ++pos;
    }
    ++pos;  // NUL (or past the end)
  }
  return r;
}

// ---- SIP ----

PacketBuffer encode_sip(const SipPacket& s) {
  PacketWriter w{s.type};
  w.u16(s.x_raw);
  w.u16(s.y_raw);
  w.s16(s.th_raw);
  w.s16(s.left_vel);
  w.s16(s.right_vel);
  w.u8(s.battery_dv);
  w.u16(s.stall_bumpers);
  w.s16(s.control);
  w.u16(s.flags);
  w.u8(s.compass);
  const std::size_t n = std::min<std::size_t>(s.sonar_count, kMaxSonarReadings);
  w.u8(static_cast<std::uint8_t>(n));
  for (std::size_t i = 0; i < n; ++i) {
    w.u8(s.sonar[i].number);
    w.u16(s.sonar[i].range);
  }
  FieldWriter fw{w, s.tail_fields};
  visit_sip_tail(fw, s);
  return w.finish();
}

Result<SipPacket> decode_sip(const PacketView& p) {
  if (!is_sip_type(p.type)) return Error{"arcos: not a SIP"};
  SipPacket s;
  s.type = p.type;
  FieldReader r{p.data};
  r.field(s.x_raw);
  r.field(s.y_raw);
  r.field(s.th_raw);
  r.field(s.left_vel);
  r.field(s.right_vel);
  r.field(s.battery_dv);
  r.field(s.stall_bumpers);
  r.field(s.control);
  r.field(s.flags);
  r.field(s.compass);
  r.field(s.sonar_count);
  if (r.truncated) return Error{"arcos: SIP shorter than its fixed part"};
  if (r.remaining() < 3U * s.sonar_count) return Error{"arcos: SIP sonar readings truncated"};
  for (std::size_t i = 0; i < s.sonar_count; ++i) {  // sonar_count <= kMaxSonarReadings by packet size
    r.field(s.sonar[i].number);
    r.field(s.sonar[i].range);
  }
  const std::uint16_t before = r.complete;
  visit_sip_tail(r, s);
  s.tail_fields = static_cast<std::uint8_t>(r.complete - before);
  s.trailing_bytes = static_cast<std::uint16_t>(r.remaining());
  return s;
}

// ---- CONFIGpac ----

bool ConfigPacket::complete() const { return fields_present >= kConfigRequiredFields; }

PacketBuffer encode_config(const ConfigPacket& c, std::uint16_t fields) {
  PacketWriter w{static_cast<std::uint8_t>(PacketType::kConfig)};
  FieldWriter fw{w, fields};
  visit_config(fw, c);
  return w.finish();
}

Result<ConfigPacket> decode_config(const PacketView& p) {
  if (p.type != static_cast<std::uint8_t>(PacketType::kConfig)) return Error{"arcos: not a CONFIGpac"};
  ConfigPacket c;
  FieldReader r{p.data};
  visit_config(r, c);
  c.fields_present = r.complete;
  return c;
}

// ---- ENCODERpac ----

PacketBuffer encode_encoder(const EncoderPacket& e) {
  PacketWriter w{static_cast<std::uint8_t>(PacketType::kEncoder)};
  w.s32(e.left);
  w.s32(e.right);
  return w.finish();
}

Result<EncoderPacket> decode_encoder(const PacketView& p) {
  if (p.type != static_cast<std::uint8_t>(PacketType::kEncoder)) return Error{"arcos: not an ENCODERpac"};
  if (p.data.size() < 8) return Error{"arcos: ENCODERpac truncated"};
  EncoderPacket e;
  FieldReader r{p.data};
  r.field(e.left);
  r.field(e.right);
  return e;
}

}  // namespace teamscan::arcos
