// ArcosClient state machine (PROTOCOLS.md §1.4 handshake and recovery, §1.6 keep-alive); see client.hpp.
#include "drivers/arcos/client.hpp"

#include <algorithm>
#include <cmath>

namespace teamscan::arcos {

const char* to_string(ArcosClientState s) {
  switch (s) {
    case ArcosClientState::kIdle: return "idle";
    case ArcosClientState::kSyncing: return "syncing";
    case ArcosClientState::kClosingStale: return "closing-stale";
    case ArcosClientState::kBaudCycle: return "baud-cycle";
    case ArcosClientState::kPaused: return "paused";
    case ArcosClientState::kOpening: return "opening";
    case ArcosClientState::kConnected: return "connected";
    case ArcosClientState::kDeviceLost: return "device-lost";
    case ArcosClientState::kShutdown: return "shutdown";
  }
  return "?";
}

ArcosClient::ArcosClient(const ArcosClientOptions& options) : opt_{options}, baud_{options.baud} {}

ArcosClientStatistics ArcosClient::statistics() const {
  ArcosClientStatistics s = stats_;
  s.parser = parser_.statistics();
  return s;
}

// ---- tx queue ----

bool ArcosClient::queue(const PacketBuffer& p, Time now) {
  if (p.size == 0 || tx_size_ + p.size > tx_.size()) {
    ++stats_.tx_overflows;
    return false;
  }
  for (std::size_t i = 0; i < p.size; ++i) tx_[(tx_head_ + tx_size_ + i) % tx_.size()] = p.bytes[i];
  tx_size_ += p.size;
  last_tx_ = now;
  ++stats_.commands_sent;
  return true;
}

std::size_t ArcosClient::take_tx(std::span<std::uint8_t> out) {
  const std::size_t n = std::min(out.size(), tx_size_);
  for (std::size_t i = 0; i < n; ++i) out[i] = tx_[(tx_head_ + i) % tx_.size()];
  tx_head_ = (tx_head_ + n) % tx_.size();
  tx_size_ -= n;
  return n;
}

// ---- handshake (§1.4) ----

void ArcosClient::start(Time now) { begin_handshake(now, true); }

void ArcosClient::begin_handshake(Time now, bool reset_counters) {
  if (reset_counters) {
    silent_tries_ = 0;
    total_tries_ = 0;
  }
  ++stats_.handshakes_started;
  baud_ = opt_.baud;
  sync_step_ = 0;
  state_ = ArcosClientState::kSyncing;
  send_sync(now);
}

void ArcosClient::send_sync(Time now) {
  (void)queue(make_command(static_cast<Command>(sync_step_)), now);
  step_deadline_ = now + opt_.sync_reply_timeout;
  recompute_deadline();
}

void ArcosClient::give_up(Time now) {
  ++stats_.give_ups;
  last_error_ = "arcos: robot does not answer the handshake; pausing before the next round";
  state_ = ArcosClientState::kPaused;
  baud_ = opt_.baud;
  step_deadline_ = now + opt_.retry_pause;
  recompute_deadline();
}

void ArcosClient::silent_try(Time now) {
  ++stats_.sync_timeouts;
  ++silent_tries_;
  ++total_tries_;
  if (silent_tries_ >= opt_.max_silent_tries || total_tries_ >= opt_.max_total_tries) {
    give_up(now);
    return;
  }
  if (silent_tries_ >= opt_.silent_tries_before_baud_cycle) {
    // Perhaps the robot still runs at another rate after an earlier client's HOSTBAUD: CLOSE at
    // every rate in turn, then start over at the nominal rate (ARIA's asyncConnectHandler).
    ++stats_.baud_cycles;
    dislodge_ = silent_tries_ >= opt_.silent_tries_before_dislodge;
    baud_index_ = 0;
    state_ = ArcosClientState::kBaudCycle;
    baud_ = opt_.close_cycle_bauds[0];
    (void)queue(make_command(Command::kClose, 1), now);
    step_deadline_ = now + opt_.baud_step;
    recompute_deadline();
    return;
  }
  begin_handshake(now, false);
}

void ArcosClient::handshake_packet(const PacketView& p, Time now) {
  if (p.type != sync_step_) {
    // E.g. SIPs because an earlier client left the server open: CLOSE and start again (§1.4).
    ++stats_.wrong_replies;
    ++total_tries_;
    last_error_ = "arcos: unexpected packet during the handshake; closing a stale connection";
    (void)queue(make_command(Command::kClose, 1), now);
    if (total_tries_ >= opt_.max_total_tries) {
      give_up(now);
      return;
    }
    state_ = ArcosClientState::kClosingStale;
    step_deadline_ = now + opt_.close_drain;
    recompute_deadline();
    return;
  }
  if (sync_step_ < 2) {
    ++sync_step_;
    send_sync(now);
    return;
  }
  // SYNC2 reply: name, class, subclass select the parameters (§1.4, §1.11).
  auto reply = decode_sync2_reply(p);
  identity_ = reply.ok() ? reply.value() : Sync2Reply{};
  const std::string_view subclass = opt_.subclass_override.empty() ? identity_.subclass.view() : opt_.subclass_override;
  auto params = params_for_subclass(subclass);
  if (params.ok()) {
    odometry_.set_params(params.value());
  } else {
    ++stats_.unknown_subclass;
    last_error_ = params.error().what;
    if (!opt_.allow_unknown_subclass) {
      (void)queue(make_command(Command::kClose, 1), now);
      give_up(now);
      return;
    }
    odometry_.set_params(fallback_params(identity_.subclass.view()));
  }
  (void)queue(make_command(Command::kOpen, 1), now);  // ARIA's OPEN with int 1 (A5)
  if (opt_.enable_motors) (void)queue(make_command(Command::kEnable, 1), now);
  if (opt_.request_config) (void)queue(make_command(Command::kConfig, 1), now);
  odometry_.rebase();
  state_ = ArcosClientState::kOpening;
  last_sip_rx_ = now;
  step_deadline_ = now + opt_.first_sip_timeout;
  recompute_deadline();
}

// ---- connected ----

void ArcosClient::connected_packet(const PacketView& p, Time now) {
  if (is_sip_type(p.type)) {
    auto sip = decode_sip(p);
    if (!sip.ok()) {
      ++stats_.bad_sips;
      return;
    }
    if (state_ == ArcosClientState::kOpening) {
      state_ = ArcosClientState::kConnected;
      ++stats_.connects;
      silent_tries_ = 0;
      total_tries_ = 0;
      last_error_ = "";
    }
    latest_sip_ = sip.value();
    odometry_.update(latest_sip_, now);
    last_sip_rx_ = now;
    ++stats_.sips;
    if (sip_cb_ != nullptr) sip_cb_(sip_ctx_, latest_sip_, odometry_.state(), now);
    recompute_deadline();
    return;
  }
  switch (static_cast<PacketType>(p.type)) {
    case PacketType::kConfig: {
      auto c = decode_config(p);  // tolerant of truncation; never required (§6)
      if (c.ok()) {
        config_ = c.value();
        have_config_ = true;
        ++stats_.configs;
      }
      return;
    }
    case PacketType::kEncoder: {
      auto e = decode_encoder(p);
      if (e.ok()) {
        encoder_ = e.value();
        ++stats_.encoder_packets;
      }
      return;
    }
    default:
      ++stats_.other_packets;  // late SYNC echoes, IOpac, gyro...: not ours to act on
      return;
  }
}

void ArcosClient::on_packet(const PacketView& p, Time now) {
  switch (state_) {
    case ArcosClientState::kSyncing: handshake_packet(p, now); return;
    case ArcosClientState::kOpening:
    case ArcosClientState::kConnected: connected_packet(p, now); return;
    default: return;  // draining, cycling, paused, lost, shut down: ignore
  }
}

void ArcosClient::on_rx(std::span<const std::uint8_t> bytes, Time now) {
  if (state_ == ArcosClientState::kIdle) begin_handshake(now, true);
  if (state_ == ArcosClientState::kDeviceLost || state_ == ArcosClientState::kShutdown) return;
  if (!bytes.empty()) last_rx_ = now;
  while (!bytes.empty()) {
    const std::size_t n = parser_.feed(bytes);
    bytes = bytes.subspan(n);
    drain_parser(now);
  }
}

void ArcosClient::drain_parser(Time now) {
  for (auto e = parser_.poll(); e.kind != ArcosParser::EventKind::kNeedMore; e = parser_.poll()) {
    if (e.kind == ArcosParser::EventKind::kPacket) on_packet(e.packet, now);
  }
}

Time ArcosClient::next_deadline() const {
  if (parser_.buffered() > 0 && state_ != ArcosClientState::kDeviceLost && state_ != ArcosClientState::kShutdown) {
    return std::min(deadline_, last_rx_ + opt_.inter_byte_timeout);
  }
  return deadline_;
}

// ---- host commands ----

void ArcosClient::send_motion(Time now) {
  switch (motion_) {
    case MotionKind::kNone: (void)queue(make_command(Command::kPulse), now); break;
    case MotionKind::kVelRvel:
      (void)queue(make_command(Command::kVel, static_cast<std::int32_t>(std::lround(trans_mm_s_))), now);
      (void)queue(make_command(Command::kRVel, static_cast<std::int32_t>(std::lround(rot_deg_s_))), now);
      break;
    case MotionKind::kVel2: (void)queue(make_vel2(left_mm_s_, right_mm_s_, params().vel2_divisor_mm_s), now); break;
  }
}

void ArcosClient::set_velocity(double trans_mm_s, double rot_deg_s, Time now) {
  motion_ = MotionKind::kVelRvel;
  trans_mm_s_ = trans_mm_s;
  rot_deg_s_ = rot_deg_s;
  last_motion_cmd_ = now;
  if (connected()) send_motion(now);
  recompute_deadline();
}

void ArcosClient::set_wheel_velocities(double left_mm_s, double right_mm_s, Time now) {
  motion_ = MotionKind::kVel2;
  left_mm_s_ = left_mm_s;
  right_mm_s_ = right_mm_s;
  last_motion_cmd_ = now;
  if (connected()) send_motion(now);
  recompute_deadline();
}

void ArcosClient::stop(Time now) {
  motion_ = MotionKind::kNone;
  if (connected()) (void)queue(make_command(Command::kStop), now);
  recompute_deadline();
}

bool ArcosClient::send_command(const PacketBuffer& packet, Time now) {
  if (!connected()) return false;
  return queue(packet, now);
}

void ArcosClient::shutdown(Time now) {
  if (state_ == ArcosClientState::kOpening || state_ == ArcosClientState::kConnected) {
    (void)queue(make_command(Command::kStop), now);
  }
  if (state_ != ArcosClientState::kDeviceLost) (void)queue(make_command(Command::kClose, 1), now);  // A19
  motion_ = MotionKind::kNone;
  baud_ = opt_.baud;
  state_ = ArcosClientState::kShutdown;
  recompute_deadline();
}

void ArcosClient::on_device_lost(Time now) {
  (void)now;
  ++stats_.device_losses;
  last_error_ = "arcos: serial device lost";
  state_ = ArcosClientState::kDeviceLost;
  tx_head_ = tx_size_ = 0;
  parser_.reset();
  recompute_deadline();
}

void ArcosClient::on_device_back(Time now) {
  if (state_ != ArcosClientState::kDeviceLost) return;
  parser_.reset();
  odometry_.rebase();
  begin_handshake(now, true);
}

// ---- timers ----

void ArcosClient::on_tick(Time now) {
  if (parser_.buffered() > 0 && now - last_rx_ >= opt_.inter_byte_timeout &&
      state_ != ArcosClientState::kDeviceLost && state_ != ArcosClientState::kShutdown) {
    // A corrupted count can make the parser wait for bytes that are not coming (§1.2).
    parser_.finish();
    drain_parser(now);
  }
  switch (state_) {
    case ArcosClientState::kIdle: begin_handshake(now, true); return;
    case ArcosClientState::kSyncing:
      if (now >= step_deadline_) silent_try(now);
      return;
    case ArcosClientState::kClosingStale:
      if (now >= step_deadline_) begin_handshake(now, false);
      return;
    case ArcosClientState::kBaudCycle:
      if (now < step_deadline_) return;
      if (++baud_index_ < opt_.close_cycle_bauds.size()) {
        baud_ = opt_.close_cycle_bauds[baud_index_];
        (void)queue(make_command(Command::kClose, 1), now);
        step_deadline_ = now + opt_.baud_step;
        recompute_deadline();
        return;
      }
      baud_ = opt_.baud;
      if (dislodge_) {
        // "to dislodge" a robot stuck in the middle of something (ARIA after > 3 silent tries).
        ++stats_.dislodge_opens;
        (void)queue(make_command(Command::kOpen, 1), now);
        dislodge_ = false;
        step_deadline_ = now + opt_.baud_step;
        recompute_deadline();
        baud_index_ = opt_.close_cycle_bauds.size();
        return;
      }
      begin_handshake(now, false);
      return;
    case ArcosClientState::kPaused:
      if (now >= step_deadline_) begin_handshake(now, true);
      return;
    case ArcosClientState::kOpening:
      if (now >= step_deadline_) {
        ++stats_.silence_reconnects;
        last_error_ = "arcos: no SIP after OPEN; reconnecting";
        begin_handshake(now, false);
        return;
      }
      break;
    case ArcosClientState::kConnected:
      if (now - last_sip_rx_ >= opt_.sip_timeout) {
        ++stats_.silence_reconnects;
        last_error_ = "arcos: SIPs stopped; reconnecting";
        odometry_.rebase();
        begin_handshake(now, true);
        return;
      }
      if (opt_.motion_command_timeout > 0ns && motion_ != MotionKind::kNone &&
          now - last_motion_cmd_ >= opt_.motion_command_timeout) {
        ++stats_.motion_timeouts;
        stop(now);
      }
      break;
    case ArcosClientState::kDeviceLost:
    case ArcosClientState::kShutdown: return;
  }
  // kOpening / kConnected: keep-alive at least every keep_alive_period (§1.6).
  if (now - last_tx_ >= opt_.keep_alive_period) {
    ++stats_.keep_alives;
    send_motion(now);
  }
  recompute_deadline();
}

void ArcosClient::recompute_deadline() {
  constexpr Time kNever = Time::from_ns(INT64_MAX);
  switch (state_) {
    case ArcosClientState::kIdle: deadline_ = Time{}; return;
    case ArcosClientState::kSyncing:
    case ArcosClientState::kClosingStale:
    case ArcosClientState::kBaudCycle:
    case ArcosClientState::kPaused: deadline_ = step_deadline_; return;
    case ArcosClientState::kOpening:
      deadline_ = std::min(step_deadline_, last_tx_ + opt_.keep_alive_period);
      return;
    case ArcosClientState::kConnected: {
      Time d = std::min(last_sip_rx_ + opt_.sip_timeout, last_tx_ + opt_.keep_alive_period);
      if (opt_.motion_command_timeout > 0ns && motion_ != MotionKind::kNone) {
        d = std::min(d, last_motion_cmd_ + opt_.motion_command_timeout);
      }
      deadline_ = d;
      return;
    }
    case ArcosClientState::kDeviceLost:
    case ArcosClientState::kShutdown: deadline_ = kNever; return;
  }
}

}  // namespace teamscan::arcos
