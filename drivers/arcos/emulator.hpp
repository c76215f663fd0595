// PioneerEmulator: the robot side of the ARCOS link as the firmware behaves (PROTOCOLS.md §1.4-§1.9),
// a sans-I/O serial::SerialEndpoint for in-process tests, the simulator and `teamscan emulate`.
// Answers SYNC0/1/2, restarts the handshake on an out-of-sequence SYNC, streams SIPs after OPEN,
// obeys the motion commands, stops the robot after the watchdog time without commands (§1.6) and
// tells its SIP source, so that a simulated world holds the robot still while its client is silent.
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

struct PioneerEmulatorOptions {
  std::string_view name = "teamscan";   // SYNC2 reply strings (§1.4)
  std::string_view robot_class = "Pioneer";
  std::string_view subclass = "p3at-sh"; // also selects DistConvFactor for the emulator's own pose
  std::uint32_t baud = 9600;
  Duration sip_period = 100ms;           // SipCycle (§1.7)
  Duration watchdog = 2000ms;            // no command for this long: motors stop (§1.6, AMRISim)
  bool motors_enabled_at_open = false;   // real robots need ENABLE 1 (§6, p2os#41)
  std::uint8_t battery_dv = 130;         // 13.0 V
  double ticks_per_mm = 30.0;            // ENCODERpac counts per mm of wheel travel (approximate)
  Duration inter_byte_timeout = 100ms;   // an incomplete command after this much silence is dropped
                                         // and its bytes re-scanned (a corrupted count must not stall
                                         // the receiver while the host sends little, §1.2)
};

// Lets code drive the SIP content (the simulator's wheel model). Called once per SIP cycle with the
// SIP the emulator built from its own state; the source overwrites what it models (XPOS/YPOS/THPOS
// raw counters, wheel velocities, stall, sonar...). Return false to skip this SIP.
class SipSource {
 public:
  virtual bool fill_sip(Time now, SipPacket& sip) = 0;
  // §1.6: the firmware stopped the robot at `since` (the last command + the watchdog time, or a CLOSE)
  // because its client went silent. A source that moves the robot (the simulator's world) holds it
  // still from `since` until on_client_back. Default: nothing.
  virtual void on_client_silent(Time since) { (void)since; }
  // A command arrived again at `at` (the client is back, or a new one opened the server).
  virtual void on_client_back(Time at) { (void)at; }

 protected:
  ~SipSource() = default;
};

// The raw SIP fields for a pose and wheel velocities, with the counters wrapped as on the wire
// (XPOS/YPOS modulo 2^16 of the DistConv count, read back with 15-bit masking, §1.10).
void fill_sip_motion(SipPacket& sip, const RobotParams& params, double x_mm, double y_mm, double th_rad,
                     double left_mm_s, double right_mm_s);

enum class PioneerState : std::uint8_t { kWaitSync0, kWaitSync1, kWaitSync2, kReady, kServerOpen };

struct PioneerEmulatorStatistics {
  std::uint64_t handshakes = 0;          // SYNC2 replies sent
  std::uint64_t handshake_restarts = 0;  // out-of-sequence SYNC
  std::uint64_t opens = 0, closes = 0;
  std::uint64_t commands = 0;            // decoded commands while the server is open
  std::uint64_t bad_commands = 0;
  std::uint64_t ignored_commands = 0;    // understood but not modelled (sonar, gripper, ...)
  std::uint64_t sips_sent = 0, configs_sent = 0, encoder_packets_sent = 0;
  std::uint64_t watchdog_stops = 0;       // commanded motion stopped by the watchdog
  std::uint64_t client_silences = 0;      // the client went silent (watchdog time or CLOSE): robot held
  std::uint64_t baud_changes = 0;        // HOSTBAUD obeyed
  std::uint64_t tx_overflows = 0;
  ArcosParserStatistics parser;
};

class PioneerEmulator final : public serial::SerialEndpoint {
 public:
  explicit PioneerEmulator(const PioneerEmulatorOptions& options = PioneerEmulatorOptions{});

  // serial::SerialEndpoint
  void on_rx(std::span<const std::uint8_t> bytes, Time now) override;
  void on_tick(Time now) override;
  std::size_t take_tx(std::span<std::uint8_t> out) override;
  [[nodiscard]] std::uint32_t baud() const override { return baud_; }
  [[nodiscard]] Time next_deadline() const override;

  void set_sip_source(SipSource* source) { source_ = source; }
  // The SIP that would go out at `now`: own state, then the source's fill — for the simulator.
  // Returns false when the source chose to skip this cycle (the packet is filled anyway).
  bool make_sip(Time now, SipPacket& sip);
  [[nodiscard]] SipPacket make_sip(Time now) {
    SipPacket s;
    (void)make_sip(now, s);
    return s;
  }

  // Sets the emulator's own odometry (mm, rad), e.g. to place the robot.
  void set_pose(double x_mm, double y_mm, double th_rad);
  // Models a power cycle: the server closes, handshake state and odometry reset.
  void power_cycle();

  [[nodiscard]] PioneerState state() const { return state_; }
  [[nodiscard]] bool server_open() const { return state_ == PioneerState::kServerOpen; }
  [[nodiscard]] bool motors_enabled() const { return motors_enabled_; }
  [[nodiscard]] double trans_vel_mm_s() const { return trans_mm_s_; }
  [[nodiscard]] double rot_vel_deg_s() const { return rad_to_deg(rot_rad_s_); }
  [[nodiscard]] double x_mm() const { return x_mm_; }
  [[nodiscard]] double y_mm() const { return y_mm_; }
  [[nodiscard]] double th_rad() const { return th_rad_; }
  [[nodiscard]] PioneerEmulatorStatistics statistics() const;
  [[nodiscard]] const RobotParams& params() const { return params_; }
  [[nodiscard]] Time last_command_time() const { return last_cmd_; }
  // True from the moment the client went silent (watchdog time without a command after an OPEN, or a
  // CLOSE) until its next command: the firmware holds the robot still (§1.6).
  [[nodiscard]] bool client_silent() const { return client_silent_; }
  [[nodiscard]] Time client_silent_since() const { return silent_since_; }

 private:
  void on_packet(const PacketView& p, Time now);
  void drain_parser(Time now);
  void server_command(const PacketView& p, Time now);
  void integrate(Time now);
  void send(const PacketBuffer& p);
  void stop_motion();
  void client_went_silent(Time since);
  void client_came_back(Time at);

  PioneerEmulatorOptions opt_;
  RobotParams params_;
  PioneerState state_ = PioneerState::kWaitSync0;
  std::uint32_t baud_;           // HOSTBAUD changes it for the connection; CLOSE restores opt_.baud
  std::uint32_t pending_baud_ = 0;  // applied once the bytes queued before it have been taken
  ArcosParser parser_;
  PioneerEmulatorStatistics stats_{};
  SipSource* source_ = nullptr;

  bool motors_enabled_ = false;
  double trans_mm_s_ = 0, rot_rad_s_ = 0;       // commanded, applied at once (no acceleration model)
  double x_mm_ = 0, y_mm_ = 0, th_rad_ = 0;     // own odometry
  double left_enc_ = 0, right_enc_ = 0;         // encoder counts (ticks)
  bool encoder_stream_ = false;
  Time last_integrate_;
  bool have_integrate_time_ = false;
  Time next_sip_;
  Time last_cmd_;
  Time last_rx_;
  bool client_silent_ = false;
  Time silent_since_;

  std::array<std::uint8_t, 8 * kMaxArcosPacket> tx_{};
  std::size_t tx_head_ = 0, tx_size_ = 0;
};

}  // namespace teamscan::arcos
