// PioneerEmulator: the firmware side of ARCOS (PROTOCOLS.md §1.4-§1.9, AMRISim's behaviour); see emulator.hpp.
#include "drivers/arcos/emulator.hpp"

#include <algorithm>
#include <cmath>

namespace teamscan::arcos {

namespace {
std::uint16_t wrap16(double counts) {
  // Two's-complement wrap of the counter, as AMRISim's int16 accumulator (§1.10).
  return static_cast<std::uint16_t>(static_cast<std::uint64_t>(std::llround(counts)) & 0xFFFFU);
}
std::int16_t clamp16(double v) {
  return static_cast<std::int16_t>(std::clamp(std::lround(v), -32768L, 32767L));
}
}  // namespace

void fill_sip_motion(SipPacket& sip, const RobotParams& params, double x_mm, double y_mm, double th_rad,
                     double left_mm_s, double right_mm_s) {
  sip.x_raw = wrap16(x_mm / params.dist_conv_mm);
  sip.y_raw = wrap16(y_mm / params.dist_conv_mm);
  sip.th_raw = clamp16(normalize_angle(th_rad) / params.angle_conv_rad);
  sip.left_vel = clamp16(left_mm_s / params.vel_conv_mm_s);
  sip.right_vel = clamp16(right_mm_s / params.vel_conv_mm_s);
  const bool moving = sip.left_vel != 0 || sip.right_vel != 0;
  sip.type = moving ? 0x33 : 0x32;
  if (sip.tail_fields > static_cast<std::uint8_t>(SipField::kRotVel)) {
    // ROTVEL in 0.1 deg/s from the wheel difference (§1.8, DiffConvFactor §1.11).
    const double w_rad_s = 0.5 * (right_mm_s - left_mm_s) * params.diff_conv_rad_per_mm;
    sip.rot_vel = clamp16(rad_to_deg(w_rad_s) * 10.0);
  }
}

PioneerEmulator::PioneerEmulator(const PioneerEmulatorOptions& options) : opt_{options}, baud_{options.baud} {
  auto p = params_for_subclass(opt_.subclass);
  params_ = p.ok() ? p.value() : fallback_params(opt_.subclass);
}

PioneerEmulatorStatistics PioneerEmulator::statistics() const {
  PioneerEmulatorStatistics s = stats_;
  s.parser = parser_.statistics();
  return s;
}

void PioneerEmulator::send(const PacketBuffer& p) {
  if (p.size == 0 || tx_size_ + p.size > tx_.size()) {
    ++stats_.tx_overflows;  // the I/O side is not reading; a real UART would drop too
    return;
  }
  for (std::size_t i = 0; i < p.size; ++i) tx_[(tx_head_ + tx_size_ + i) % tx_.size()] = p.bytes[i];
  tx_size_ += p.size;
}

std::size_t PioneerEmulator::take_tx(std::span<std::uint8_t> out) {
  const std::size_t n = std::min(out.size(), tx_size_);
  for (std::size_t i = 0; i < n; ++i) out[i] = tx_[(tx_head_ + i) % tx_.size()];
  tx_head_ = (tx_head_ + n) % tx_.size();
  tx_size_ -= n;
  if (tx_size_ == 0 && pending_baud_ != 0) {  // the bytes sent at the old rate are out
    baud_ = pending_baud_;
    pending_baud_ = 0;
  }
  return n;
}

void PioneerEmulator::set_pose(double x_mm, double y_mm, double th_rad) {
  x_mm_ = x_mm;
  y_mm_ = y_mm;
  th_rad_ = normalize_angle(th_rad);
}

void PioneerEmulator::power_cycle() {
  state_ = PioneerState::kWaitSync0;
  baud_ = opt_.baud;
  pending_baud_ = 0;
  stop_motion();
  motors_enabled_ = false;
  encoder_stream_ = false;
  x_mm_ = y_mm_ = th_rad_ = 0;
  left_enc_ = right_enc_ = 0;
  parser_.reset();
  tx_head_ = tx_size_ = 0;
}

void PioneerEmulator::stop_motion() {
  trans_mm_s_ = 0;
  rot_rad_s_ = 0;
}

void PioneerEmulator::client_went_silent(Time since) {
  if (client_silent_) return;
  client_silent_ = true;
  silent_since_ = since;
  ++stats_.client_silences;
  if (source_ != nullptr) source_->on_client_silent(since);
}

void PioneerEmulator::client_came_back(Time at) {
  if (!client_silent_) return;
  client_silent_ = false;
  if (source_ != nullptr) source_->on_client_back(at);
}

void PioneerEmulator::integrate(Time now) {
  if (!have_integrate_time_) {
    last_integrate_ = now;
    have_integrate_time_ = true;
    return;
  }
  const double dt_s = to_seconds(now - last_integrate_);
  last_integrate_ = now;
  if (dt_s <= 0) return;
  // Unicycle with the heading at mid-interval.
  const double th_mid = th_rad_ + 0.5 * rot_rad_s_ * dt_s;
  x_mm_ += trans_mm_s_ * std::cos(th_mid) * dt_s;
  y_mm_ += trans_mm_s_ * std::sin(th_mid) * dt_s;
  th_rad_ = normalize_angle(th_rad_ + rot_rad_s_ * dt_s);
  const double half_diff_mm_s = rot_rad_s_ / params_.diff_conv_rad_per_mm;
  left_enc_ += (trans_mm_s_ - half_diff_mm_s) * dt_s * opt_.ticks_per_mm;
  right_enc_ += (trans_mm_s_ + half_diff_mm_s) * dt_s * opt_.ticks_per_mm;
}

bool PioneerEmulator::make_sip(Time now, SipPacket& sip) {
  integrate(now);
  sip = SipPacket{};
  sip.tail_fields = static_cast<std::uint8_t>(SipField::kFaultFlags) + 1;  // as ARCOS/AMRISim (§1.8)
  sip.battery_dv = opt_.battery_dv;
  sip.battery_x10 = opt_.battery_dv;
  sip.charge_state = 0;
  sip.flags = motors_enabled_ ? 0x0001 : 0x0000;
  sip.control = 0;
  const double half_diff_mm_s = rot_rad_s_ / params_.diff_conv_rad_per_mm;
  fill_sip_motion(sip, params_, x_mm_, y_mm_, th_rad_, trans_mm_s_ - half_diff_mm_s, trans_mm_s_ + half_diff_mm_s);
  return source_ == nullptr || source_->fill_sip(now, sip);
}

Time PioneerEmulator::next_deadline() const {
  const Time flush = parser_.buffered() > 0 ? last_rx_ + opt_.inter_byte_timeout : Time::from_ns(INT64_MAX);
  if (state_ != PioneerState::kServerOpen) return flush;
  // The watchdog is due while the client is not silent yet: the robot stops at that very instant.
  return std::min(flush, client_silent_ ? next_sip_ : std::min(next_sip_, last_cmd_ + opt_.watchdog));
}

void PioneerEmulator::on_tick(Time now) {
  if (parser_.buffered() > 0 && now - last_rx_ >= opt_.inter_byte_timeout) {
    parser_.finish();
    drain_parser(now);
  }
  if (state_ != PioneerState::kServerOpen) return;
  if (!client_silent_ && now - last_cmd_ >= opt_.watchdog) {
    // §1.6: the firmware stops the robot when no client command arrived within the watchdog time: the
    // motion up to that instant counts, none after it (a late tick does not move the robot further).
    const Time stop_at = last_cmd_ + opt_.watchdog;
    if (!have_integrate_time_ || stop_at > last_integrate_) integrate(stop_at);
    if (trans_mm_s_ != 0 || rot_rad_s_ != 0) {
      ++stats_.watchdog_stops;
      stop_motion();
    }
    client_went_silent(stop_at);
  }
  integrate(now);
  if (now >= next_sip_) {
    SipPacket sip;
    if (make_sip(now, sip)) {
      send(encode_sip(sip));
      ++stats_.sips_sent;
    }
    if (encoder_stream_) {
      send(encode_encoder({static_cast<std::int32_t>(std::llround(left_enc_)),
                           static_cast<std::int32_t>(std::llround(right_enc_))}));
      ++stats_.encoder_packets_sent;
    }
    // Keep the cycle's phase; after a long gap (no ticks) resume from now rather than bursting.
    next_sip_ += opt_.sip_period;
    if (next_sip_ <= now) next_sip_ = now + opt_.sip_period;
  }
}

void PioneerEmulator::on_rx(std::span<const std::uint8_t> bytes, Time now) {
  if (!bytes.empty()) last_rx_ = now;
  while (!bytes.empty()) {
    const std::size_t n = parser_.feed(bytes);
    bytes = bytes.subspan(n);
    drain_parser(now);
  }
}

void PioneerEmulator::drain_parser(Time now) {
  for (auto e = parser_.poll(); e.kind != ArcosParser::EventKind::kNeedMore; e = parser_.poll()) {
    if (e.kind == ArcosParser::EventKind::kPacket) on_packet(e.packet, now);
  }
}

void PioneerEmulator::on_packet(const PacketView& p, Time now) {
  if (state_ == PioneerState::kServerOpen) {
    server_command(p, now);
    return;
  }
  // Handshake (§1.4). An out-of-sequence SYNC restarts it at SYNC0 (AMRISim's comment on the
  // specified firmware behaviour); a SYNC0 at any point is answered as a fresh start.
  switch (p.type) {
    case 0:
      if (state_ != PioneerState::kWaitSync0) ++stats_.handshake_restarts;
      send(make_command(Command::kSync0));
      state_ = PioneerState::kWaitSync1;
      return;
    case 1:
      if (state_ == PioneerState::kWaitSync1) {
        send(make_command(Command::kSync1));
        state_ = PioneerState::kWaitSync2;
      } else if (state_ == PioneerState::kReady) {
        // OPEN: start the server, SIPs from now on every SipCycle.
        state_ = PioneerState::kServerOpen;
        ++stats_.opens;
        motors_enabled_ = opt_.motors_enabled_at_open;
        stop_motion();
        last_cmd_ = now;
        client_came_back(now);
        next_sip_ = now;
        have_integrate_time_ = false;
        integrate(now);
      } else {
        ++stats_.handshake_restarts;
        state_ = PioneerState::kWaitSync0;
      }
      return;
    case 2:
      if (state_ == PioneerState::kWaitSync2) {
        Sync2Reply r;
        r.name.assign(opt_.name);
        r.robot_class.assign(opt_.robot_class);
        r.subclass.assign(opt_.subclass);
        send(encode_sync2_reply(r));
        ++stats_.handshakes;
        state_ = PioneerState::kReady;
      } else {
        // CLOSE outside the server, or SYNC2 out of sequence.
        if (state_ != PioneerState::kWaitSync0) ++stats_.handshake_restarts;
        state_ = PioneerState::kWaitSync0;
      }
      return;
    default:
      ++stats_.ignored_commands;  // no server: commands are not obeyed
      return;
  }
}

void PioneerEmulator::server_command(const PacketView& p, Time now) {
  auto cmd = decode_command(p);
  if (!cmd.ok()) {
    ++stats_.bad_commands;
    return;
  }
  integrate(now);  // motion so far at the old velocity
  ++stats_.commands;
  last_cmd_ = now;  // any command feeds the watchdog, PULSE included (§1.6)
  const CommandPacket& c = cmd.value();
  if (static_cast<Command>(c.command) != Command::kClose) client_came_back(now);
  const double max_v = params_.max_velocity_mm_s;
  const double max_w = deg_to_rad(params_.max_rot_velocity_deg_s);
  switch (static_cast<Command>(c.command)) {
    case Command::kPulse:
    case Command::kOpen: return;
    case Command::kClose:
      // The server stops and the host port returns to its power-up rate: this is why ARIA sends
      // CLOSE at every rate when the robot is silent (§1.4).
      ++stats_.closes;
      stop_motion();
      client_went_silent(now);  // the motors stop with the server: the robot stands until a new OPEN
      encoder_stream_ = false;
      state_ = PioneerState::kWaitSync0;
      baud_ = opt_.baud;
      pending_baud_ = 0;
      return;
    case Command::kHostBaud: {
      // §1.1: 0..4 = 9600/19200/38400/57600/115200; the new rate holds until CLOSE or power-up.
      static constexpr std::uint32_t kRates[] = {9600, 19200, 38400, 57600, 115200};
      if (c.value < 0 || c.value > 4) {
        ++stats_.bad_commands;
        return;
      }
      pending_baud_ = kRates[c.value];
      if (tx_size_ == 0) {
        baud_ = pending_baud_;
        pending_baud_ = 0;
      }
      ++stats_.baud_changes;
      return;
    }
    case Command::kEnable:
      motors_enabled_ = c.value != 0;
      if (!motors_enabled_) stop_motion();
      return;
    case Command::kSetO:
      x_mm_ = y_mm_ = th_rad_ = 0;
      return;
    case Command::kStop:
    case Command::kEStop: stop_motion(); return;
    case Command::kVel:
      if (motors_enabled_) trans_mm_s_ = std::clamp(static_cast<double>(c.value), -max_v, max_v);
      return;
    case Command::kRVel:
    case Command::kRotate:  // same as RVEL in ARCOS (§1.5)
      if (motors_enabled_) rot_rad_s_ = std::clamp(deg_to_rad(static_cast<double>(c.value)), -max_w, max_w);
      return;
    case Command::kVel2: {
      if (!motors_enabled_) return;
      double l = 0, r = 0;
      vel2_split(c.value, params_.vel2_divisor_mm_s, l, r);
      trans_mm_s_ = std::clamp(0.5 * (l + r), -max_v, max_v);
      rot_rad_s_ = std::clamp(0.5 * (r - l) * params_.diff_conv_rad_per_mm, -max_w, max_w);
      return;
    }
    case Command::kConfig: {
      ConfigPacket cfg;
      cfg.robot_class.assign(opt_.robot_class);
      cfg.subclass.assign(opt_.subclass);
      cfg.serial_number.assign("EMU-0001");
      cfg.name.assign(opt_.name);
      cfg.firmware_version.assign("teamscan-emulator");
      cfg.sip_cycle_ms = static_cast<std::uint8_t>(std::clamp<std::int64_t>(opt_.sip_period / 1ms, 0, 255));
      cfg.watchdog_ms = static_cast<std::uint16_t>(std::clamp<std::int64_t>(opt_.watchdog / 1ms, 0, 65535));
      cfg.trans_vel_max = static_cast<std::uint16_t>(max_v);
      cfg.rot_vel_max = static_cast<std::uint16_t>(params_.max_rot_velocity_deg_s);
      cfg.ticks_mm = static_cast<std::uint16_t>(std::lround(opt_.ticks_per_mm));
      cfg.low_battery = 110;
      cfg.shutdown_voltage = 105;
      send(encode_config(cfg, kConfigRequiredFields));
      ++stats_.configs_sent;
      return;
    }
    case Command::kEncoder: encoder_stream_ = c.value > 0; return;
    default: ++stats_.ignored_commands; return;
  }
}

}  // namespace teamscan::arcos
