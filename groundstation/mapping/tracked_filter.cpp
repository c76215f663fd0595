// The Kalman-linked robot-body filter.
#include "groundstation/mapping/tracked_filter.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "common/result.hpp"

namespace teamscan::mapping {

BodyBox body_box(const RobotEstimate& other, const TrackedOptions& o, const Eigen::Matrix2d& extra_cov_m2) {
  BodyBox b;
  b.centre_m = other.position_m;
  b.velocity_mps = other.velocity_mps;
  const double c = std::cos(other.heading_rad), s = std::sin(other.heading_rad);
  b.axis_x = {c, s};
  b.axis_y = {-s, c};
  // σ of the position along each body axis: uᵀ·C·u of the Kalman 2×2 covariance (plus the scanning
  // robot's own drift covariance: the point and the box are registered by different odometries).
  const Eigen::Matrix2d cov = o.include_drift ? Eigen::Matrix2d(other.position_cov_m2 + extra_cov_m2)
                                              : Eigen::Matrix2d(other.position_cov_m2 - other.drift_cov_m2);
  const Eigen::Vector2d ux{c, s}, uy{-s, c};
  const double sigma_x = std::sqrt(std::max(0.0, ux.dot(cov * ux)));
  const double sigma_y = std::sqrt(std::max(0.0, uy.dot(cov * uy)));
  // Heading: the fixed σ of the options and the teammate's odometry heading drift (tracker.hpp),
  // independent, so in quadrature. A heading error θ moves a point at distance ρ from the robot's
  // centre by ρ·sin θ in either axis.
  const double heading_sigma = std::hypot(o.heading_sigma_rad, o.include_drift ? other.heading_sigma_rad : 0.0);
  const double sin_turn = std::sin(std::min(1.0, o.n_sigma * heading_sigma));
  const double turn_m = std::hypot(o.half_length_m, o.half_width_m) * sin_turn;
  b.half_x_m = o.half_length_m + o.margin_m + o.n_sigma * sigma_x + turn_m;
  b.half_y_m = o.half_width_m + o.margin_m + o.n_sigma * sigma_y + turn_m;
  b.z_min_m = o.floor_clearance_m;
  b.z_max_m = o.height_m + o.margin_m;
  b.low_band_m = o.low_band_m;
  b.low_half_x_m = o.half_length_m + o.margin_m;
  b.low_half_y_m = o.half_width_m + o.margin_m;
  if (o.height_profile) {
    // The wheel strips take the Kalman part of the position uncertainty outwards (the floor under the
    // chassis stays); not the drift part, which grows to decimetres and would take the floor around.
    const Eigen::Matrix2d kalman = other.position_cov_m2 - other.drift_cov_m2;
    const double kx = std::sqrt(std::max(0.0, ux.dot(kalman * ux))), ky = std::sqrt(std::max(0.0, uy.dot(kalman * uy)));
    const double low_margin = o.low_margin_m < 0.0 ? o.margin_m : o.low_margin_m;
    b.low_half_x_m = o.wheel_half_length_m + low_margin + o.n_sigma * kx;
    b.low_half_y_m = o.half_width_m + low_margin + o.n_sigma * ky;
    b.low_inner_y_m = std::max(0.0, o.wheel_inner_y_m - low_margin);
    if (o.low_floor_n_sigma >= 0.0 && o.low_outline_margin_m >= 0.0) {
      b.floor_z_per_sin_elev_m = o.low_floor_n_sigma * o.range_noise_m;
      b.outline_half_x_m = o.wheel_half_length_m + o.low_outline_margin_m;
      b.outline_half_y_m = o.half_width_m + o.low_outline_margin_m;
      b.outline_inner_y_m = std::max(0.0, o.wheel_inner_y_m - o.low_outline_margin_m);
    }
    const double upper_turn_m =
        std::hypot(std::abs(o.upper_centre_x_m) + o.upper_half_length_m, o.upper_half_width_m) * sin_turn;
    b.upper_from_z_m = o.upper_z_m + o.margin_m;
    b.upper_centre_x_m = o.upper_centre_x_m;
    b.upper_half_x_m = o.upper_half_length_m + o.margin_m + o.n_sigma * sigma_x + upper_turn_m;
    b.upper_half_y_m = o.upper_half_width_m + o.margin_m + o.n_sigma * sigma_y + upper_turn_m;
  } else {
    b.upper_from_z_m = std::numeric_limits<double>::infinity();
  }
  return b;
}

double box_reach_m(const BodyBox& b, double sweep_s) {
  // Every test of box_contains bounds |along| and |across| by one of these pairs (the outline lies
  // inside the low footprint); the centre moves by velocity · dt_s with |dt_s| ≤ sweep_s.
  const double upper_x = std::isfinite(b.upper_from_z_m) ? std::abs(b.upper_centre_x_m) + b.upper_half_x_m : 0.0;
  const double upper_y = std::isfinite(b.upper_from_z_m) ? b.upper_half_y_m : 0.0;
  const double r = std::max({std::hypot(b.half_x_m, b.half_y_m), std::hypot(b.low_half_x_m, b.low_half_y_m),
                             std::hypot(upper_x, upper_y)});
  return r + std::hypot(b.velocity_mps.x, b.velocity_mps.y) * std::abs(sweep_s) + 1e-6;
}

bool box_may_reach(const BodyBox& b, const PointBounds& points, double sweep_s) {
  if (!(points.lo_x <= points.hi_x)) return false;  // no points (or none finite in x, y)
  const double reach_m = box_reach_m(b, sweep_s);
  const double gap_x = std::max({0.0, points.lo_x - b.centre_m.x, b.centre_m.x - points.hi_x});
  const double gap_y = std::max({0.0, points.lo_y - b.centre_m.y, b.centre_m.y - points.hi_y});
  return gap_x * gap_x + gap_y * gap_y <= reach_m * reach_m;
}

bool box_contains(const BodyBox& b, const MapPoint& p, double dt_s) {
  if (p.z < b.z_min_m || p.z > b.z_max_m) return false;
  const double dx = p.x - (b.centre_m.x + b.velocity_mps.x * dt_s);
  const double dy = p.y - (b.centre_m.y + b.velocity_mps.y * dt_s);
  const double along = dx * b.axis_x.x + dy * b.axis_x.y, across = std::abs(dx * b.axis_y.x + dy * b.axis_y.y);
  if (p.z < b.low_band_m) {
    if (!(std::abs(along) <= b.low_half_x_m && across <= b.low_half_y_m && across >= b.low_inner_y_m)) return false;
    if (b.floor_z_per_sin_elev_m < 0.0) return true;
    // Floor-consistent (within n σ_z of z = 0, σ_z the range noise's vertical part along this beam):
    // a wheel hit only at the wheel's outline (TrackedOptions::low_floor_n_sigma).
    const double ex = p.x - b.sensor_m.x, ey = p.y - b.sensor_m.y, ez = p.z - b.sensor_m.z;
    const double range_m = std::sqrt(ex * ex + ey * ey + ez * ez);
    if (range_m > 0.0 && std::abs(p.z) * range_m <= b.floor_z_per_sin_elev_m * std::abs(ez))
      return std::abs(along) <= b.outline_half_x_m && across <= b.outline_half_y_m && across >= b.outline_inner_y_m;
    return true;
  }
  if (p.z > b.upper_from_z_m) return std::abs(along - b.upper_centre_x_m) <= b.upper_half_x_m && across <= b.upper_half_y_m;
  return std::abs(along) <= b.half_x_m && across <= b.half_y_m;
}

FilterParams TrackedFilter::params() const {
  return {{"half_length_m", options_.half_length_m}, {"half_width_m", options_.half_width_m},
          {"height_m", options_.height_m},           {"floor_clearance_m", options_.floor_clearance_m},
          {"margin_m", options_.margin_m},           {"n_sigma", options_.n_sigma},
          {"heading_sigma_deg", options_.heading_sigma_rad * 180.0 / 3.14159265358979323846},
          {"sweep_s", options_.sweep_s},             {"low_band_m", options_.low_band_m}, {"low_margin_m", options_.low_margin_m},
          {"low_floor_n_sigma", options_.low_floor_n_sigma}, {"range_noise_m", options_.range_noise_m}, {"low_outline_margin_m", options_.low_outline_margin_m},
          {"height_profile", options_.height_profile ? 1.0 : 0.0},
          {"include_drift", options_.include_drift ? 1.0 : 0.0}};
}

void TrackedFilter::point_bits(const ScanView& scan, std::span<std::uint8_t> removed) const {
  TEAMSCAN_EXPECTS(removed.size() == scan.points.size());
  std::fill(removed.begin(), removed.end(), std::uint8_t{0});
  if (!scan.team) return;
  const double n = static_cast<double>(scan.points.size());
  // The scanning robot's own odometry drift (tracker.hpp): its points are off by its position error
  // plus its heading error times the range, relative to teammates registered by their own odometry.
  const RobotEstimate* self = scan.team->find(scan.robot);
  // The scan's footprint (x, y bounds): a teammate whose box cannot reach it is skipped without testing
  // its points (with 32 robots most teammates are rooms away; the decisions are the same).
  PointBounds footprint;
  for (const MapPoint& p : scan.points) footprint.add(p);
  for (const RobotEstimate& other : scan.team->robots) {
    if (other.robot == scan.robot || !other.valid) continue;
    Eigen::Matrix2d extra = Eigen::Matrix2d::Zero();
    if (options_.include_drift && self != nullptr && self->valid) {
      const double range_m = std::hypot(other.position_m.x - scan.origin_m.x, other.position_m.y - scan.origin_m.y);
      const double lever_m = range_m * std::sin(std::min(1.0, self->heading_sigma_rad));
      extra = self->drift_cov_m2 + Eigen::Matrix2d::Identity() * (lever_m * lever_m);
    }
    BodyBox box = body_box(other, options_, extra);
    box.sensor_m = scan.origin_m;
    if (!box_may_reach(box, footprint, options_.sweep_s)) continue;
    for (std::size_t i = 0; i < scan.points.size(); ++i) {
      if (removed[i]) continue;
      // The teammates are interpolated to each beam's time within the sweep (TrackedOptions::sweep_s).
      const double dt_s = -options_.sweep_s * (1.0 - (static_cast<double>(i) + 0.5) / n);
      if (box_contains(box, scan.points[i], dt_s)) removed[i] = 1;
    }
  }
}

}  // namespace teamscan::mapping
