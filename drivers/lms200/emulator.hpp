// An emulated SICK LMS 200 (the device side of PROTOCOLS.md §2) as a sans-I/O SerialEndpoint: it
// answers every host command of §2.4, switches its own line rate, holds variant/config/mode state
// and streams 0xB0 telegrams paced by its line rate and the 75 Hz mirror (§2.10). Ranges come from a
// RangeSource the caller drives (the simulator ray-casts each beam at its own time).
//
// Streaming rule (documented for users of the emulator): the mirror completes one scan every
// R × 13.33 ms (R = 1, 2, 4 revolutions for 1°, 0.5°, 0.25°), counted from the 0x24 command. Every
// telegram occupies the line for its transmission time at baud() (10 bits a byte; with pace_output
// take_tx also releases bytes only at that rate). A scan telegram starts when its sweep ends if the
// line is free; whenever the line frees, the newest completed scan that was not yet sent is queued;
// scans that complete while a telegram is still on the line are superseded (counted as skipped).
// So at 500 kBd every scan is sent, at 38400 a 361-value stream gives about 5 scans/s (§2.10).
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

// What the range source is asked for: one scan whose last beam was measured at `sweep_end`; beam i
// was measured at sweep_end − variant.beam_age(i) (common/laser_geometry.hpp).
struct SweepTiming {
  Time sweep_end;
  LaserVariant variant;
  std::uint32_t scan_number = 0;
};

// One beam as the scanner measured it. A no-return is `invalid = over_range` (or any range above the
// mode's maximum); `flags` are the bits above the distance (mode 0: 1 field A, 2 field B, 4 dazzle).
struct BeamReading {
  std::uint32_t range_mm = 0;
  std::uint8_t flags = 0;
  BeamInvalid invalid = BeamInvalid::none;
};

// The hook the emulator calls once per sent scan; must not allocate (it runs on the stream path).
class RangeSource {
 public:
  virtual ~RangeSource() = default;
  // Fills beams[0 .. variant.beams()).
  virtual void measure(const SweepTiming& sweep, std::span<BeamReading> beams) = 0;
};

struct LmsEmulatorOptions {
  std::uint32_t power_up_baud = 9600;        // §2.1; also the rate after a reset unless 0x66 01 stored another
  bool send_power_on = false;                // send 0x90 `power_on_delay` after start (a real LMS: ~30 s)
  Duration power_on_delay = 0ms;
  Duration reset_delay = 2s;                 // 0x10 -> 0x91 at once, 0x90 at power_up_baud after this
  Duration write_config_delay = 0ms;         // a real 0x77 takes seconds (§2.4)
  LaserVariant variant{180, 100};
  std::uint8_t units = 0;                    // config block E at power-up: 0 cm (the LMS default), 1 mm, 2 dm
  std::uint8_t measuring_mode = 0;           // config block D
  std::size_t config_bytes = kConfigBytes;   // 32 (older firmware) or 34
  std::string_view type = "LMS200;30106";    // 0xBA and 0x90 text
  std::uint8_t status_byte = kHealthyStatus;
  // true: take_tx hands out bytes only once their 10 bits have been on the line (for a harness that
  // moves bytes instantly). false: everything at once, for links that pace by baud themselves
  // (serial::VirtualLink, serial::PtyRunner); the line-busy time still drives the streaming rule.
  bool pace_output = false;
};

struct LmsEmulatorStatistics {
  std::uint64_t commands = 0;
  std::uint64_t naks_sent = 0;
  std::uint64_t incorrect_commands = 0;
  std::uint64_t scans_sent = 0;
  std::uint64_t scans_skipped = 0;  // completed while the line was busy (superseded)
  std::uint64_t baud_switches = 0;
  std::uint64_t resets = 0;
};

class LmsEmulator final : public serial::SerialEndpoint {
 public:
  explicit LmsEmulator(const LmsEmulatorOptions& options = {}, RangeSource* ranges = nullptr);

  // Starts the device at `now` (power applied). Call once before the first on_tick.
  void power_up(Time now);

  void on_rx(std::span<const std::uint8_t> bytes, Time now) override;
  void on_tick(Time now) override;
  std::size_t take_tx(std::span<std::uint8_t> out) override;
  [[nodiscard]] std::uint32_t baud() const override { return baud_; }
  [[nodiscard]] Time next_deadline() const override;

  void set_range_source(RangeSource* ranges) { ranges_ = ranges; }
  // Reset by the test or the simulator as if the scanner restarted on its own (0x91 not sent).
  void spontaneous_reset(Time now);

  [[nodiscard]] bool streaming() const { return mode_ == OperatingMode::continuous && powered_; }
  [[nodiscard]] bool powered() const { return powered_; }
  [[nodiscard]] bool in_setup_mode() const { return setup_; }
  [[nodiscard]] LaserVariant variant() const { return variant_; }
  [[nodiscard]] std::uint8_t units() const { return config_[6]; }
  [[nodiscard]] std::uint8_t measuring_mode() const { return config_[5]; }
  [[nodiscard]] std::span<const std::uint8_t> config() const { return std::span{config_}.first(config_len_); }
  [[nodiscard]] const LmsEmulatorStatistics& statistics() const { return stats_; }
  [[nodiscard]] const LmsParserStatistics& parser_statistics() const { return parser_.statistics(); }
  [[nodiscard]] Duration scan_period() const { return kLmsRevolution * variant_.revolutions(); }

 private:
  void handle_telegram(const TelegramView& t);
  void handle_mode(std::span<const std::uint8_t> data);
  // Appends to the transmit queue; an idle line starts sending at max(earliest, line free).
  void queue(std::span<const std::uint8_t> bytes, Time earliest);
  void queue(std::span<const std::uint8_t> bytes) { queue(bytes, now_); }
  void queue_byte(std::uint8_t b) { queue(std::span{&b, 1}); }
  void queue_scan(Time sweep_end);
  void load_defaults();
  void finish_reset(Time now);
  [[nodiscard]] std::size_t pending_tx() const { return tx_end_ - tx_begin_; }
  [[nodiscard]] std::size_t sendable_now() const;

  LmsEmulatorOptions options_;
  RangeSource* ranges_;
  LmsParser parser_{StreamDirection::to_device};
  Time now_{};
  bool powered_ = false;
  Time power_on_due_{};
  bool power_on_pending_ = false;
  std::uint32_t baud_;
  std::uint32_t permanent_baud_;
  std::uint32_t pending_baud_ = 0;  // applied once the ACK and 0xA0 have left the line
  OperatingMode mode_ = OperatingMode::polled;
  bool nak_armed_ = true;           // one NAK per rejected telegram
  bool setup_ = false;
  LaserVariant variant_;
  std::array<std::uint8_t, kMaxConfigBytes> config_{};
  std::size_t config_len_;
  // Delayed 0xF7 reply (0x77 takes seconds on a real device).
  bool write_reply_pending_ = false;
  Time write_reply_due_{};
  bool write_accepted_ = false;
  // Continuous output: sweep grid and the newest sweep sent.
  Time stream_start_{};
  std::int64_t last_sent_sweep_ = -1;
  std::uint32_t scan_number_ = 0;
  // Transmit queue, paced: bytes of the current burst leave at baud/10 bytes per second.
  std::array<std::uint8_t, 4 * kMaxLmsTelegram> tx_{};
  std::size_t tx_begin_ = 0;
  std::size_t tx_end_ = 0;
  Time burst_start_{};
  std::int64_t burst_sent_ = 0;
  Time line_free_at_{};
  std::array<BeamReading, kMaxBeams> beams_{};
  std::array<std::uint16_t, kMaxBeams> words_{};
  std::array<std::uint8_t, kMaxLmsTelegram> scratch_{};
  LmsEmulatorStatistics stats_;
};

}  // namespace teamscan::lms200
