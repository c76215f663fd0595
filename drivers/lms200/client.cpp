// LMS 2xx host client: bring-up state machine (PROTOCOLS.md §2.11), recovery, scan delivery.
#include "drivers/lms200/client.hpp"

#include <algorithm>
#include <cstring>

namespace teamscan::lms200 {
namespace {

constexpr std::array<std::uint32_t, 4> kProbeRates{9600, 19200, 38400, 500000};  // §2.1
// While a request is outstanding a scan may be on the line in front of the reply: allow for the
// longest 0xB0 (812 bytes) plus the longest reply we request (0xB1, 160) and the ACK.
constexpr std::int64_t kLineAllowanceBytes = 812 + 160 + 1;

std::uint8_t code(Reply r) { return static_cast<std::uint8_t>(r); }

}  // namespace

const char* to_string(LmsClientState state) {
  switch (state) {
    case LmsClientState::idle: return "idle";
    case LmsClientState::waiting_power_on: return "waiting_power_on";
    case LmsClientState::probing: return "probing";
    case LmsClientState::stopping_stream: return "stopping_stream";
    case LmsClientState::switching_baud: return "switching_baud";
    case LmsClientState::confirming_baud: return "confirming_baud";
    case LmsClientState::setting_variant: return "setting_variant";
    case LmsClientState::reading_config: return "reading_config";
    case LmsClientState::entering_setup: return "entering_setup";
    case LmsClientState::writing_config: return "writing_config";
    case LmsClientState::starting_stream: return "starting_stream";
    case LmsClientState::streaming: return "streaming";
    case LmsClientState::waiting_reset: return "waiting_reset";
    case LmsClientState::backoff: return "backoff";
    case LmsClientState::stopping: return "stopping";
    case LmsClientState::returning_baud: return "returning_baud";
    case LmsClientState::stopped: return "stopped";
    case LmsClientState::device_lost: return "device_lost";
  }
  return "unknown";
}

LmsClient::LmsClient(const LmsClientOptions& options) : options_{options} {}

void LmsClient::start(Time now) {
  now_ = now;
  set_baud(9600);
  enter(options_.wait_for_power_on ? LmsClientState::waiting_power_on : LmsClientState::probing, now);
}

void LmsClient::shutdown(Time now) {
  now_ = now;
  if (state_ == LmsClientState::idle || state_ == LmsClientState::stopped || state_ == LmsClientState::device_lost) {
    enter(LmsClientState::stopped, now);
    return;
  }
  enter(LmsClientState::stopping, now);
}

void LmsClient::on_device_lost(Time now) {
  now_ = now;
  ++stats_.device_losses;
  last_error_ = "serial device lost";
  enter(LmsClientState::device_lost, now);
}

void LmsClient::on_device_back(Time now) {
  now_ = now;
  if (state_ != LmsClientState::device_lost) return;
  // The scanner may have kept its rate (adapter unplugged) or restarted (power): probe, last rate first.
  enter(LmsClientState::probing, now);
}

void LmsClient::set_baud(std::uint32_t baud) {
  baud_ = baud;
  parser_.reset();  // bytes received at the old rate mean nothing at the new one
}

Duration LmsClient::line_allowance() const { return serial_transmission_time(kLineAllowanceBytes, baud_); }

void LmsClient::request(std::size_t n, std::uint8_t expect, Duration timeout, Time now) {
  TEAMSCAN_EXPECTS(n > 0 && n <= request_.size());
  request_len_ = n;
  expect_ = expect;
  waiting_ = true;
  timeout_ = timeout + line_allowance();
  deadline_ = now + timeout_;
  retries_left_ = state_ == LmsClientState::probing ? 0 : options_.retries;
  if (tx_len_ + n <= tx_.size()) {
    std::copy_n(request_.begin(), n, tx_.begin() + static_cast<std::ptrdiff_t>(tx_len_));
    tx_len_ += n;
  }
}

void LmsClient::resend(Time now) {
  ++stats_.retries;
  --retries_left_;
  deadline_ = now + timeout_;
  if (tx_len_ + request_len_ <= tx_.size()) {
    std::copy_n(request_.begin(), request_len_, tx_.begin() + static_cast<std::ptrdiff_t>(tx_len_));
    tx_len_ += request_len_;
  }
}

void LmsClient::step_failed(const char* why, Time now) {
  last_error_ = why;
  waiting_ = false;
  switch (state_) {
    case LmsClientState::probing: probe_next(now); break;
    case LmsClientState::stopping:
    case LmsClientState::returning_baud: enter(LmsClientState::stopped, now); break;  // best effort
    default: enter(LmsClientState::probing, now); break;
  }
}

void LmsClient::refused(const char* why, Time now) {
  ++stats_.refused;
  last_error_ = why;
  waiting_ = false;
  if (state_ == LmsClientState::stopping || state_ == LmsClientState::returning_baud) {
    enter(LmsClientState::stopped, now);
    return;
  }
  enter(LmsClientState::backoff, now);
}

void LmsClient::start_probe(Time now) {
  ++stats_.probe_rounds;
  probe_index_ = 0;
  probe_count_ = 0;
  probe_next(now);
}

void LmsClient::probe_next(Time now) {
  if (probe_count_ == kProbeRates.size()) {
    start_probe(now);  // every rate tried: go round again (the timeouts pace the rounds)
    return;
  }
  // Order: the last rate that worked first, then the others in the table's order.
  std::uint32_t rate = last_good_baud_;
  if (probe_count_ > 0) {
    do {
      rate = kProbeRates[probe_index_++ % kProbeRates.size()];
    } while (rate == last_good_baud_);
  }
  ++probe_count_;
  set_baud(rate);
  request(build_status_request(request_), code(Reply::status), options_.reply_timeout, now);
}

void LmsClient::enter(LmsClientState s, Time now) {
  state_ = s;
  waiting_ = false;
  switch (s) {
    case LmsClientState::idle: break;
    case LmsClientState::waiting_power_on:
      set_baud(9600);
      timer_ = now + options_.power_on_timeout;
      break;
    case LmsClientState::probing: start_probe(now); break;
    case LmsClientState::stopping_stream:
      request(build_stop_continuous(request_), code(Reply::change_mode), options_.reply_timeout, now);
      break;
    case LmsClientState::switching_baud:
      if (baud_ == options_.target_baud || !baud_mode(options_.target_baud)) {
        enter(LmsClientState::setting_variant, now);
        return;
      }
      request(build_baud_switch(request_, options_.target_baud), code(Reply::change_mode), options_.reply_timeout, now);
      break;
    case LmsClientState::confirming_baud: timer_ = now + options_.baud_settle; break;
    case LmsClientState::setting_variant:
      request(build_variant(request_, options_.variant), code(Reply::variant), options_.reply_timeout, now);
      break;
    case LmsClientState::reading_config:
      if (!options_.set_config) {
        enter(LmsClientState::starting_stream, now);
        return;
      }
      request(build_read_config(request_), code(Reply::read_config), options_.reply_timeout, now);
      break;
    case LmsClientState::entering_setup:
      request(build_setup_mode(request_, options_.password), code(Reply::change_mode), options_.reply_timeout, now);
      break;
    case LmsClientState::writing_config:
      request(build_write_config(request_, std::span{config_}.first(config_len_)), code(Reply::write_config),
              options_.write_config_timeout, now);
      break;
    case LmsClientState::starting_stream:
      request(build_start_continuous(request_), code(Reply::change_mode), options_.reply_timeout, now);
      break;
    case LmsClientState::streaming:
      ++stats_.bringups;
      last_telegram_ = now;
      break;
    case LmsClientState::waiting_reset:
      set_baud(9600);  // §6: after 0x91 the 0x90 comes at the power-up rate
      timer_ = now + options_.reset_timeout;
      break;
    case LmsClientState::backoff: timer_ = now + options_.retry_backoff; break;
    case LmsClientState::stopping:
      request(build_stop_continuous(request_), code(Reply::change_mode), options_.reply_timeout, now);
      break;
    case LmsClientState::returning_baud:
      if (baud_ == 9600) {
        enter(LmsClientState::stopped, now);
        return;
      }
      request(build_baud_switch(request_, 9600), code(Reply::change_mode), options_.reply_timeout, now);
      break;
    case LmsClientState::stopped: break;
    case LmsClientState::device_lost:
      tx_len_ = 0;
      parser_.reset();
      break;
  }
}

bool LmsClient::config_needs_write() const {
  return config_[5] != static_cast<std::uint8_t>(options_.measuring_mode) ||
         config_[6] != static_cast<std::uint8_t>(options_.units) ||
         ((config_[4] & 0x02) != 0) != options_.realtime_index;
}

void LmsClient::handle_reply(const TelegramView& t, Time now) {
  waiting_ = false;
  const auto data = t.data();
  const bool mode_done = t.code() == code(Reply::change_mode) && data.size() == 1 && data[0] == 0;
  switch (state_) {
    case LmsClientState::stopping_stream:
      if (mode_done) enter(LmsClientState::switching_baud, now); else refused("stop stream refused", now);
      break;
    case LmsClientState::switching_baud:
      if (!mode_done) {
        refused("baud switch refused", now);
        break;
      }
      ++stats_.baud_switches;
      set_baud(options_.target_baud);
      enter(LmsClientState::confirming_baud, now);
      break;
    case LmsClientState::confirming_baud:
      // The status reply at the new rate is the confirmation (MRPT); its baud code must agree.
      if (const auto info = parse_status_data(data); info && info->baud != 0 && info->baud != baud_) {
        step_failed("status reply reports another baud rate", now);
        break;
      }
      last_good_baud_ = baud_;
      enter(LmsClientState::setting_variant, now);
      break;
    case LmsClientState::setting_variant: {
      const bool ok = data.size() == 5 && data[0] == 0x01 &&
                      (data[1] | (data[2] << 8)) == options_.variant.fov_deg &&
                      (data[3] | (data[4] << 8)) == options_.variant.resolution_cdeg;
      if (ok) enter(LmsClientState::reading_config, now); else refused("variant refused", now);
      break;
    }
    case LmsClientState::reading_config:
      if (data.size() != kConfigBytes && data.size() != kMaxConfigBytes) {
        refused("configuration block of unexpected length", now);
        break;
      }
      config_len_ = data.size();
      std::copy(data.begin(), data.end(), config_.begin());
      mode_ = static_cast<MeasuringMode>(config_[5]);
      if (config_needs_write()) enter(LmsClientState::entering_setup, now); else enter(LmsClientState::starting_stream, now);
      break;
    case LmsClientState::entering_setup:
      if (!mode_done) {
        refused("setup mode refused (password)", now);
        break;
      }
      // §2.6: modify in place and write back the same length as read.
      config_[5] = static_cast<std::uint8_t>(options_.measuring_mode);
      config_[6] = static_cast<std::uint8_t>(options_.units);
      config_[4] = static_cast<std::uint8_t>(options_.realtime_index ? (config_[4] | 0x02) : (config_[4] & ~0x02));
      enter(LmsClientState::writing_config, now);
      break;
    case LmsClientState::writing_config:
      if (data.empty() || data[0] != 0x01) {
        refused("configuration write refused", now);
        break;
      }
      mode_ = options_.measuring_mode;
      enter(LmsClientState::starting_stream, now);
      break;
    case LmsClientState::starting_stream:
      if (mode_done) enter(LmsClientState::streaming, now); else refused("start stream refused", now);
      break;
    case LmsClientState::stopping: enter(LmsClientState::returning_baud, now); break;
    case LmsClientState::returning_baud:
      set_baud(9600);
      enter(LmsClientState::stopped, now);
      break;
    default: break;
  }
}

void LmsClient::handle_scan(const TelegramView& t, Time now) {
  if (state_ != LmsClientState::streaming) return;  // stream still flowing during stop/shutdown
  if (!decode_scan(t.bytes, mode_, decoded_).ok()) {
    ++stats_.decode_errors;
    return;
  }
  if (options_.drop_bad_status && decoded_.status.drop_scan()) {
    ++stats_.scans_bad_status;
    return;
  }
  const ScanArrival arrival{now, static_cast<std::uint16_t>(t.bytes.size()), baud_, options_.variant};
  ++stats_.scans;
  if (sink_ != nullptr) {
    sink_->on_scan(decoded_, arrival);
    return;
  }
  if (queue_size_ == kScanQueue) {
    ++stats_.scans_overflow;
    queue_head_ = (queue_head_ + 1) % kScanQueue;
    --queue_size_;
  }
  const std::size_t slot = (queue_head_ + queue_size_) % kScanQueue;
  queue_[slot] = decoded_;
  arrivals_[slot] = arrival;
  ++queue_size_;
}

bool LmsClient::take_scan(ScanTelegram& scan, ScanArrival& arrival) {
  if (queue_size_ == 0) return false;
  scan = queue_[queue_head_];
  arrival = arrivals_[queue_head_];
  queue_head_ = (queue_head_ + 1) % kScanQueue;
  --queue_size_;
  return true;
}

void LmsClient::on_rx(std::span<const std::uint8_t> bytes, Time now) {
  now_ = now;
  if (state_ == LmsClientState::device_lost || state_ == LmsClientState::idle) return;
  while (!bytes.empty()) {
    bytes = bytes.subspan(parser_.feed(bytes));
    LmsEvent e;
    while (parser_.next(e)) {
      if (e.kind == LmsEvent::Kind::nak && waiting_) {
        ++stats_.naks;
        if (retries_left_ > 0) resend(now); else step_failed("NAK", now);
        continue;
      }
      if (e.kind != LmsEvent::Kind::telegram) continue;
      const TelegramView t{e.bytes};
      last_telegram_ = now;
      const std::uint8_t c = t.code();
      if (c == code(Reply::measured_values)) {
        // `now` is when the chunk's last byte arrived; bytes behind this telegram in the same chunk
        // (still buffered or not yet fed) arrived after its last byte, one byte time each.
        const auto trailing = static_cast<std::int64_t>(parser_.buffered() + bytes.size());
        handle_scan(t, now - serial_transmission_time(trailing, baud_));
        if (state_ == LmsClientState::probing) {  // a stream at this rate proves the rate
          last_good_baud_ = baud_;
          enter(LmsClientState::stopping_stream, now);
        }
        continue;
      }
      if (state_ == LmsClientState::stopped) continue;
      if (c == code(Reply::reset_ack)) {
        ++stats_.scanner_resets;
        enter(LmsClientState::waiting_reset, now);
        continue;
      }
      if (c == code(Reply::power_on)) {
        // Fresh scanner at its power-up rate, polled mode: bring it up from here.
        if (state_ != LmsClientState::waiting_power_on && state_ != LmsClientState::waiting_reset &&
            state_ != LmsClientState::probing)
          ++stats_.scanner_resets;
        last_good_baud_ = baud_;
        if (state_ == LmsClientState::stopping || state_ == LmsClientState::returning_baud)
          enter(LmsClientState::stopped, now);  // shutting down and the scanner is at 9600 anyway
        else
          enter(LmsClientState::stopping_stream, now);
        continue;
      }
      if (state_ == LmsClientState::probing) {
        last_good_baud_ = baud_;
        enter(LmsClientState::stopping_stream, now);
        continue;
      }
      if (waiting_ && c == expect_) {
        handle_reply(t, now);
        continue;
      }
      if (waiting_ && c == code(Reply::incorrect_command)) {
        ++stats_.incorrect_command;
        step_failed("0x92 incorrect command", now);
      }
    }
  }
}

void LmsClient::on_tick(Time now) {
  now_ = now;
  if (waiting_ && now >= deadline_) {
    ++stats_.timeouts;
    if (retries_left_ > 0) resend(now); else step_failed("no reply", now);
    return;
  }
  switch (state_) {
    case LmsClientState::waiting_power_on:
    case LmsClientState::waiting_reset:
    case LmsClientState::backoff:
      if (now >= timer_) enter(LmsClientState::probing, now);
      break;
    case LmsClientState::confirming_baud:
      if (!waiting_ && now >= timer_)
        request(build_status_request(request_), code(Reply::status), options_.reply_timeout, now);
      break;
    case LmsClientState::streaming:
      if (now - last_telegram_ >= options_.silence_timeout) {
        ++stats_.silences;
        last_error_ = "no telegram within the silence timeout";
        enter(LmsClientState::probing, now);
      }
      break;
    default: break;
  }
}

std::size_t LmsClient::take_tx(std::span<std::uint8_t> out) {
  const std::size_t n = std::min(out.size(), tx_len_);
  std::copy_n(tx_.begin(), n, out.begin());
  std::memmove(tx_.data(), tx_.data() + n, tx_len_ - n);
  tx_len_ -= n;
  return n;
}

Time LmsClient::next_deadline() const {
  Time t = now_ + 1s;
  if (tx_len_ > 0) return now_;
  if (waiting_) t = std::min(t, deadline_);
  switch (state_) {
    case LmsClientState::waiting_power_on:
    case LmsClientState::waiting_reset:
    case LmsClientState::backoff:
    case LmsClientState::confirming_baud:
      if (!waiting_) t = std::min(t, timer_);
      break;
    case LmsClientState::streaming: t = std::min(t, last_telegram_ + options_.silence_timeout); break;
    default: break;
  }
  return t;
}

}  // namespace teamscan::lms200
