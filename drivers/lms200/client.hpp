// The host side of an LMS 2xx link: the bring-up state machine of PROTOCOLS.md §2.11 as a sans-I/O
// SerialEndpoint (no fd, no clock: time comes in as arguments), scan delivery, recovery.
//
// Bring-up: probe the rate (9600/19200/38400/500k with 0x31) or wait for the 0x90 power-on telegram,
// stop any stream (0x20 25), switch to the target rate (0x20 4x -> A0 00 -> host switches -> settle
// -> 0x31 confirms at the new rate), set the variant (0x3B), read the configuration (0x74) and, if the
// units/measuring mode/real-time-index bit differ, enter setup mode (0x20 00 "SICK_LMS") and write the
// block back with the same length (0x77), start continuous output (0x20 24), stream.
// Recovery: 0x91/0x90 (scanner reset) -> bring-up again from 9600; no telegram for silence_timeout
// while streaming -> probe again; on_device_lost()/on_device_back() around a lost serial device.
// shutdown(): stop the stream (0x20 25) and return the scanner to 9600 (0x20 42), §2.11 step 8.
//
// The I/O loop must apply baud() to the port before writing what take_tx() returns.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>
#include <string_view>

#include "common/capacities.hpp"
#include "common/laser_geometry.hpp"
#include "common/time.hpp"
#include "drivers/lms200/codec.hpp"
#include "drivers/lms200/parser.hpp"
#include "drivers/lms200/scan.hpp"
#include "drivers/serial/endpoint.hpp"

namespace teamscan::lms200 {

struct LmsClientOptions {
  std::uint32_t target_baud = 500000;  // 500000, 38400, 19200 or 9600
  LaserVariant variant{180, 100};      // 180/1, 180/0.5, 100/1, 100/0.5, 100/0.25 (§2.5)
  bool set_config = true;              // read-modify-write the config block via setup mode
  Unit units = Unit::mm;               // config block E
  MeasuringMode measuring_mode = MeasuringMode::m8_fields_dazzle;  // config block D
  bool realtime_index = false;         // config block C bit 0x02
  std::string_view password = kSetupPassword;
  bool wait_for_power_on = false;      // start by listening at 9600 for the 0x90 (power just applied)
  Duration power_on_timeout = 65s;     // ARIA waits 65 s (§2.1); then probe
  Duration reset_timeout = 65s;        // 0x91 -> 0x90 (§2.10)
  Duration reply_timeout = 300ms;      // per request, plus the time a scan + reply take on the line
  Duration write_config_timeout = 20s; // 0x77 takes seconds (sicktoolbox 15 s, Player 25 s)
  Duration baud_settle = 50ms;         // host UART switched -> confirm (MRPT waits 250–500 ms)
  Duration silence_timeout = 500ms;    // streaming and no telegram for this long -> probe again
  Duration retry_backoff = 1s;         // after a refused step, before the next bring-up
  int retries = 2;                     // resends of a request that timed out or was NAKed
  bool drop_bad_status = true;         // §2.9: status class >= 3 or implausible -> scan not delivered
};

enum class LmsClientState : std::uint8_t {
  idle,              // before start()
  waiting_power_on,  // listening at 9600 for 0x90
  probing,           // 0x31 at each rate in turn
  stopping_stream,   // 0x20 25
  switching_baud,    // 0x20 4x
  confirming_baud,   // settle, then 0x31 at the new rate
  setting_variant,   // 0x3B
  reading_config,    // 0x74
  entering_setup,    // 0x20 00 "SICK_LMS"
  writing_config,    // 0x77
  starting_stream,   // 0x20 24
  streaming,
  waiting_reset,     // 0x91 seen: waiting for 0x90 at 9600
  backoff,           // a step was refused; bring-up again after retry_backoff
  stopping,          // shutdown: 0x20 25
  returning_baud,    // shutdown: 0x20 42
  stopped,           // shut down
  device_lost,       // the serial device is gone (on_device_lost)
};
[[nodiscard]] const char* to_string(LmsClientState state);

// When and how a scan arrived: the receive time of its last byte (the time passed to on_rx, less
// one byte time for every byte that followed it in that chunk) and what is needed to back-date it by
// the transmission time (DESIGN.md: a scan's stamp is the end of its sweep).
struct ScanArrival {
  Time last_byte;
  std::uint16_t telegram_bytes = 0;
  std::uint32_t baud = 0;
  LaserVariant variant{};
  [[nodiscard]] Duration transmission() const { return serial_transmission_time(telegram_bytes, baud); }
  [[nodiscard]] Time sweep_end_estimate() const { return last_byte - transmission(); }
};

class ScanSink {
 public:
  virtual ~ScanSink() = default;
  virtual void on_scan(const ScanTelegram& scan, const ScanArrival& arrival) = 0;
};

struct LmsClientStatistics {
  std::uint64_t scans = 0;               // delivered
  std::uint64_t scans_bad_status = 0;    // dropped by drop_bad_status
  std::uint64_t scans_overflow = 0;      // poll queue full: oldest dropped
  std::uint64_t decode_errors = 0;       // 0xB0 that did not decode
  std::uint64_t naks = 0;
  std::uint64_t incorrect_command = 0;   // 0x92 replies
  std::uint64_t timeouts = 0;
  std::uint64_t retries = 0;
  std::uint64_t probe_rounds = 0;
  std::uint64_t baud_switches = 0;
  std::uint64_t bringups = 0;            // reached streaming
  std::uint64_t scanner_resets = 0;      // 0x90/0x91 seen outside bring-up
  std::uint64_t silences = 0;            // silence_timeout hit while streaming
  std::uint64_t device_losses = 0;
  std::uint64_t refused = 0;             // a step refused (variant, password, config)
};

class LmsClient final : public serial::SerialEndpoint {
 public:
  explicit LmsClient(const LmsClientOptions& options = {});

  // Begins the bring-up at `now` (port opened at `baud()` = 9600).
  void start(Time now);
  // Stops the stream and returns the scanner to 9600; state() becomes `stopped` when done (or when
  // the scanner did not answer).
  void shutdown(Time now);
  void on_device_lost(Time now);
  void on_device_back(Time now);

  void on_rx(std::span<const std::uint8_t> bytes, Time now) override;
  void on_tick(Time now) override;
  std::size_t take_tx(std::span<std::uint8_t> out) override;
  [[nodiscard]] std::uint32_t baud() const override { return baud_; }
  [[nodiscard]] Time next_deadline() const override;

  // Scans: to the sink if one is set, else into a queue of kScanQueue (oldest dropped when full).
  void set_scan_sink(ScanSink* sink) { sink_ = sink; }
  [[nodiscard]] bool take_scan(ScanTelegram& scan, ScanArrival& arrival);
  static constexpr std::size_t kScanQueue = 4;

  [[nodiscard]] LmsClientState state() const { return state_; }
  [[nodiscard]] const char* state_name() const { return to_string(state_); }
  [[nodiscard]] bool streaming() const { return state_ == LmsClientState::streaming; }
  [[nodiscard]] const char* last_error() const { return last_error_; }
  [[nodiscard]] const LmsClientStatistics& statistics() const { return stats_; }
  [[nodiscard]] const LmsParserStatistics& parser_statistics() const { return parser_.statistics(); }
  [[nodiscard]] std::span<const std::uint8_t> device_config() const { return std::span{config_}.first(config_len_); }
  [[nodiscard]] MeasuringMode measuring_mode() const { return mode_; }

 private:
  void enter(LmsClientState s, Time now);
  void request(std::size_t n, std::uint8_t expect, Duration timeout, Time now);
  void resend(Time now);
  void step_failed(const char* why, Time now);
  void refused(const char* why, Time now);
  void handle_reply(const TelegramView& t, Time now);
  void handle_scan(const TelegramView& t, Time now);
  void start_probe(Time now);
  void probe_next(Time now);
  void set_baud(std::uint32_t baud);
  void after_variant(Time now);
  [[nodiscard]] bool config_needs_write() const;
  [[nodiscard]] Duration line_allowance() const;

  LmsClientOptions options_;
  LmsClientState state_ = LmsClientState::idle;
  Time now_{};
  std::uint32_t baud_ = 9600;
  std::uint32_t last_good_baud_ = 9600;
  LmsParser parser_{StreamDirection::from_device};
  // The outstanding request: its bytes (for resends), the reply code awaited, the deadline.
  std::array<std::uint8_t, 64> request_{};
  std::size_t request_len_ = 0;
  std::uint8_t expect_ = 0;
  bool waiting_ = false;
  Time deadline_{};
  Duration timeout_{};
  int retries_left_ = 0;
  // Probe: index into the rate list, and the generic state timer.
  std::size_t probe_index_ = 0;
  std::size_t probe_count_ = 0;
  Time timer_{};
  Time last_telegram_{};
  const char* last_error_ = "";
  // Configuration block as read (0x74), then modified.
  std::array<std::uint8_t, kMaxConfigBytes> config_{};
  std::size_t config_len_ = 0;
  MeasuringMode mode_ = MeasuringMode::m8_fields_dazzle;
  // Output.
  std::array<std::uint8_t, 2 * kMaxLmsTelegram> tx_{};
  std::size_t tx_len_ = 0;
  // Scan delivery.
  ScanSink* sink_ = nullptr;
  ScanTelegram decoded_{};
  std::array<ScanTelegram, kScanQueue> queue_{};
  std::array<ScanArrival, kScanQueue> arrivals_{};
  std::size_t queue_head_ = 0;
  std::size_t queue_size_ = 0;
  LmsClientStatistics stats_;
};

}  // namespace teamscan::lms200
