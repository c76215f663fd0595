// Emulated LMS 200: command handling of PROTOCOLS.md §2.4–§2.8, paced output, 0xB0 streaming (§2.10).
#include "drivers/lms200/emulator.hpp"

#include <algorithm>
#include <cstring>

namespace teamscan::lms200 {
namespace {

constexpr std::uint8_t kUnknownMode = 0xFF;

}  // namespace

LmsEmulator::LmsEmulator(const LmsEmulatorOptions& options, RangeSource* ranges)
    : options_{options},
      ranges_{ranges},
      baud_{options.power_up_baud},
      permanent_baud_{options.power_up_baud},
      variant_{options.variant},
      config_len_{std::min(options.config_bytes, kMaxConfigBytes)} {
  load_defaults();
}

void LmsEmulator::load_defaults() {
  config_.fill(0);
  config_[5] = options_.measuring_mode;  // D
  config_[6] = options_.units;           // E
  config_[9] = 0x02;                     // H multiple evaluation (the value public drivers write)
  config_[10] = 0x02;                    // I restart mode
  variant_ = options_.variant;
  mode_ = OperatingMode::polled;
  setup_ = false;
  write_reply_pending_ = false;
  pending_baud_ = 0;
  last_sent_sweep_ = -1;
}

void LmsEmulator::power_up(Time now) {
  now_ = now;
  line_free_at_ = now;
  if (options_.send_power_on) {
    powered_ = false;
    power_on_pending_ = true;
    power_on_due_ = now + options_.power_on_delay;
  } else {
    powered_ = true;
  }
}

void LmsEmulator::spontaneous_reset(Time now) {
  now_ = now;
  ++stats_.resets;
  powered_ = false;
  tx_begin_ = tx_end_ = 0;
  parser_.reset();
  load_defaults();
  power_on_pending_ = true;
  power_on_due_ = now + options_.reset_delay;
}

void LmsEmulator::finish_reset(Time now) {
  power_on_pending_ = false;
  powered_ = true;
  baud_ = permanent_baud_;
  line_free_at_ = now;
  const std::size_t n = build_power_on(scratch_, options_.type, options_.status_byte);
  queue(std::span{scratch_}.first(n));
}

std::size_t LmsEmulator::sendable_now() const {
  const std::size_t pending = pending_tx();
  if (!options_.pace_output || pending == 0) return pending;
  if (now_ < burst_start_) return 0;
  // Bytes fully on the line since the burst started: elapsed_us × baud / 10 bits / 1e6. The product
  // stays below 2^63 for bursts shorter than ~500 hours at 500 kBd.
  const std::int64_t elapsed_us = (now_ - burst_start_).count() / 1000;
  const std::int64_t done = elapsed_us * static_cast<std::int64_t>(baud_) / 10'000'000 - burst_sent_;
  if (done <= 0) return 0;
  return std::min(pending, static_cast<std::size_t>(done));
}

void LmsEmulator::queue(std::span<const std::uint8_t> bytes, Time earliest) {
  if (pending_tx() == 0) {
    tx_begin_ = tx_end_ = 0;
    burst_start_ = std::max(earliest, line_free_at_);
    burst_sent_ = 0;
  }
  if (tx_.size() - tx_end_ < bytes.size() && tx_begin_ > 0) {
    const std::size_t n = pending_tx();
    std::memmove(tx_.data(), tx_.data() + tx_begin_, n);
    tx_begin_ = 0;
    tx_end_ = n;
  }
  const std::size_t n = std::min(bytes.size(), tx_.size() - tx_end_);  // a full queue drops (never here)
  std::copy_n(bytes.begin(), n, tx_.begin() + static_cast<std::ptrdiff_t>(tx_end_));
  tx_end_ += n;
}

std::size_t LmsEmulator::take_tx(std::span<std::uint8_t> out) {
  const std::size_t n = std::min(out.size(), sendable_now());
  std::copy_n(tx_.begin() + static_cast<std::ptrdiff_t>(tx_begin_), n, out.begin());
  tx_begin_ += n;
  burst_sent_ += static_cast<std::int64_t>(n);
  if (n > 0 && pending_tx() == 0) {
    // Paced or not, the line is busy for the burst's transmission time: the streaming rule (send the
    // newest scan when the line is free) holds on a link that paces the bytes itself too.
    line_free_at_ = burst_start_ + serial_transmission_time(burst_sent_, baud_);
    if (pending_baud_ != 0) {
      // §2.4: the LMS changes its rate after the ACK and the 0xA0 reply have left at the old rate.
      baud_ = pending_baud_;
      pending_baud_ = 0;
      ++stats_.baud_switches;
    }
  }
  return n;
}

Time LmsEmulator::next_deadline() const {
  Time t = now_ + 1s;
  const std::size_t pending = pending_tx();
  if (pending > 0) {
    if (!options_.pace_output) return now_;
    const auto chunk = static_cast<std::int64_t>(std::min<std::size_t>(pending, 32));
    t = std::min(t, burst_start_ + serial_transmission_time(burst_sent_ + chunk, baud_) + 1us);
  }
  if (power_on_pending_) t = std::min(t, power_on_due_);
  if (write_reply_pending_) t = std::min(t, write_reply_due_);
  if (streaming()) {
    const std::int64_t period = scan_period().count();
    const std::int64_t k = (now_ - stream_start_).count() / period;
    t = std::min(t, stream_start_ + Duration{(k + 1) * period});
  }
  return t;
}

void LmsEmulator::on_tick(Time now) {
  now_ = now;
  if (power_on_pending_ && now >= power_on_due_) finish_reset(now);
  if (!powered_) return;
  if (write_reply_pending_ && now >= write_reply_due_) {
    write_reply_pending_ = false;
    const std::size_t n = build_write_config_reply(scratch_, write_accepted_, config(), options_.status_byte);
    queue(std::span{scratch_}.first(n));
  }
  if (streaming() && pending_tx() == 0 && now >= line_free_at_) {
    const std::int64_t period = scan_period().count();
    const std::int64_t newest = (now - stream_start_).count() / period - 1;  // newest completed sweep
    if (newest > last_sent_sweep_) {
      if (last_sent_sweep_ >= 0) stats_.scans_skipped += static_cast<std::uint64_t>(newest - last_sent_sweep_ - 1);
      last_sent_sweep_ = newest;
      queue_scan(stream_start_ + Duration{(newest + 1) * period});
    }
  }
}

void LmsEmulator::queue_scan(Time sweep_end) {
  const std::uint16_t n = variant_.beams();
  const auto beams = std::span{beams_}.first(n);
  if (ranges_ != nullptr) {
    ranges_->measure(SweepTiming{sweep_end, variant_, scan_number_}, beams);
  } else {
    std::fill(beams.begin(), beams.end(), BeamReading{3000, 0, BeamInvalid::none});  // a wall at 3 m
  }
  const auto unit = static_cast<Unit>(config_[6] <= 2 ? config_[6] : 0);
  const auto mode = static_cast<MeasuringMode>(config_[5]);
  for (std::size_t i = 0; i < n; ++i)
    words_[i] = encode_value_word(beams[i].range_mm, beams[i].flags, beams[i].invalid, unit, mode);
  CountWord cw;
  cw.values = n;
  cw.unit_bits = static_cast<std::uint8_t>(unit);
  // Config block C bit 0x02: append the real-time scan index (§2.6, §2.7).
  const std::optional<std::uint8_t> rt =
      (config_[4] & 0x02) != 0 ? std::optional<std::uint8_t>{static_cast<std::uint8_t>(scan_number_ & 0xFF)}
                               : std::nullopt;
  const std::size_t len = build_scan_reply(scratch_, cw.encode(), std::span{words_}.first(n), rt, options_.status_byte);
  // The scanner starts sending when the sweep ends (or the line frees), not when we were ticked.
  queue(std::span{scratch_}.first(len), std::min(sweep_end, now_));
  ++scan_number_;
  ++stats_.scans_sent;
}

void LmsEmulator::on_rx(std::span<const std::uint8_t> bytes, Time now) {
  now_ = now;
  while (!bytes.empty()) {
    bytes = bytes.subspan(parser_.feed(bytes));
    LmsEvent e;
    while (parser_.next(e)) {
      if (!powered_) continue;  // booting or resetting: the LMS does not listen
      switch (e.kind) {
        case LmsEvent::Kind::telegram:
          nak_armed_ = true;
          handle_telegram(TelegramView{e.bytes});
          break;
        case LmsEvent::Kind::bad_crc:
        case LmsEvent::Kind::bad_length:
          // §2.2: a telegram that was not accepted is answered by a lone NAK — one per broken
          // telegram, not one per false header the re-scan finds inside it.
          if (nak_armed_) {
            queue_byte(kNak);
            ++stats_.naks_sent;
            nak_armed_ = false;
          }
          break;
        default: break;
      }
    }
  }
  if (parser_.buffered() == 0) nak_armed_ = true;  // the broken telegram is behind us
}

void LmsEmulator::handle_telegram(const TelegramView& t) {
  ++stats_.commands;
  const auto data = t.data();
  std::size_t n = 0;
  auto incorrect = [&] {
    ++stats_.incorrect_commands;
    return build_incorrect_command(scratch_, options_.status_byte);
  };
  // Every telegram that arrived intact is acknowledged first (§2.2); 0x92 then says it was illegal.
  queue_byte(kAck);
  switch (static_cast<Command>(t.code())) {
    case Command::change_mode: handle_mode(data); return;
    case Command::status: {
      StatusInfo info;
      info.operating_mode = static_cast<std::uint8_t>(mode_);
      info.measuring_mode = config_[5];
      info.variant = variant_;
      info.baud = baud_;
      info.permanent_baud = permanent_baud_ != options_.power_up_baud;
      info.units = config_[6];
      n = data.empty() ? build_status_reply(scratch_, info, options_.status_byte) : incorrect();
      break;
    }
    case Command::poll_values:
      if (data.size() == 1 && data[0] == 0x01) {
        queue_scan(now_);
        return;
      }
      n = incorrect();
      break;
    case Command::error_telegram:
      n = build_reply(scratch_, static_cast<std::uint8_t>(Reply::error_telegram), {}, options_.status_byte);
      break;
    case Command::lms_type: n = build_lms_type_reply(scratch_, options_.type, options_.status_byte); break;
    case Command::variant: {
      if (data.size() != 4) {
        n = incorrect();
        break;
      }
      const LaserVariant wanted{static_cast<std::uint16_t>(data[0] | (data[1] << 8)),
                                static_cast<std::uint16_t>(data[2] | (data[3] << 8))};
      const bool ok = is_supported_variant(wanted);
      if (ok) {
        variant_ = wanted;
        // sicktoolbox: the scanner stops streaming when the variant changes mid-stream (§2.5).
        if (mode_ == OperatingMode::continuous) mode_ = OperatingMode::polled;
      }
      n = build_variant_reply(scratch_, ok, variant_, options_.status_byte);
      break;
    }
    case Command::read_config: n = build_config_reply(scratch_, config(), options_.status_byte); break;
    case Command::write_config: {
      // Setup mode only, same length as the block this firmware has (§2.6), units 0..2.
      write_accepted_ = setup_ && data.size() == config_len_ && data[6] <= 2 && is_known_measuring_mode(data[5]);
      if (write_accepted_) std::copy(data.begin(), data.end(), config_.begin());
      write_reply_pending_ = true;
      write_reply_due_ = now_ + options_.write_config_delay;
      on_tick(now_);
      return;
    }
    case Command::store_permanent:
      if (data.size() == 1 && (data[0] == 0x01 || data[0] == 0x02)) {
        if (data[0] == 0x01) permanent_baud_ = baud_;
        n = build_store_reply(scratch_, true, options_.status_byte);
      } else {
        n = incorrect();
      }
      break;
    case Command::reset: {
      ++stats_.resets;
      n = build_reset_ack(scratch_, options_.status_byte);
      queue(std::span{scratch_}.first(n));
      // After the 0x91 the device reboots: deaf until the 0x90 at the power-up rate (§2.10, §6).
      powered_ = false;
      power_on_pending_ = true;
      power_on_due_ = now_ + options_.reset_delay;
      parser_.reset();
      load_defaults();
      return;
    }
    default: n = incorrect(); break;
  }
  queue(std::span{scratch_}.first(n));
}

void LmsEmulator::handle_mode(std::span<const std::uint8_t> data) {
  const std::uint8_t m = data.empty() ? kUnknownMode : data[0];
  ModeResult result = ModeResult::done;
  bool known = true;
  switch (m) {
    case 0x00: {  // setup mode: 8-byte password (§2.4)
      const bool ok = data.size() == 9 && std::memcmp(data.data() + 1, kSetupPassword.data(), 8) == 0;
      result = ok ? ModeResult::done : ModeResult::bad_password;
      if (ok) setup_ = true;
      break;
    }
    case 0x24:
      if (mode_ != OperatingMode::continuous) {
        stream_start_ = now_;
        last_sent_sweep_ = -1;
      }
      mode_ = OperatingMode::continuous;
      setup_ = false;
      break;
    case 0x25:
      mode_ = OperatingMode::polled;
      setup_ = false;
      break;
    case 0x10: mode_ = OperatingMode::diagnostic; break;
    case 0x40:
    case 0x41:
    case 0x42:
    case 0x48:
      pending_baud_ = baud_of_mode(static_cast<OperatingMode>(m));
      break;
    default: known = false; break;  // 0x26/0x27/0x2A/0x2B (mean values, sub-ranges) are not emulated
  }
  if (!known || (data.size() != 1 && m != 0x00)) {
    pending_baud_ = 0;
    ++stats_.incorrect_commands;
    const std::size_t n = build_incorrect_command(scratch_, options_.status_byte);
    queue(std::span{scratch_}.first(n));
    return;
  }
  const std::size_t n = build_mode_reply(scratch_, result, options_.status_byte);
  queue(std::span{scratch_}.first(n));  // a baud switch takes effect once this has left (take_tx)
}

}  // namespace teamscan::lms200
