// Metrics by their definitions in PAPER_NOTES "The metrics" and ANCHORS.md §1.1.
#include "groundstation/mapping/metrics.hpp"

#include <cmath>
#include <limits>
#include <vector>

#include "common/result.hpp"

namespace teamscan::mapping {
namespace {
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
double pct(std::uint64_t part, std::uint64_t whole) {
  return whole == 0 ? kNaN : 100.0 * static_cast<double>(part) / static_cast<double>(whole);
}
}  // namespace

double ClassTally::kept_pct() const { return pct(total - removed, total); }

RemovalMetrics removal_metrics(std::span<const LabelledPoint> points, std::span<const std::uint8_t> removed) {
  TEAMSCAN_EXPECTS(points.size() == removed.size());
  RemovalMetrics m;
  for (std::size_t i = 0; i < points.size(); ++i) {
    const auto cls = static_cast<std::size_t>(points[i].label);
    const bool gone = removed[i] != 0;
    if (cls < kPointClasses) {
      ++m.by_class[cls].total;
      if (gone) ++m.by_class[cls].removed;
    }
    if (points[i].is_ghost()) {
      ++m.ghosts;
      if (gone) ++m.ghosts_removed;
    } else {
      ++m.others;
      if (gone) ++m.others_removed;
    }
  }
  m.ghost_removed_pct = pct(m.ghosts_removed, m.ghosts);
  m.other_removed_pct = pct(m.others_removed, m.others);
  // ANCHORS §1.1: SA = static kept / static, DA = dynamic removed / dynamic, AA = √(SA·DA),
  // HA = 2·SA·DA / (SA + DA), all in percent and point-wise.
  m.da = m.ghost_removed_pct;
  m.sa = pct(m.others - m.others_removed, m.others);
  m.aa = std::sqrt(m.sa * m.da);
  const double sum = m.sa + m.da;  // NaN propagates when a class is absent
  m.ha = sum == 0.0 ? 0.0 : 2.0 * m.sa * m.da / sum;
  return m;
}

double plane_error_improvement_pct(const PlaneFit& before, const PlaneFit& after) {
  if (!before.found || !after.found) return kNaN;
  const double e0 = std::abs(before.signed_mean_error_m), e1 = std::abs(after.signed_mean_error_m);
  if (e0 == 0.0) return kNaN;
  return 100.0 * (e0 - e1) / e0;
}

double plane_inlier_improvement_pct(const PlaneFit& before, const PlaneFit& after) {
  if (!before.found || !after.found || before.inlier_share == 0.0) return kNaN;
  return 100.0 * (after.inlier_share - before.inlier_share) / before.inlier_share;
}

double floor_bias_m(std::span<const MapPoint> points, const Plane& reference, double threshold_m,
                    std::span<const std::uint8_t> removed) {
  TEAMSCAN_EXPECTS(removed.empty() || removed.size() == points.size());
  double sum = 0;
  std::uint64_t n = 0;
  for (std::size_t i = 0; i < points.size(); ++i) {
    if (!removed.empty() && removed[i]) continue;
    const double e = reference.signed_distance(points[i]);
    if (std::abs(e) > threshold_m) continue;
    sum += e;
    ++n;
  }
  return n ? sum / static_cast<double>(n) : kNaN;
}

double floor_bias_improvement_pct(double before_m, double after_m) {
  if (!std::isfinite(before_m) || !std::isfinite(after_m) || before_m == 0.0) return kNaN;
  return 100.0 * (std::abs(before_m) - std::abs(after_m)) / std::abs(before_m);
}

Table1 table1(std::span<const LabelledPoint> labelled, std::span<const MapPoint> points, const RansacOptions& options) {
  TEAMSCAN_EXPECTS(labelled.size() == points.size());
  Table1 t;
  t.with_ghosts = fit_plane_ransac(points, options);
  std::vector<std::uint8_t> ghost(points.size());
  for (std::size_t i = 0; i < points.size(); ++i) ghost[i] = labelled[i].is_ghost() ? 1 : 0;
  t.without_ghosts = fit_plane_ransac(points, options, ghost);
  if (t.with_ghosts.found) {
    std::uint64_t in = 0, in_ghost = 0;
    const Plane& plane = t.with_ghosts.plane;
    for (std::size_t i = 0; i < points.size(); ++i) {
      if (std::abs(plane.signed_distance(points[i])) > options.threshold_m) continue;
      ++in;
      if (ghost[i]) ++in_ghost;
    }
    t.ghost_share_of_inliers_pct = pct(in_ghost, in);
  }
  t.error_improvement_pct = plane_error_improvement_pct(t.with_ghosts, t.without_ghosts);
  t.inlier_improvement_pct = plane_inlier_improvement_pct(t.with_ghosts, t.without_ghosts);
  return t;
}

}  // namespace teamscan::mapping
