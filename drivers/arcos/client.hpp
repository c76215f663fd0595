// ArcosClient: the host side of the ARCOS link as a sans-I/O state machine (serial::SerialEndpoint).
// Handshake SYNC0/1/2 with ARIA's retry and recovery logic, OPEN, ENABLE, keep-alive, velocity
// commands, SIP decoding and odometry, reconnection after silence or device loss (PROTOCOLS.md §1.4,
// §1.6, §6). No fd, no clock, no allocation: the I/O loop calls on_rx/on_tick/take_tx and applies
// baud() to the port before each take_tx (the client changes the rate while recovering, §1.4).
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>
#include <string_view>

#include "common/time.hpp"
#include "drivers/arcos/codec.hpp"
#include "drivers/arcos/odometry.hpp"
#include "drivers/arcos/parser.hpp"
#include "drivers/serial/endpoint.hpp"

namespace teamscan::arcos {

struct ArcosClientOptions {
  std::uint32_t baud = 9600;                 // the robot's host port rate (§1.1)
  Duration sync_reply_timeout = 1000ms;      // per SYNC echo, as ARIA (§1.4)
  int silent_tries_before_baud_cycle = 2;    // "nothing came back twice": CLOSE at every rate
  int silent_tries_before_dislodge = 4;      // "more than 3 silent tries": also OPEN(1)
  int max_silent_tries = 10;                 // then pause and start over (a daemon never gives up)
  int max_total_tries = 50;
  Duration retry_pause = 5s;                 // pause after giving up, before the next round
  Duration close_drain = 300ms;              // after CLOSE for a wrong reply: ignore input this long
  Duration baud_step = 50ms;                 // time spent at each rate of the CLOSE cycle
  std::array<std::uint32_t, 5> close_cycle_bauds = {9600, 38400, 115200, 19200, 57600};  // ARIA's order
  bool enable_motors = true;                 // ENABLE 1 after OPEN (allenh1/p2os#41, §6)
  bool request_config = false;               // CONFIG 1 after OPEN; never waited for (§6)
  Duration keep_alive_period = 500ms;        // PULSE or the motion command re-sent (§1.6)
  Duration first_sip_timeout = 2000ms;       // OPEN sent, no SIP: reconnect
  Duration sip_timeout = 1000ms;             // connected, no SIP for this long (10 cycles): reconnect
  Duration motion_command_timeout = 0ns;     // host-side timeout: 0 = off, else STOP when the host
                                             // has not refreshed its velocity (rosaria#51, §6)
  Duration inter_byte_timeout = 100ms;       // a packet still incomplete after this much silence is
                                             // abandoned and its bytes re-scanned (ARIA's receiver, §1.2)
  std::string_view subclass_override{};      // non-empty: use these parameters, not SYNC2's
  bool allow_unknown_subclass = true;        // unknown subclass: p3at-sh fallback (counted) vs. refuse
};

enum class ArcosClientState : std::uint8_t {
  kIdle,          // not started (first on_tick starts)
  kSyncing,       // SYNC0/1/2 sent, waiting for the echo
  kClosingStale,  // wrong reply: CLOSE sent, ignoring input for close_drain
  kBaudCycle,     // silent robot: sending CLOSE at each rate in turn
  kPaused,        // gave up a round; starts over after retry_pause
  kOpening,       // OPEN sent, waiting for the first SIP
  kConnected,     // SIPs flowing
  kDeviceLost,    // the I/O loop reported the device gone
  kShutdown,      // CLOSE sent on request; nothing more until start()
};
[[nodiscard]] const char* to_string(ArcosClientState s);

struct ArcosClientStatistics {
  std::uint64_t handshakes_started = 0;
  std::uint64_t sync_timeouts = 0;        // silent tries
  std::uint64_t wrong_replies = 0;        // unexpected packet type during the handshake
  std::uint64_t baud_cycles = 0;
  std::uint64_t dislodge_opens = 0;
  std::uint64_t give_ups = 0;             // rounds abandoned (10 silent / 50 total)
  std::uint64_t connects = 0;
  std::uint64_t silence_reconnects = 0;   // no SIP for sip_timeout / first_sip_timeout
  std::uint64_t device_losses = 0;
  std::uint64_t unknown_subclass = 0;
  std::uint64_t sips = 0;
  std::uint64_t bad_sips = 0;             // verified packets of SIP type that did not decode
  std::uint64_t configs = 0;
  std::uint64_t encoder_packets = 0;
  std::uint64_t other_packets = 0;
  std::uint64_t keep_alives = 0;
  std::uint64_t commands_sent = 0;
  std::uint64_t tx_overflows = 0;         // commands dropped because take_tx was not called
  std::uint64_t motion_timeouts = 0;
  ArcosParserStatistics parser;
};

// Called for every decoded SIP (allocation-free callback: function pointer + context).
using SipCallback = void (*)(void* context, const SipPacket& sip, const OdometryState& odometry, Time received);

class ArcosClient final : public serial::SerialEndpoint {
 public:
  explicit ArcosClient(const ArcosClientOptions& options = ArcosClientOptions{});

  // serial::SerialEndpoint
  void on_rx(std::span<const std::uint8_t> bytes, Time now) override;
  void on_tick(Time now) override;
  std::size_t take_tx(std::span<std::uint8_t> out) override;
  [[nodiscard]] std::uint32_t baud() const override { return baud_; }
  [[nodiscard]] Time next_deadline() const override;

  // Host commands. Velocities are sent at once when connected and re-sent as the keep-alive.
  void set_velocity(double trans_mm_s, double rot_deg_s, Time now);    // VEL + RVEL
  void set_wheel_velocities(double left_mm_s, double right_mm_s, Time now);  // VEL2
  void stop(Time now);                                                 // STOP; keep-alive becomes PULSE
  // Any other command (SONAR, SETO, BUMPSTALL...). False if not connected or the tx queue is full.
  bool send_command(const PacketBuffer& packet, Time now);

  void shutdown(Time now);   // STOP + CLOSE(1), then silent until start()
  void start(Time now);      // (re)start the handshake
  void on_device_lost(Time now);
  void on_device_back(Time now);

  void set_sip_callback(SipCallback cb, void* context) { sip_cb_ = cb; sip_ctx_ = context; }

  [[nodiscard]] ArcosClientState state() const { return state_; }
  [[nodiscard]] bool connected() const { return state_ == ArcosClientState::kConnected; }
  [[nodiscard]] ArcosClientStatistics statistics() const;
  [[nodiscard]] const SipPacket& latest_sip() const { return latest_sip_; }
  [[nodiscard]] Time latest_sip_time() const { return odometry_.state().stamp; }
  [[nodiscard]] const OdometryState& odometry() const { return odometry_.state(); }
  [[nodiscard]] const Sync2Reply& identity() const { return identity_; }
  [[nodiscard]] const RobotParams& params() const { return odometry_.params(); }
  [[nodiscard]] bool have_config() const { return have_config_; }
  [[nodiscard]] const ConfigPacket& config() const { return config_; }
  [[nodiscard]] const EncoderPacket& latest_encoder() const { return encoder_; }
  [[nodiscard]] const char* last_error() const { return last_error_; }

 private:
  enum class MotionKind : std::uint8_t { kNone, kVelRvel, kVel2 };

  void begin_handshake(Time now, bool reset_counters);
  void send_sync(Time now);
  void on_packet(const PacketView& p, Time now);
  void handshake_packet(const PacketView& p, Time now);
  void silent_try(Time now);
  void give_up(Time now);
  void connected_packet(const PacketView& p, Time now);
  void send_motion(Time now);
  bool queue(const PacketBuffer& p, Time now);
  void recompute_deadline();
  void drain_parser(Time now);

  ArcosClientOptions opt_;
  ArcosClientState state_ = ArcosClientState::kIdle;
  std::uint32_t baud_;
  ArcosParser parser_;
  Odometry odometry_;
  ArcosClientStatistics stats_{};

  // handshake
  std::uint8_t sync_step_ = 0;
  int silent_tries_ = 0, total_tries_ = 0;
  std::size_t baud_index_ = 0;
  bool dislodge_ = false;
  Time step_deadline_;   // the state's own timer (echo timeout, drain end, pause end, ...)

  // connection
  Time last_tx_;
  Time last_rx_;
  Time last_sip_rx_;
  Time last_motion_cmd_;
  MotionKind motion_ = MotionKind::kNone;
  double trans_mm_s_ = 0, rot_deg_s_ = 0, left_mm_s_ = 0, right_mm_s_ = 0;
  Time deadline_;

  SipPacket latest_sip_{};
  Sync2Reply identity_{};
  ConfigPacket config_{};
  bool have_config_ = false;
  EncoderPacket encoder_{};
  const char* last_error_ = "";
  SipCallback sip_cb_ = nullptr;
  void* sip_ctx_ = nullptr;

  // tx queue: whole packets, bytes in order
  std::array<std::uint8_t, 4 * kMaxArcosPacket> tx_{};
  std::size_t tx_head_ = 0, tx_size_ = 0;
};

}  // namespace teamscan::arcos
