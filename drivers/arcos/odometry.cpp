// ARCOS odometry (PROTOCOLS.md §1.10, §1.11); see odometry.hpp.
#include "drivers/arcos/odometry.hpp"

namespace teamscan::arcos {

Result<RobotParams> params_for_subclass(std::string_view subclass) {
  RobotParams p;
  if (subclass == "p3at") {
    p.subclass = "p3at";
    p.dist_conv_mm = 0.465;
    return p;
  }
  if (subclass == "p3at-sh") {
    p.subclass = "p3at-sh";
    p.dist_conv_mm = 1.0;
    return p;
  }
  return Error{"arcos: no parameters for this robot subclass (known: p3at, p3at-sh)"};
}

RobotParams fallback_params(std::string_view subclass) {
  RobotParams p;  // the p3at-sh factors
  p.subclass = subclass;
  return p;
}

void Odometry::reset() {
  state_ = OdometryState{};
  have_reference_ = false;
  initialised_ = false;
}

void Odometry::rebase() { have_reference_ = false; }

void Odometry::update(const SipPacket& sip, Time received) {
  const double dist = params_.dist_conv_mm;
  if (!initialised_) {
    state_.pose.x_m = mm_to_m(static_cast<double>(sip.x_raw & 0x7FFFU) * dist);
    state_.pose.y_m = mm_to_m(static_cast<double>(sip.y_raw & 0x7FFFU) * dist);
    state_.pose.theta_rad = normalize_angle(static_cast<double>(sip.th_raw) * params_.angle_conv_rad);
    initialised_ = true;
  } else if (have_reference_) {
    const std::int32_t dx = unwrap15(last_x_, sip.x_raw);
    const std::int32_t dy = unwrap15(last_y_, sip.y_raw);
    const std::int32_t dth = static_cast<std::int32_t>(sip.th_raw) - static_cast<std::int32_t>(last_th_);
    state_.pose.x_m += mm_to_m(static_cast<double>(dx) * dist);
    state_.pose.y_m += mm_to_m(static_cast<double>(dy) * dist);
    state_.pose.theta_rad = normalize_angle(state_.pose.theta_rad + static_cast<double>(dth) * params_.angle_conv_rad);
  }
  have_reference_ = true;
  last_x_ = sip.x_raw;
  last_y_ = sip.y_raw;
  last_th_ = sip.th_raw;

  state_.left_vel_mm_s = static_cast<double>(sip.left_vel) * params_.vel_conv_mm_s;
  state_.right_vel_mm_s = static_cast<double>(sip.right_vel) * params_.vel_conv_mm_s;
  state_.trans_vel_mm_s = 0.5 * (state_.left_vel_mm_s + state_.right_vel_mm_s);
  if (sip.has(SipField::kRotVel)) {
    state_.rot_vel_rad_s = deg_to_rad(static_cast<double>(sip.rot_vel) * 0.1);  // 0.1 deg/s (§1.8)
  } else {
    state_.rot_vel_rad_s = 0.5 * (state_.right_vel_mm_s - state_.left_vel_mm_s) * params_.diff_conv_rad_per_mm;
  }
  state_.stamp = received;
  ++state_.sips;
}

}  // namespace teamscan::arcos
