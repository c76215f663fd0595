// Pioneer odometry counters and LMS-200 value words, device and client side (devices.hpp).
#include "sim/devices.hpp"

#include <cmath>

#include "common/dataset/dataset.hpp"

namespace teamscan::sim {

PioneerParams pioneer_params(std::string_view subclass) {
  PioneerParams p;
  p.dist_conv_mm = subclass == "p3at" ? 0.465 : 1.0;
  return p;
}

bool is_known_subclass(std::string_view subclass) { return subclass == "p3at" || subclass == "p3at-sh"; }

SipOdometry PioneerOdometry::step(const Pose2& true_pose, double dt_s) {
  // True motion since the last cycle, in the robot frame of the last pose: forward distance along
  // the mean heading (the wheels of a skid-steer base move along its heading) and heading change.
  const double dtheta = normalize_angle(true_pose.theta_rad - last_true_.theta_rad);
  const double mean_heading = last_true_.theta_rad + 0.5 * dtheta;
  const double dx = true_pose.x_m - last_true_.x_m, dy = true_pose.y_m - last_true_.y_m;
  const double ds = dx * std::cos(mean_heading) + dy * std::sin(mean_heading);
  last_true_ = true_pose;

  // Wheel slip and drift (seeded): what the encoders report, not what happened.
  // Systematic terms first (OdometryNoise), then the random ones; a random term draws only when on,
  // so adding one never shifts the others' streams.
  double ds_meas = ds * (1.0 + noise_.slip), dtheta_meas = dtheta * (1.0 + noise_.turn_slip);
  if (noise_.slip_sigma > 0) ds_meas *= 1.0 + noise_.slip_sigma * rng_.normal();
  if (noise_.heading_sigma > 0) dtheta_meas *= 1.0 + noise_.heading_sigma * rng_.normal();
  dtheta_meas += noise_.drift_rad_per_m * std::abs(ds_meas);
  if (noise_.heading_walk_rad_per_sqrt_m > 0 && ds != 0.0)
    dtheta_meas += noise_.heading_walk_rad_per_sqrt_m * std::sqrt(std::abs(ds)) * rng_.normal();

  const double heading_mid = odom_.theta_rad + 0.5 * dtheta_meas;
  odom_.x_m += ds_meas * std::cos(heading_mid);
  odom_.y_m += ds_meas * std::sin(heading_mid);
  odom_.theta_rad = normalize_angle(odom_.theta_rad + dtheta_meas);

  SipOdometry sip;
  // XPOS/YPOS: the firmware's counters wrap; only the low 15 bits are meaningful (§1.10).
  const auto x_counts = static_cast<std::int64_t>(std::llround(odom_.x_m * 1000.0 / params_.dist_conv_mm));
  const auto y_counts = static_cast<std::int64_t>(std::llround(odom_.y_m * 1000.0 / params_.dist_conv_mm));
  sip.xpos = static_cast<std::uint16_t>(x_counts & 0x7FFF);
  sip.ypos = static_cast<std::uint16_t>(y_counts & 0x7FFF);
  // THPOS: the firmware keeps 4096 counts per turn (§1.8: 2π/4096 rad per count).
  auto th = static_cast<std::int64_t>(std::llround(odom_.theta_rad * 4096.0 / (2.0 * kPi)));
  if (th >= 2048) th -= 4096;
  if (th < -2048) th += 4096;
  sip.thpos = static_cast<std::int16_t>(th);
  // Wheel velocities: v ∓ w / DiffConvFactor (ARIA: w = (R − L) / 2 · DiffConvFactor).
  const double v_mmps = dt_s > 0 ? ds_meas * 1000.0 / dt_s : 0.0;
  const double w_radps = dt_s > 0 ? dtheta_meas / dt_s : 0.0;
  sip.left_vel_mmps = static_cast<std::int16_t>(std::lround(v_mmps - w_radps / params_.diff_conv));
  sip.right_vel_mmps = static_cast<std::int16_t>(std::lround(v_mmps + w_radps / params_.diff_conv));
  return sip;
}

Pose2 OdometryDecoder::decode(const SipOdometry& sip) {
  const std::uint16_t x = sip.xpos & 0x7FFF, y = sip.ypos & 0x7FFF;
  if (!initialised_) {
    // First SIP: the counters as signed 15-bit values.
    x_counts_ = x >= 0x4000 ? static_cast<std::int64_t>(x) - 0x8000 : x;
    y_counts_ = y >= 0x4000 ? static_cast<std::int64_t>(y) - 0x8000 : y;
    initialised_ = true;
  } else {
    // ARIA's wrap rule: a step above +0x1000 wrapped backwards, below −0x1000 forwards.
    auto delta = [](std::uint16_t now, std::uint16_t before) {
      std::int64_t d = static_cast<std::int64_t>(now) - static_cast<std::int64_t>(before);
      if (d > 0x1000) {
        d -= 0x8000;
      } else if (d < -0x1000) {
        d += 0x8000;
      }
      return d;
    };
    x_counts_ += delta(x, last_x_);
    y_counts_ += delta(y, last_y_);
  }
  last_x_ = x;
  last_y_ = y;
  return {static_cast<double>(x_counts_) * params_.dist_conv_mm * 1e-3,
          static_cast<double>(y_counts_) * params_.dist_conv_mm * 1e-3,
          normalize_angle(static_cast<double>(sip.thpos) * params_.angle_conv_rad)};
}

double OdometryDecoder::forward_velocity_mps(const SipOdometry& sip) const {
  return 0.5 * (sip.left_vel_mmps + sip.right_vel_mmps) * 1e-3;
}

double OdometryDecoder::yaw_rate_radps(const SipOdometry& sip) const {
  return 0.5 * (sip.right_vel_mmps - sip.left_vel_mmps) * params_.diff_conv;
}

std::uint16_t lms_value_word(bool hit, double range_m, double sigma_mm, Rng& rng) {
  if (!hit) return kLmsCodeNotValid;
  double range_mm = range_m * 1000.0;
  if (sigma_mm > 0) range_mm += sigma_mm * rng.normal();
  const long rounded = std::lround(range_mm);
  if (rounded < 0) return 0;
  if (rounded > kLmsMaxRangeMm) return kLmsCodeTooFar;
  return static_cast<std::uint16_t>(rounded);
}

DecodedRange decode_lms_value(std::uint16_t word) {
  const auto distance = static_cast<std::uint16_t>(word & kLmsDistanceMask);
  DecodedRange r;
  if (distance == kLmsCodeTooFar) {
    r.flags = point_flags::kOutOfRange | point_flags::kInvalid;
  } else if (distance == 0x1FFE) {
    r.flags = point_flags::kDazzled | point_flags::kInvalid;
  } else if (distance > kLmsMaxRangeMm || distance == 0) {
    r.flags = point_flags::kInvalid;  // not valid, overflow, S/N too small, channel error, no echo
  } else {
    r.valid = true;
    r.range_mm = distance;
  }
  return r;
}

void fill_sip_odometry(const SipOdometry& o, arcos::SipPacket& sip, double diff_conv) {
  sip.x_raw = o.xpos;
  sip.y_raw = o.ypos;
  sip.th_raw = o.thpos;
  sip.left_vel = o.left_vel_mmps;
  sip.right_vel = o.right_vel_mmps;
  sip.type = (o.left_vel_mmps != 0 || o.right_vel_mmps != 0) ? 0x33 : 0x32;
  if (sip.has(arcos::SipField::kRotVel)) {
    const double w_rad_s = 0.5 * (o.right_vel_mmps - o.left_vel_mmps) * diff_conv;
    sip.rot_vel = static_cast<std::int16_t>(std::lround(rad_to_deg(w_rad_s) * 10.0));
  }
}

}  // namespace teamscan::sim
