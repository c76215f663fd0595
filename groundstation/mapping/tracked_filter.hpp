// `tracked` (docs/beyond.md): the position and direction filters (PAPER_NOTES eqs. 6–7)
// replaced by one 3-D test against each teammate's real body: the Pioneer 3-AT's bounding box,
// oriented by its heading, at its Kalman estimate moved to the beam's time, inflated by n·σ of the
// Kalman position covariance at the scan's time along each box axis and by the heading uncertainty.
#pragma once

#include <limits>
#include <algorithm>

#include "groundstation/mapping/freespace_tracked_options.hpp"
#include "groundstation/mapping/filter.hpp"

namespace teamscan::mapping {

// A teammate's body box for one scan: centre at the scan's stamp, velocity for beam times, box axes
// and inflated half-extents.
struct BodyBox {
  Vec2 centre_m;
  Vec2 velocity_mps;
  Vec2 axis_x, axis_y;  // unit vectors: heading and its left normal
  double half_x_m = 0, half_y_m = 0, z_min_m = 0, z_max_m = 0;
  // Below low_band_m: the bare footprint + margin (TrackedOptions::low_band_m).
  double low_band_m = 0, low_half_x_m = 0, low_half_y_m = 0;
  double low_inner_y_m = 0;  // wheel strips: |across| from this to low_half_y_m (0: the whole footprint)
  // Floor-consistent low points (|z| ≤ low_floor_n_sigma · range_noise_m · |sin elevation| of the beam
  // from `sensor_m`) only within the wheels' outline + margin (TrackedOptions::low_floor_n_sigma;
  // floor_z_per_sin_elev_m < 0: off).
  double floor_z_per_sin_elev_m = -1, outline_half_x_m = 0, outline_half_y_m = 0, outline_inner_y_m = 0;
  Vec3 sensor_m;  // the scanning robot's sensor origin (set per scan by TrackedFilter::classify)
  // Above upper_from_z_m: only the housing box, centred upper_centre_x_m ahead along axis_x
  // (TrackedOptions::height_profile; +inf when off).
  double upper_from_z_m = 0, upper_centre_x_m = 0, upper_half_x_m = 0, upper_half_y_m = 0;
};

// The inflated box of `other` (RobotEstimate at the scan's stamp) for these options. `extra_cov_m2`
// is uncertainty of the scanning robot's own registration relative to the teammate (its odometry
// drift, see TrackerOptions), added to the teammate's Kalman covariance.
[[nodiscard]] BodyBox body_box(const RobotEstimate& other, const TrackedOptions& options,
                               const Eigen::Matrix2d& extra_cov_m2 = Eigen::Matrix2d::Zero());
// Whether `p` lies in `box` with the teammate moved by `dt_s` (beam time − scan stamp), the beam
// coming from box.sensor_m.
[[nodiscard]] bool box_contains(const BodyBox& box, const MapPoint& p, double dt_s);
// How far from box.centre_m (in x, y) a point box_contains accepts can lie, for |dt_s| ≤ sweep_s: a
// bound, so a scan whose points are all further away needs no test.
[[nodiscard]] double box_reach_m(const BodyBox& box, double sweep_s);
// The x, y bounds of a set of points (empty: lo > hi), and whether a box may contain one of them
// (box_reach_m against the bounds): false means no point of the set needs a box_contains test.
struct PointBounds {
  double lo_x = std::numeric_limits<double>::infinity(), hi_x = -std::numeric_limits<double>::infinity();
  double lo_y = std::numeric_limits<double>::infinity(), hi_y = -std::numeric_limits<double>::infinity();
  void add(const MapPoint& p) {
    lo_x = std::min(lo_x, static_cast<double>(p.x));
    hi_x = std::max(hi_x, static_cast<double>(p.x));
    lo_y = std::min(lo_y, static_cast<double>(p.y));
    hi_y = std::max(hi_y, static_cast<double>(p.y));
  }
};
[[nodiscard]] bool box_may_reach(const BodyBox& box, const PointBounds& points, double sweep_s);

class TrackedFilter final : public Filter {
 public:
  explicit TrackedFilter(TrackedOptions options) : options_{options} {}
  [[nodiscard]] std::string method() const override { return "tracked"; }
  [[nodiscard]] FilterParams params() const override;
  void point_bits(const ScanView& scan, std::span<std::uint8_t> bits) const override;
  void insert(const ScanView&, std::span<const std::uint8_t>) override {}
  void decide(std::span<const MapPoint>, std::span<const std::uint8_t> bits, std::span<std::uint8_t> removed) const override {
    std::copy(bits.begin(), bits.end(), removed.begin());
  }
  void reset() override {}

 private:
  TrackedOptions options_;
};

}  // namespace teamscan::mapping
