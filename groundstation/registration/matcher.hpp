// Scan-to-map matching in the plane: a robot's recent vertical-surface features (odometry-map frame)
// against the reference features (map frame, LineMap) by point-to-line ICP, for the
// correction map_from_odom = (x, y, yaw). Robust (Huber) weights, a shrinking correspondence gate,
// normals that must agree. The normal-equations Hessian is eigen-analysed: a direction the geometry
// does not constrain (a corridor's axis) is left where the prior had it and reported. The result
// says whether the match is usable (overlap, residual, step) and carries the 3×3 covariance.
#pragma once

#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <span>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include "common/pose.hpp"
#include "common/flat_key_map.hpp"
#include "groundstation/registration/surface_grid.hpp"

namespace teamscan::registration {

// The reference: line features in a 2-D hash grid of their positions, updated in place. Features
// come in groups (the team's reference: one group per voxel column, SurfaceGrid::take_changes), and a
// group's features are replaced when its column changes: an update costs what changed, never the
// whole map (the k-d tree this replaced was rebuilt from every feature: docs/registration.md "Cost").
class LineMap {
 public:
  // Cells of `cell_m`, in tiles of 16 × 16 cells (one hash look-up per tile a query touches).
  static constexpr double kDefaultCellM = 0.25;
  static constexpr std::size_t kMaxPerGroup = 8;  // a column gives one feature per normal direction
  explicit LineMap(double cell_m = kDefaultCellM);

  // From scratch: feature i is group i (its index for nearest() and feature() is i).
  void build(std::span<const LineFeature> features);
  void clear();
  // The features of `group` become `features` (none: the group is gone); at most kMaxPerGroup are
  // kept, the rest counted (dropped()).
  void replace(std::uint64_t group, std::span<const LineFeature> features);

  [[nodiscard]] std::size_t size() const { return size_; }
  // The feature nearest() answered with (`index` < slots(); valid until the next change).
  [[nodiscard]] const LineFeature& feature(std::size_t index) const { return slots_[index].f; }
  [[nodiscard]] std::size_t slots() const { return slots_.size(); }
  // Index of the nearest feature to (x, y) within `max_distance_m` whose normal agrees with (nx, ny)
  // (|dot| ≥ min_dot; among the 4 nearest), or -1. A query without a normal (0, 0: a bare point)
  // takes the nearest line. Equal distances are ordered by (group, place in the group): the answer
  // depends on the features alone, never on the order they came in.
  [[nodiscard]] std::ptrdiff_t nearest(double x_m, double y_m, double nx, double ny, double max_distance_m,
                                       double min_dot) const;
  // Every feature with its group, by group and place in it (to compare two maps).
  void collect(std::vector<std::pair<std::uint64_t, LineFeature>>& out) const;

  // Counters: groups replaced, features put in and taken out, features beyond kMaxPerGroup.
  [[nodiscard]] std::uint64_t groups_replaced() const { return groups_replaced_; }
  [[nodiscard]] std::uint64_t features_added() const { return features_added_; }
  [[nodiscard]] std::uint64_t features_removed() const { return features_removed_; }
  [[nodiscard]] std::uint64_t dropped() const { return dropped_; }

 private:
  static constexpr std::uint32_t kNone = ~std::uint32_t{0};
  static constexpr int kTileBits = 4;  // 16 × 16 cells
  struct Slot {
    LineFeature f;
    std::uint64_t group = 0;
    std::uint32_t place = 0;  // in the group
    bool live = false;
  };
  struct Entry {  // a feature in its cell (the position and normal inline: a query reads no slot)
    double x_m, y_m, nx, ny;
    std::uint32_t slot;
  };
  struct Group {
    std::uint32_t count = 0;
    std::array<std::uint32_t, kMaxPerGroup> slots{};
  };
  using Tile = std::array<std::uint32_t, 1u << (2 * kTileBits)>;  // cell index per cell, or kNone

  [[nodiscard]] std::int64_t cell_of(double v) const { return static_cast<std::int64_t>(std::floor(v / cell_m_)); }
  static std::uint64_t tile_key(std::int64_t tx, std::int64_t ty);
  [[nodiscard]] const std::vector<Entry>* cell(std::int64_t cx, std::int64_t cy) const;
  std::vector<Entry>& cell_for_insert(std::int64_t cx, std::int64_t cy);
  void insert(std::uint32_t slot);
  void erase(std::uint32_t slot);
  // (distance², group, place) order of two slots at distance² d2a and d2b.
  [[nodiscard]] bool before(double d2a, std::uint32_t a, double d2b, std::uint32_t b) const;

  double cell_m_;
  std::vector<Slot> slots_;
  std::vector<std::uint32_t> free_;
  FlatKeyMap<Group> groups_;
  FlatKeyMap<std::uint32_t> tiles_;  // tile key → index in tile_cells_
  std::vector<Tile> tile_cells_;
  std::vector<std::vector<Entry>> cells_;
  std::int64_t cx_lo_ = 0, cx_hi_ = -1, cy_lo_ = 0, cy_hi_ = -1;  // cells ever used (a query stops beyond)
  std::size_t size_ = 0;
  std::uint64_t groups_replaced_ = 0, features_added_ = 0, features_removed_ = 0, dropped_ = 0;
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
