// The paper's filters (PAPER_NOTES eqs. 4–8) and their factory.
#include "groundstation/mapping/filter.hpp"

#include <algorithm>
#include <cmath>

#include "common/dataset/dataset.hpp"
#include "common/result.hpp"

namespace teamscan::mapping {

bool direction_cone_contains(const DirectionOptions& options, Vec2 self_m, Vec2 other_m, Vec3 p_m) {
  // PAPER_NOTES eq. 7, horizontal: L from R1 (self) to R2 (other); p_L the foot of p on L;
  // d_r(p_L) the distance R1→p_L along L, d_p(p, L) the distance of p from L.
  const Vec2 line = other_m - self_m;
  const double line_length_m = line.norm();
  if (line_length_m <= 0.0) return false;  // teammate on top of us: no direction
  const Vec2 u = (1.0 / line_length_m) * line;
  const Vec2 v{p_m.x - self_m.x, p_m.y - self_m.y};
  const double along_m = v.x * u.x + v.y * u.y;  // d_r(p_L)
  if (along_m <= 0.0) return false;              // not ahead of R1 along L
  const double across_m = std::abs(v.x * u.y - v.y * u.x);  // d_p(p, L)
  if (!(across_m < along_m * std::tan(options.half_angle_rad))) return false;
  if (options.range_gate_beyond_m > 0.0 && along_m > line_length_m + options.range_gate_beyond_m) return false;
  if (options.height_gate_m > 0.0 && !(p_m.z < options.height_gate_m)) return false;
  return true;
}

FilterParams FrequencyFilter::params() const { return {{"resolution_m", options_.resolution_m}, {"k", options_.k}}; }

void FrequencyFilter::classify(const ScanView& scan, std::span<std::uint8_t> removed) const {
  TEAMSCAN_EXPECTS(removed.size() == scan.points.size());
  const double limit = threshold();  // eq. 4: count < μ − k·σ
  for (std::size_t i = 0; i < scan.points.size(); ++i)
    removed[i] = static_cast<double>(map_.count_at(scan.points[i])) < limit ? 1 : 0;
}

void VisibilityFilter::classify(const ScanView& scan, std::span<std::uint8_t> removed) const {
  TEAMSCAN_EXPECTS(removed.size() == scan.points.size());
  for (std::size_t i = 0; i < scan.points.size(); ++i) {
    // Eq. 5: an occupied voxel strictly below in the same column hides this one from a floor view.
    const VoxelKey k = map_.key_of(scan.points[i]);
    const auto lowest = map_.column_lowest_z(k.x, k.y);
    removed[i] = (lowest && *lowest < k.z) ? 1 : 0;
  }
}

void PositionFilter::classify(const ScanView& scan, std::span<std::uint8_t> removed) const {
  TEAMSCAN_EXPECTS(removed.size() == scan.points.size());
  std::fill(removed.begin(), removed.end(), std::uint8_t{0});
  if (!scan.team) return;
  const double radius_m = options_.n * options_.sigma_m;  // eq. 6
  for (const RobotEstimate& other : scan.team->robots) {
    if (other.robot == scan.robot || !other.valid) continue;
    for (std::size_t i = 0; i < scan.points.size(); ++i) {
      const double dx = scan.points[i].x - other.position_m.x, dy = scan.points[i].y - other.position_m.y;
      if (std::hypot(dx, dy) < radius_m) removed[i] = 1;
    }
  }
}

FilterParams DirectionFilter::params() const {
  return {{"half_angle_deg", rad_to_deg(options_.half_angle_rad)},
          {"from_flags", options_.source == DirectionSource::flags ? 1.0 : 0.0},
          {"range_gate_beyond_m", options_.range_gate_beyond_m},
          {"height_gate_m", options_.height_gate_m}};
}

void DirectionFilter::classify(const ScanView& scan, std::span<std::uint8_t> removed) const {
  TEAMSCAN_EXPECTS(removed.size() == scan.points.size());
  std::fill(removed.begin(), removed.end(), std::uint8_t{0});
  if (options_.source == DirectionSource::flags) {
    // The robot's own decision, as it flagged the point before sending it.
    for (std::size_t i = 0; i < scan.flags.size() && i < removed.size(); ++i)
      removed[i] = (scan.flags[i] & point_flags::kDirectionFiltered) ? 1 : 0;
    return;
  }
  if (!scan.team) return;
  const Vec2 self{scan.map_from_robot.x_m, scan.map_from_robot.y_m};
  for (const RobotEstimate& other : scan.team->robots) {
    if (other.robot == scan.robot || !other.valid) continue;
    for (std::size_t i = 0; i < scan.points.size(); ++i) {
      const MapPoint& p = scan.points[i];
      if (direction_cone_contains(options_, self, other.position_m, {p.x, p.y, p.z})) removed[i] = 1;
    }
  }
}

FilterParams SequentialFilter::params() const {
  FilterParams out;
  for (const auto& [name, value] : first_->params()) out.emplace_back(first_->method() + "." + name, value);
  for (const auto& [name, value] : second_->params()) out.emplace_back(second_->method() + "." + name, value);
  return out;
}

void SequentialFilter::survivors(const ScanView& scan, std::span<const std::uint8_t> removed, Survivors& out) const {
  out.points.clear();
  out.flags.clear();
  out.kept_index.clear();
  for (std::size_t i = 0; i < scan.points.size(); ++i) {
    if (removed[i]) continue;
    out.points.push_back(scan.points[i]);
    if (i < scan.flags.size()) out.flags.push_back(scan.flags[i]);
    out.kept_index.push_back(i);
  }
}

void SequentialFilter::observe(const ScanView& scan) {
  first_->observe(scan);
  std::vector<std::uint8_t> removed(scan.points.size());
  first_->classify(scan, removed);
  Survivors kept;
  survivors(scan, removed, kept);
  ScanView reduced = scan;
  reduced.points = kept.points;
  reduced.flags = kept.flags;
  second_->observe(reduced);
}

void SequentialFilter::classify(const ScanView& scan, std::span<std::uint8_t> removed) const {
  TEAMSCAN_EXPECTS(removed.size() == scan.points.size());
  first_->classify(scan, removed);
  Survivors kept;
  survivors(scan, removed, kept);
  ScanView reduced = scan;
  reduced.points = kept.points;
  reduced.flags = kept.flags;
  std::vector<std::uint8_t> second_removed(kept.points.size());
  second_->classify(reduced, second_removed);
  for (std::size_t j = 0; j < kept.kept_index.size(); ++j)
    if (second_removed[j]) removed[kept.kept_index[j]] = 1;
}

const std::vector<std::string>& known_methods() {
  static const std::vector<std::string> methods{"frequency", "visibility", "position", "direction", "combined"};
  return methods;
}

std::unique_ptr<Filter> make_filter(const std::string& method, const MethodOptions& options) {
  if (method == "frequency") return std::make_unique<FrequencyFilter>(options.frequency);
  if (method == "visibility") return std::make_unique<VisibilityFilter>(options.visibility);
  if (method == "position") return std::make_unique<PositionFilter>(options.position);
  if (method == "direction") return std::make_unique<DirectionFilter>(options.direction);
  if (method == "combined") {
    DirectionOptions direction = options.direction;
    direction.half_angle_rad = options.combined_half_angle_rad;
    return std::make_unique<SequentialFilter>("combined", std::make_unique<DirectionFilter>(direction),
                                              std::make_unique<VisibilityFilter>(VisibilityOptions{options.combined_resolution_m}));
  }
  return nullptr;
}

}  // namespace teamscan::mapping
