// ARCOS (Pioneer 3-AT) packet codec: checksum, command builders into fixed buffers, and encoders/
// decoders for the robot's packets (SYNC2 reply, SIP 0x32/0x33, CONFIGpac 0x20, ENCODERpac 0x90).
// Pure and allocation-free (STYLE.md 1, 5). Layouts: PROTOCOLS.md §1.2-§1.9.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>
#include <string_view>

#include "common/capacities.hpp"
#include "common/result.hpp"

namespace teamscan::arcos {

// §1.2 framing.
inline constexpr std::uint8_t kHeader0 = 0xFA;
inline constexpr std::uint8_t kHeader1 = 0xFB;
inline constexpr std::size_t kMinCount = 3;                       // type byte + 2 checksum bytes
inline constexpr std::size_t kMaxCount = kMaxArcosPacket - 3;     // the count is one byte: 255
inline constexpr std::size_t kMaxBody = kMaxCount - 2;            // type byte + data: 253

// §1.3 argument type bytes.
inline constexpr std::uint8_t kArgPositive = 0x3B;
inline constexpr std::uint8_t kArgNegative = 0x1B;
inline constexpr std::uint8_t kArgString = 0x2B;

// §1.5 command numbers (client -> robot). SYNC0/1/2 share numbers with PULSE/OPEN/CLOSE (§1.4).
enum class Command : std::uint8_t {
  kPulse = 0, kSync0 = 0, kOpen = 1, kSync1 = 1, kClose = 2, kSync2 = 2, kPolling = 3, kEnable = 4,
  kSetA = 5, kSetV = 6, kSetO = 7, kMove = 8, kRotate = 9, kSetRv = 10, kVel = 11, kHead = 12,
  kDHead = 13, kSay = 15, kJoyInfo = 17, kConfig = 18, kEncoder = 19, kRVel = 21, kSetRa = 23,
  kSonar = 28, kStop = 29, kDigOut = 30, kVel2 = 32, kGripper = 33, kIoRequest = 40,
  kBumpStall = 44, kJoyDrive = 47, kSonarCycle = 48, kHostBaud = 50, kEStop = 55, kGyro = 58,
  kBatteryInfo = 62, kRevCount = 88, kDriftFactor = 89, kTicksMm = 93,
};

// §1.7 packet types (robot -> client).
enum class PacketType : std::uint8_t {
  kSync0 = 0x00, kSync1 = 0x01, kSync2 = 0x02, kConfig = 0x20, kSipStopped = 0x32,
  kSipMoving = 0x33, kEncoder = 0x90, kSerAux = 0xB0, kSerAux2 = 0xB8, kGyro = 0x98, kIo = 0xF0,
};

[[nodiscard]] constexpr bool is_sip_type(std::uint8_t type) { return type == 0x32 || type == 0x33; }

// §1.2 checksum over `body` = the bytes from the type byte up to (not including) the checksum:
// big-endian 16-bit words summed mod 2^16, an odd last byte XORed into the low half.
[[nodiscard]] std::uint16_t checksum(std::span<const std::uint8_t> body);

// One complete packet on the wire (FA FB count body chk_hi chk_lo), in a fixed buffer.
struct PacketBuffer {
  std::array<std::uint8_t, kMaxArcosPacket> bytes{};
  std::size_t size = 0;
  [[nodiscard]] std::span<const std::uint8_t> span() const { return {bytes.data(), size}; }
};

// A verified packet: its type/command byte and the data after it (checksum excluded). Points into
// the buffer it was parsed from.
struct PacketView {
  std::uint8_t type = 0;
  std::span<const std::uint8_t> data;
  std::span<const std::uint8_t> wire;  // the whole packet, header to checksum
};

// Checks one complete packet (header, count = size - 3 >= 3, checksum) and returns its view.
[[nodiscard]] Result<PacketView> verify_packet(std::span<const std::uint8_t> wire);

// Builds a body into a PacketBuffer; finish() writes header, count and checksum. Appends past
// kMaxBody set an overflow flag, and finish() then fails (a programming error in the caller's sizes).
class PacketWriter {
 public:
  explicit PacketWriter(std::uint8_t type);
  void u8(std::uint8_t v);
  void u16(std::uint16_t v);  // little endian (§1.2)
  void s16(std::int16_t v) { u16(static_cast<std::uint16_t>(v)); }
  void u32(std::uint32_t v);
  void s32(std::int32_t v) { u32(static_cast<std::uint32_t>(v)); }
  void bytes(std::span<const std::uint8_t> b);
  void cstr(std::string_view s);  // the characters, then a NUL (§1.4 SYNC2 reply, §1.9 strings)
  [[nodiscard]] bool overflow() const { return overflow_; }
  [[nodiscard]] PacketBuffer finish() const;

 private:
  PacketBuffer buf_{};
  std::size_t body_size_ = 0;
  bool overflow_ = false;
};

// ---- client -> robot commands (§1.3, §1.5) ----

// A command without argument (N = 3): SYNC0/1/2, PULSE, OPEN, CLOSE, STOP, ...
[[nodiscard]] PacketBuffer make_command(Command c);
// A command with an int argument: 0x3B + magnitude LE for >= 0, 0x1B + magnitude LE for < 0 (§1.3).
// The magnitude is 16 bits: values beyond ±65535 are clamped (they are meaningless to ARCOS).
[[nodiscard]] PacketBuffer make_command(Command c, std::int32_t value);
// A command with a string argument: 0x2B, length byte, the bytes (no NUL, as p2os; §1.3).
// Strings longer than the packet allows are truncated.
[[nodiscard]] PacketBuffer make_command_string(Command c, std::span<const std::uint8_t> s);
// A command followed by a bare argument type byte, e.g. SETO as `07 3B` (A13, §1.3).
[[nodiscard]] PacketBuffer make_command_type_only(Command c, std::uint8_t arg_type = kArgPositive);

inline constexpr int kVel2DivisorMmS = 20;  // §1.11 Vel2Divisor
// VEL2 argument word: high byte left, low byte right, each a signed byte in units of the divisor,
// rounded to nearest and clamped to [-128, 127]; the word is then an ordinary signed int (§1.5).
[[nodiscard]] std::int32_t vel2_argument(double left_mm_s, double right_mm_s, int divisor_mm_s = kVel2DivisorMmS);
[[nodiscard]] PacketBuffer make_vel2(double left_mm_s, double right_mm_s, int divisor_mm_s = kVel2DivisorMmS);
// Splits a decoded VEL2 int back into wheel speeds (mm/s).
void vel2_split(std::int32_t argument, int divisor_mm_s, double& left_mm_s, double& right_mm_s);

// A decoded client command (what the robot side sees).
struct CommandPacket {
  enum class Arg : std::uint8_t { kNone, kInt, kString, kTypeOnly };
  std::uint8_t command = 0;
  Arg arg = Arg::kNone;
  std::int32_t value = 0;                    // kInt: the signed value (0x1B negates)
  std::uint8_t arg_type = 0;                 // the type byte when there is one
  std::span<const std::uint8_t> string;      // kString: the counted bytes
};
// Fails on an unknown argument type byte or a truncated argument.
[[nodiscard]] Result<CommandPacket> decode_command(const PacketView& p);

// ---- robot -> client packets ----

// Fixed NUL-terminated string of the robot's identity strings (§1.4, §1.9).
inline constexpr std::size_t kMaxIdString = 32;
struct IdString {
  std::array<char, kMaxIdString> chars{};  // always NUL-terminated
  void assign(std::string_view s);
  [[nodiscard]] std::string_view view() const;
};

// SYNC2 reply, packet type 2: name, class, subclass, each NUL-terminated (§1.4 step 3).
struct Sync2Reply {
  IdString name, robot_class, subclass;
};
[[nodiscard]] PacketBuffer encode_sync2_reply(const Sync2Reply& r);
// Accepts a missing final NUL and missing trailing strings (fields stay empty).
[[nodiscard]] Result<Sync2Reply> decode_sync2_reply(const PacketView& p);

// §1.8 SIP. Raw wire values; conversion to SI is odometry.hpp's job.
inline constexpr std::size_t kMaxSonarReadings = (kMaxBody - 20) / 3;  // what fits in one packet

struct SonarReading {
  std::uint8_t number = 0;
  std::uint16_t range = 0;  // × RangeConvFactor (1.0) -> mm
};

// The optional tail of a SIP, in wire order (§1.8). A SIP carries a prefix of these.
enum class SipField : std::uint8_t {
  kGripState, kAnPort, kAnalog, kDigIn, kDigOut, kBatteryX10, kChargeState, kRotVel, kFaultFlags,
  kLatVel, kTemperature, kStateOfCharge, kMicroTime, kFlags3,
};
inline constexpr std::uint8_t kSipTailFieldCount = 14;

struct SipPacket {
  std::uint8_t type = 0x32;        // 0x32 motors stopped, 0x33 moving
  std::uint16_t x_raw = 0;         // XPOS as sent (16 bits); the low 15 bits count (§1.10)
  std::uint16_t y_raw = 0;
  std::int16_t th_raw = 0;         // × AngleConvFactor -> rad
  std::int16_t left_vel = 0;       // × VelConvFactor -> mm/s
  std::int16_t right_vel = 0;
  std::uint8_t battery_dv = 0;     // 0.1 V
  std::uint16_t stall_bumpers = 0; // bit 0 left stall, 1-7 rear bumpers, 8 right stall, 9-15 front
  std::int16_t control = 0;        // heading set-point, THPOS units
  std::uint16_t flags = 0;         // bit 0 motors enabled, 1-4 sonar arrays, 5 e-stop, ...
  std::uint8_t compass = 0;        // 2-degree units
  std::uint8_t sonar_count = 0;
  std::array<SonarReading, kMaxSonarReadings> sonar{};
  // Tail: the first `tail_fields` fields of SipField are present.
  std::uint8_t tail_fields = 0;
  std::uint8_t grip_state = 0, an_port = 0, analog = 0, dig_in = 0, dig_out = 0;
  std::uint16_t battery_x10 = 0;   // 0.1 V
  std::uint8_t charge_state = 255; // 255 = unknown when absent (ARIA)
  std::int16_t rot_vel = 0;        // 0.1 deg/s
  std::uint16_t fault_flags = 0;
  std::int16_t lat_vel = 0;        // mm/s
  std::int8_t temperature_c = -127;
  std::uint8_t state_of_charge = 0;
  std::uint32_t micro_time_us = 0;
  std::uint32_t flags3 = 0;
  std::uint16_t trailing_bytes = 0;  // bytes after the last field we know (decoder only)

  [[nodiscard]] bool has(SipField f) const { return static_cast<std::uint8_t>(f) < tail_fields; }
  [[nodiscard]] bool left_stall() const { return (stall_bumpers & 0x0001U) != 0; }
  [[nodiscard]] bool right_stall() const { return (stall_bumpers & 0x0100U) != 0; }
  [[nodiscard]] std::uint8_t rear_bumpers() const { return static_cast<std::uint8_t>((stall_bumpers >> 1) & 0x7FU); }
  [[nodiscard]] std::uint8_t front_bumpers() const { return static_cast<std::uint8_t>((stall_bumpers >> 9) & 0x7FU); }
  [[nodiscard]] bool motors_enabled() const { return (flags & 0x0001U) != 0; }
  [[nodiscard]] bool estop() const { return (flags & 0x0020U) != 0; }
};

// Writes the fixed part, min(sonar_count, capacity) readings and the first tail_fields tail fields.
[[nodiscard]] PacketBuffer encode_sip(const SipPacket& s);
// Accepts short SIPs: the tail fields present are those whose bytes are complete (ARIA reads each
// only if bytes remain). Fails if the fixed part or the announced sonar readings are truncated.
[[nodiscard]] Result<SipPacket> decode_sip(const PacketView& p);

// §1.9 CONFIGpac 0x20. Every field in wire order; `fields_present` counts how many were complete.
struct ConfigPacket {
  IdString robot_class, subclass, serial_number;
  std::uint8_t four_mots = 0;
  std::uint16_t rot_vel_top = 0, trans_vel_top = 0, rot_acc_top = 0, trans_acc_top = 0, pwm_max = 0;
  IdString name;
  std::uint8_t sip_cycle_ms = 0, host_baud = 0, aux1_baud = 0;
  std::uint16_t has_gripper = 0, front_sonar = 0;
  std::uint8_t rear_sonar = 0;
  std::uint16_t low_battery = 0, rev_count = 0, watchdog_ms = 0;
  std::uint8_t normal_mpacs = 0;
  std::uint16_t stall_val = 0, stall_count = 0, joy_vel = 0, joy_rot_vel = 0, rot_vel_max = 0,
                trans_vel_max = 0, rot_accel = 0, rot_decel = 0, rot_kp = 0, rot_kv = 0, rot_ki = 0,
                trans_accel = 0, trans_decel = 0, trans_kp = 0, trans_kv = 0, trans_ki = 0;
  std::uint8_t front_bumps = 0, rear_bumps = 0, has_charger = 0, sonar_cycle = 0, autobaud = 0,
               gyro_type = 0;
  std::int16_t drift_factor = 0;
  std::uint8_t aux2_baud = 0, aux3_baud = 0;
  std::uint16_t ticks_mm = 0, shutdown_voltage = 0;
  IdString firmware_version;
  std::uint16_t gyro_cw = 0, gyro_ccw = 0;
  std::uint8_t kinematics_delay = 0;
  std::uint16_t lat_vel_top = 0, lat_acc_top = 0, lat_vel_max = 0, lat_accel = 0, lat_decel = 0,
                powerbot_charge_threshold = 0;
  std::uint8_t pdb_port = 0;
  std::uint16_t gyro_rate_limit = 0;
  std::int8_t high_temp_shutdown = 0;
  std::uint16_t power_bits = 0;
  std::uint8_t battery_type = 0;
  std::uint16_t soc_low = 0, soc_shutdown = 0;
  IdString bootloader_version;
  std::uint32_t config_flags = 0;
  std::int16_t gyro_fw_version = 0;

  std::uint16_t fields_present = 0;  // decoder: complete fields read, in wire order
  [[nodiscard]] bool complete() const;  // every field up to GyroRateLimit (the non-optional part)
};
inline constexpr std::uint16_t kConfigRequiredFields = 59;  // class .. GyroRateLimit
inline constexpr std::uint16_t kConfigAllFields = 67;       // + the optional tail

// Encodes the first `fields` fields (default all).
[[nodiscard]] PacketBuffer encode_config(const ConfigPacket& c, std::uint16_t fields = kConfigAllFields);
// Never fails on truncation (§6: a P3DX-SH sends a CONFIGpac that fails; the connection must not
// depend on it): reads as many complete fields as there are. Fails only on a wrong packet type.
[[nodiscard]] Result<ConfigPacket> decode_config(const PacketView& p);

// ENCODERpac 0x90: raw left and right encoder counts, int32 LE each (§1.7).
struct EncoderPacket {
  std::int32_t left = 0, right = 0;
};
[[nodiscard]] PacketBuffer encode_encoder(const EncoderPacket& e);
[[nodiscard]] Result<EncoderPacket> decode_encoder(const PacketView& p);

}  // namespace teamscan::arcos
