// The device side of the simulation in numbers: how a Pioneer 3-AT turns wheel motion into the
// SIP odometry fields (PROTOCOLS.md §1.8, §1.10, §1.11) and how an LMS-200 turns a true range into
// a measured value word (§2.7); plus the client-side decoding of both, as ARIA does it. The
// simulator's direct path goes through exactly these fields, so its points equal what a client
// decodes from the bytes of a SIP / 0xB0 telegram carrying the same fields.
#pragma once

#include <cstdint>
#include <string_view>

#include "common/pose.hpp"
#include "drivers/arcos/codec.hpp"
#include "sim/rng.hpp"

namespace teamscan::sim {

// ARCOS conversion factors of a Pioneer subclass (§1.11).
struct PioneerParams {
  double dist_conv_mm = 1.0;          // mm per XPOS/YPOS count: p3at 0.465, p3at-sh 1.0
  double angle_conv_rad = 0.001534;   // rad per THPOS count as the client decodes (ARIA's 0.001534)
  double diff_conv = 0.0034;          // DiffConvFactor: rot vel (rad/s) = (R − L) / 2 · diff_conv
};
[[nodiscard]] PioneerParams pioneer_params(std::string_view subclass);
[[nodiscard]] bool is_known_subclass(std::string_view subclass);

// The odometry fields of one standard SIP (§1.8) as the firmware reports them.
struct SipOdometry {
  std::uint16_t xpos = 0, ypos = 0;   // low 15 bits meaningful (§1.10)
  std::int16_t thpos = 0;             // 4096 counts per turn, in [-2048, 2047]
  std::int16_t left_vel_mmps = 0, right_vel_mmps = 0;
};

// Writes one SIP's odometry fields as the firmware sends them: position, wheel velocities, the
// motors-moving type (0x33 moving, 0x32 stopped) and, when the packet carries ROTVEL, the rotation in
// 0.1°/s from the wheel difference (PROTOCOLS.md §1.8; DiffConvFactor §1.11).
void fill_sip_odometry(const SipOdometry& o, arcos::SipPacket& sip, double diff_conv = PioneerParams{}.diff_conv);

// How a skid-steered Pioneer 3-AT's dead reckoning departs from the truth (sim/scenarios/README.md
// `[robot.odometry]`). Four wheels that must skid sideways to turn: the encoders see the wheels, not
// the ground. Systematic terms dominate (Borenstein & Feng's UMBmark): the wheels slip, so the
// encoders report more distance than was travelled (`slip`); on a turn the wheels skid, so the
// wheel difference over-states the rotation (`turn_slip`: the effective wheelbase is not the one the
// firmware's DiffConvFactor was calibrated for); unequal tyres turn the robot a little on every metre
// (`drift_rad_per_m`). Random terms: per-cycle jitter of distance and turn (`slip_sigma`,
// `heading_sigma`) and a random walk of the heading error with the distance (`heading_walk_*`: floor
// irregularities). Every random term draws from the robot's seeded odometry stream, only when on.
struct OdometryNoise {
  double slip_sigma = 0.0;             // relative σ of each SIP cycle's travelled distance
  double heading_sigma = 0.0;          // relative σ of each SIP cycle's heading change
  double drift_rad_per_m = 0.0;        // systematic heading drift per metre driven (sign = direction)
  double slip = 0.0;                   // systematic: reported distance = true distance · (1 + slip)
  double turn_slip = 0.0;              // systematic: reported heading change = true change · (1 + turn_slip)
  double heading_walk_rad_per_sqrt_m = 0.0;  // σ of the heading error's random walk after 1 m driven
};

// Firmware dead reckoning: integrates the (noisy) wheel motion between SIP cycles from a pose that
// starts at 0, 0, 0 when the client connects, and encodes it into SIP counters.
class PioneerOdometry {
 public:
  PioneerOdometry(PioneerParams params, OdometryNoise noise, Rng rng, const Pose2& true_start)
      : params_{params}, noise_{noise}, rng_{rng}, last_true_{true_start} {}

  // Advances to the true pose at the next SIP cycle, `dt_s` after the previous one.
  [[nodiscard]] SipOdometry step(const Pose2& true_pose, double dt_s);
  // The firmware's internal (unquantised) odometry pose.
  [[nodiscard]] const Pose2& internal_pose() const { return odom_; }

 private:
  PioneerParams params_;
  OdometryNoise noise_;
  Rng rng_;
  Pose2 last_true_;
  Pose2 odom_;
};

// Client-side decoding of SIP odometry as ARIA's processMotorPacket does (§1.10): 15-bit modular
// deltas of XPOS/YPOS accumulated, THPOS converted with AngleConvFactor; the first SIP initialises.
class OdometryDecoder {
 public:
  explicit OdometryDecoder(PioneerParams params) : params_{params} {}
  [[nodiscard]] Pose2 decode(const SipOdometry& sip);
  [[nodiscard]] double forward_velocity_mps(const SipOdometry& sip) const;
  [[nodiscard]] double yaw_rate_radps(const SipOdometry& sip) const;

 private:
  PioneerParams params_;
  bool initialised_ = false;
  std::uint16_t last_x_ = 0, last_y_ = 0;
  std::int64_t x_counts_ = 0, y_counts_ = 0;
};

// LMS-200 range values in mm mode, measuring mode 0x00 (§2.7): 13 distance bits; reserved codes.
inline constexpr std::uint16_t kLmsMaxRangeMm = 8182;       // largest valid distance in mm mode
inline constexpr std::uint16_t kLmsCodeTooFar = 0x1FF7;     // "value > maximum" (8183)
inline constexpr std::uint16_t kLmsCodeNotValid = 0x1FFF;   // no return / value not valid
inline constexpr std::uint16_t kLmsDistanceMask = 0x1FFF;

// The value word the scanner sends for a beam whose true range is `range_m` (hit = false: no return),
// with Gaussian range noise of `sigma_mm`, rounded to whole millimetres.
[[nodiscard]] std::uint16_t lms_value_word(bool hit, double range_m, double sigma_mm, Rng& rng);

// Client side: distance in mm from a value word, or 0 with the reason if it is a reserved code.
struct DecodedRange {
  bool valid = false;
  std::uint16_t range_mm = 0;
  std::uint16_t flags = 0;  // point_flags on invalid values
};
[[nodiscard]] DecodedRange decode_lms_value(std::uint16_t word);

}  // namespace teamscan::sim
