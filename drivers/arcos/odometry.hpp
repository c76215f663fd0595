// ARCOS odometry: robot parameters by SYNC2 subclass (PROTOCOLS.md §1.11), ARIA's 15-bit unwrap of
// XPOS/YPOS (§1.10) and client-side pose integration from SIP deltas. Pure, no allocation.
#pragma once

#include <cstdint>
#include <string_view>

#include "common/pose.hpp"
#include "common/result.hpp"
#include "common/time.hpp"
#include "drivers/arcos/codec.hpp"

namespace teamscan::arcos {

// Conversion factors of one robot type (ARIA params, §1.11).
struct RobotParams {
  std::string_view subclass = "p3at-sh";
  double dist_conv_mm = 1.0;            // DistConvFactor: mm per XPOS/YPOS unit
  double angle_conv_rad = 0.001534;     // AngleConvFactor: rad per THPOS unit (2π/4096)
  double vel_conv_mm_s = 1.0;           // VelConvFactor
  double range_conv_mm = 1.0;           // RangeConvFactor (sonar)
  double diff_conv_rad_per_mm = 0.0034; // DiffConvFactor: (R - L)/2 × this = rad/s
  int vel2_divisor_mm_s = 20;           // Vel2Divisor
  double max_velocity_mm_s = 1200.0;
  double max_rot_velocity_deg_s = 300.0;
};

// `p3at` (older P2OS/AROS controller, DistConv 0.465) and `p3at-sh` (ARCOS H8S/SH, DistConv 1.0).
// Any other subclass is an error: applying the wrong DistConvFactor silently scales every
// distance by 2.15 (§6, rosaria#47). The caller chooses: fail loudly, or the explicit fallback below.
[[nodiscard]] Result<RobotParams> params_for_subclass(std::string_view subclass);
// The documented fallback for unknown subclasses: the `p3at-sh` factors (every SH-controller
// Pioneer uses DistConv 1.0; p3at 0.465 is only the legacy controller), with `subclass` kept.
[[nodiscard]] RobotParams fallback_params(std::string_view subclass);

// ARIA's delta of two 15-bit position counters (§1.10): mask 0x7FFF, then fold |Δ| > 0x1000.
[[nodiscard]] constexpr std::int32_t unwrap15(std::uint16_t previous, std::uint16_t current) {
  std::int32_t d = static_cast<std::int32_t>(current & 0x7FFFU) - static_cast<std::int32_t>(previous & 0x7FFFU);
  if (d > 0x1000) d -= 0x8000;
  if (d < -0x1000) d += 0x8000;
  return d;
}

struct OdometryState {
  Pose2 pose;                  // integrated odometry pose (m, rad) in the robot's odometry frame
  double trans_vel_mm_s = 0;   // (L + R)/2
  double rot_vel_rad_s = 0;    // ROTVEL when the SIP has it, else (R - L)/2 × DiffConvFactor
  double left_vel_mm_s = 0, right_vel_mm_s = 0;
  Time stamp;                  // receive time of the SIP this state comes from
  std::uint64_t sips = 0;      // SIPs integrated since reset()
};

// Integrates SIPs as ARIA's processMotorPacket does: the first SIP initialises the pose to the
// SIP's own (converted) position; later SIPs add their unwrapped deltas. THPOS is absolute and
// not wrapped beyond the angle normalisation.
class Odometry {
 public:
  explicit Odometry(const RobotParams& params = RobotParams{}) : params_{params} {}
  void set_params(const RobotParams& params) { params_ = params; }
  [[nodiscard]] const RobotParams& params() const { return params_; }

  void update(const SipPacket& sip, Time received);
  // Forget everything: the next SIP initialises the pose again.
  void reset();
  // Keep the integrated pose but treat the next SIP as a new reference (after a reconnection the
  // robot's counters may have been reset by a power cycle; the pose continues where it was).
  void rebase();

  [[nodiscard]] const OdometryState& state() const { return state_; }

 private:
  RobotParams params_;
  OdometryState state_;
  bool have_reference_ = false;
  bool initialised_ = false;
  std::uint16_t last_x_ = 0, last_y_ = 0;
  std::int16_t last_th_ = 0;
};

}  // namespace teamscan::arcos
