// Evaluation metrics on a labelled cloud (PAPER_NOTES "The metrics", ANCHORS.md §1.1): the paper's
// four (% ghost, % other, % improvement in floor-plane error and inliers), the dynamic-map
// benchmark's point-wise SA/DA/AA/HA, the share kept per scene class, and the paper's Table 1.
#pragma once

#include <array>
#include <cstdint>
#include <span>

#include "common/dataset/dataset.hpp"
#include "groundstation/mapping/ransac.hpp"

namespace teamscan::mapping {

inline constexpr std::size_t kPointClasses = 6;  // PointClass none..robot

struct ClassTally {
  std::uint64_t total = 0;
  std::uint64_t removed = 0;
  // Share kept in percent (NaN when the class is absent).
  [[nodiscard]] double kept_pct() const;
};

// Point-wise confusion of a filter's decisions against the labels; ghost = PointClass::robot.
struct RemovalMetrics {
  std::uint64_t ghosts = 0, ghosts_removed = 0;
  std::uint64_t others = 0, others_removed = 0;
  std::array<ClassTally, kPointClasses> by_class{};
  double ghost_removed_pct = 0;  // paper "% ghost points" = DA
  double other_removed_pct = 0;  // paper "% other points" = 100 − SA
  double sa = 0, da = 0, aa = 0, ha = 0;
};

[[nodiscard]] RemovalMetrics removal_metrics(std::span<const LabelledPoint> points, std::span<const std::uint8_t> removed);

// (|E_before| − |E_after|) / |E_before| in percent (NaN if E_before is 0 or a fit is missing).
[[nodiscard]] double plane_error_improvement_pct(const PlaneFit& before, const PlaneFit& after);
// Relative change of the inlier share in percent (NaN if a fit is missing).
[[nodiscard]] double plane_inlier_improvement_pct(const PlaneFit& before, const PlaneFit& after);

// Deterministic floor-bias measure (docs/beyond.md "Floor-plane error"): the signed mean
// distance to a FIXED reference plane of the kept points within `threshold_m` of it. The paper's
// signed error is measured against each cloud's own best RANSAC sample, so it changes with which
// 3-point sample wins (docs/evaluation.md note 4); against one reference for every cloud, the
// measure moves only by what the filter removed. evaluate() uses the least-squares floor of the
// ghost-free cloud (Table 1's `without_ghosts.plane`) as the reference: ghosts near the floor pull
// the bias up, removing them brings it back to ~0. NaN when no point is within the threshold.
[[nodiscard]] double floor_bias_m(std::span<const MapPoint> points, const Plane& reference, double threshold_m,
                                  std::span<const std::uint8_t> removed = {});
// (|bias_before| − |bias_after|) / |bias_before| in percent (NaN if either is NaN or before is 0).
[[nodiscard]] double floor_bias_improvement_pct(double before_m, double after_m);

// The paper's Table 1: floor plane with all points, and with the ghost points removed by label.
struct Table1 {
  PlaneFit with_ghosts;
  PlaneFit without_ghosts;
  double ghost_share_of_inliers_pct = 0;  // ghosts among the with-ghosts fit's inliers
  double error_improvement_pct = 0;
  double inlier_improvement_pct = 0;
};

[[nodiscard]] Table1 table1(std::span<const LabelledPoint> labelled, std::span<const MapPoint> points,
                            const RansacOptions& options);

}  // namespace teamscan::mapping
