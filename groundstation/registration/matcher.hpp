// Scan-to-map matching in the plane: a robot's recent vertical-surface features (odometry-map frame)
// against the reference features (map frame) by point-to-line ICP with a k-d tree (nanoflann), for the
// correction map_from_odom = (x, y, yaw). Robust (Huber) weights, a shrinking correspondence gate,
// normals that must agree. The normal-equations Hessian is eigen-analysed: a direction the geometry
// does not constrain (a corridor's axis) is left where the prior had it and reported. The result
// says whether the match is usable (overlap, residual, step) and carries the 3×3 covariance.
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <span>
#include <vector>

#include <Eigen/Core>

#include "common/pose.hpp"
#include "groundstation/registration/surface_grid.hpp"

namespace teamscan::registration {

// The reference: line features with a 2-D k-d tree over their positions. Rebuilt, not updated.
class LineMap {
 public:
  LineMap();
  ~LineMap();
  LineMap(const LineMap&) = delete;
  LineMap& operator=(const LineMap&) = delete;

  void build(std::vector<LineFeature> features);
  [[nodiscard]] std::size_t size() const { return features_.size(); }
  [[nodiscard]] const std::vector<LineFeature>& features() const { return features_; }
  // Index of the nearest feature to (x, y) within `max_distance_m` whose normal agrees with (nx, ny)
  // (|dot| ≥ min_dot; among the 4 nearest), or -1. A query without a normal (0, 0: a bare point)
  // takes the nearest line.
  [[nodiscard]] std::ptrdiff_t nearest(double x_m, double y_m, double nx, double ny, double max_distance_m,
                                       double min_dot) const;

 private:
  struct Index;
  std::vector<LineFeature> features_;
  std::unique_ptr<Index> index_;
};

struct MatchOptions {
  int iterations = 12;
  double gate_start_m = 0.30;        // correspondence gate of the first iteration …
  double gate_end_m = 0.10;          // … shrinking to this by the last
  double huber_m = 0.02;             // robust weight: residuals beyond this count linearly
  double min_normal_dot = 0.8;       // |n_source · n_map| of a correspondence (≈ 37°)
  double lever_m = 2.0;              // yaw is compared with metres at this lever arm (eigen-analysis)
  double degenerate_ratio = 0.01;    // λ / λ_max below this: the direction is not constrained
  std::size_t min_correspondences = 25;
  double min_overlap = 0.45;         // share of source features with a correspondence at the end gate
  double max_rms_m = 0.035;          // weighted RMS point-to-line residual at the end
  double max_step_m = 0.12;          // the correction may move at most this per match …
  double max_step_rad = 0.035;       // … and turn at most this (2°): never a jump
  double min_sigma_m = 0.005;        // covariance floor (features are not independent samples)
  double min_sigma_rad = 0.001;
  double covariance_scale = 4.0;     // inflates σ²·H⁻¹: neighbouring features share their errors
  double unconstrained_sigma = 1.0;  // σ given to a degenerate direction (m, or rad × lever)
};

enum class MatchStatus : std::uint8_t {
  accepted,
  too_few_features,   // the source or the map has too little vertical structure
  no_overlap,         // too few correspondences or too small a share of the source matched
  poor_fit,           // residual too large: ambiguous or wrong
  step_too_large,     // the solution would move the correction by more than a bounded step
};
[[nodiscard]] const char* to_string(MatchStatus s);

struct MatchResult {
  MatchStatus status = MatchStatus::too_few_features;
  Pose2 map_from_odom;                // the estimate (equals the prior unless accepted)
  // Covariance of (x, y, yaw) of a left perturbation about `pivot_m`: map_from_odom ≈
  // Rot(δyaw about pivot) · Trans(δx, δy) · estimate. Degenerate directions carry unconstrained_sigma².
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Identity();
  Vec2 pivot_m;
  bool degenerate = false;
  Eigen::Vector3d unconstrained = Eigen::Vector3d::Zero();  // (x, y, yaw·lever) unit direction when degenerate
  double condition = 0;               // λ_min / λ_max of the scaled Hessian
  double overlap = 0;                 // share of source features matched at the end gate
  double rms_m = 0;
  std::size_t correspondences = 0;
  std::size_t source_features = 0;
  int iterations = 0;
  double step_m = 0, step_rad = 0;    // |estimate − prior|
};

// Matches `source` (features in the odometry-map frame: where odometry alone puts them) against
// `map`, starting from `prior` (the current correction). Pure: no state.
[[nodiscard]] MatchResult match(const LineMap& map, std::span<const LineFeature> source, const Pose2& prior,
                                const MatchOptions& options);

// Δ ∘ t with Δ the rotation by `dtheta_rad` about `pivot` followed by the translation (dx, dy): the
// left perturbation the covariances are expressed in.
[[nodiscard]] Pose2 perturb(const Pose2& t, const Vec2& pivot, double dx_m, double dy_m, double dtheta_rad);
// The perturbation about `pivot` that takes `from` to `to` (inverse of perturb).
[[nodiscard]] Eigen::Vector3d difference(const Pose2& to, const Pose2& from, const Vec2& pivot);

// Moves a left perturbation's covariance from pivot `from` to pivot `to` (same transform).
[[nodiscard]] Eigen::Matrix3d move_pivot(const Eigen::Matrix3d& cov, const Vec2& from, const Vec2& to);

}  // namespace teamscan::registration
