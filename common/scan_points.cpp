// One LMS 2xx scan -> 3-D points in the map frame (see scan_points.hpp for the geometry and flags).
#include "common/scan_points.hpp"

#include <cmath>
#include <limits>

#include "common/fixed_point.hpp"
#include "common/result.hpp"
#include "common/units.hpp"

namespace teamscan {

ScanProjector::ScanProjector(const Pose3& robot_from_laser, const Pose2& map_from_odom,
                             const ScanPointsOptions& options)
    : robot_from_laser_{robot_from_laser}, map_from_odom_{map_from_odom}, options_{options} {}

void ScanProjector::prepare(LaserVariant variant) {
  TEAMSCAN_EXPECTS(variant.resolution_cdeg == 25 || variant.resolution_cdeg == 50 || variant.resolution_cdeg == 100);
  TEAMSCAN_EXPECTS(variant.beams() <= kMaxBeams);
  variant_ = variant;
  for (std::uint16_t i = 0; i < variant.beams(); ++i) {
    const Vec3 d_laser = beam_in_laser(variant.beam_angle_rad(i), 1.0);
    direction_robot_[i] = robot_from_laser_.rotation.apply(d_laser);
  }
}

bool ScanProjector::project(BeamSpans beams, Time stamp, LaserVariant variant, const OdometryHistory<>& odometry,
                            ScanPoints& out) {
  if (beams.range_mm.size() != variant.beams() || beams.flags.size() != beams.range_mm.size() ||
      beams.range_mm.size() > kMaxBeams)
    return false;
  if (!(variant == variant_)) prepare(variant);

  const double reg_c = std::cos(map_from_odom_.theta_rad), reg_s = std::sin(map_from_odom_.theta_rad);
  const Vec3 mount = robot_from_laser_.translation;

  out.stamp = stamp;
  out.count = static_cast<std::uint16_t>(beams.range_mm.size());
  out.unplaced = 0;

  // The sensor origin and the robot pose at the stamp (the paper's R1 for the direction filter).
  const Result<Pose2> at_stamp = odometry.interpolate(stamp, options_.max_extrapolation);
  out.pose_ok = at_stamp.ok();
  if (out.pose_ok) {
    out.map_from_robot = map_from_odom_ * at_stamp.value();
    const double c = std::cos(out.map_from_robot.theta_rad), s = std::sin(out.map_from_robot.theta_rad);
    out.origin_x_mm = to_mm(out.map_from_robot.x_m + c * mount.x - s * mount.y);
    out.origin_y_mm = to_mm(out.map_from_robot.y_m + s * mount.x + c * mount.y);
    out.origin_z_mm = to_mm(mount.z);
  } else {
    out.map_from_robot = Pose2{};
    out.origin_x_mm = out.origin_y_mm = out.origin_z_mm = 0;
  }

  for (std::uint16_t i = 0; i < out.count; ++i) {
    ScanPoint& p = out.points[i];
    p.beam = i;
    p.flags = 0;
    const std::uint32_t range_mm = beams.range_mm[i];
    const std::uint8_t in_flags = beams.flags[i];
    if ((in_flags & kBeamInvalid) != 0 || range_mm == 0) p.flags |= kPointInvalid;
    if ((in_flags & kBeamDazzled) != 0) p.flags |= kPointDazzled;
    if (p.flags == 0 && range_mm > options_.max_range_mm) p.flags |= kPointOutOfRange;

    const Time beam_time = stamp - variant_.beam_age(i);
    const Result<Pose2> odom_from_robot = odometry.interpolate(beam_time, options_.max_extrapolation);
    if (!odom_from_robot.ok()) {
      p.flags |= kPointNoPose;
      p.x_mm = p.y_mm = p.z_mm = 0;
      ++out.unplaced;
      continue;
    }
    // map_from_robot(t_i) = map_from_odom · odom_from_robot(t_i), written out to share reg_c/reg_s.
    const Pose2& o = odom_from_robot.value();
    const double x_m = map_from_odom_.x_m + reg_c * o.x_m - reg_s * o.y_m;
    const double y_m = map_from_odom_.y_m + reg_s * o.x_m + reg_c * o.y_m;
    const double theta_rad = map_from_odom_.theta_rad + o.theta_rad;
    const double c = std::cos(theta_rad), s = std::sin(theta_rad);

    // Invalid and dazzled beams sit at the laser centre (range 0): no phantom point far away.
    const double r_m = (p.flags & (kPointInvalid | kPointDazzled)) != 0 ? 0.0 : static_cast<double>(range_mm) * 1e-3;
    const Vec3& d = direction_robot_[i];
    const double px = mount.x + r_m * d.x, py = mount.y + r_m * d.y, pz = mount.z + r_m * d.z;
    p.x_mm = to_mm(x_m + c * px - s * py);
    p.y_mm = to_mm(y_m + s * px + c * py);
    p.z_mm = to_mm(pz);
  }
  return true;
}

}  // namespace teamscan
