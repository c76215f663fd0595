// The paper's filters (PAPER_NOTES eqs. 4–8) and their factory.
#include "groundstation/mapping/filter.hpp"

#include <algorithm>
#include <cmath>

#include "common/dataset/dataset.hpp"
#include "common/result.hpp"
#include "common/units.hpp"
#include "groundstation/mapping/best.hpp"
#include "groundstation/mapping/freespace_filter.hpp"
#include "groundstation/mapping/tracked_filter.hpp"
#include "onboard/cone/direction_cone.hpp"

namespace teamscan::mapping {

namespace {
// The onboard filter's parameters from ours (the stale-team policy does not apply offline: the tracker
// already marks a lost teammate invalid).
cone::DirectionFilterParams onboard_params(const DirectionOptions& o) {
  cone::DirectionFilterParams params;
  params.half_angle_deg = rad_to_deg(o.half_angle_rad);
  params.range_gate = o.range_gate;
  params.range_gate_margin_m = o.range_gate_margin_m;
  params.height_gate = o.height_gate;
  params.height_gate_margin_m = o.height_gate_margin_m;
  return params;
}
}  // namespace

FilterParams FrequencyFilter::params() const {
  return {{"resolution_m", options_.resolution_m}, {"k", options_.k}, {"grid_origin_z_m", options_.grid_origin_z_m}};
}

void Filter::observe(const ScanView& scan) {
  std::vector<std::uint8_t> bits(scan.points.size());
  point_bits(scan, bits);
  insert(scan, bits);
}

void Filter::classify(const ScanView& scan, std::span<std::uint8_t> removed) const {
  TEAMSCAN_EXPECTS(removed.size() == scan.points.size());
  std::vector<std::uint8_t> bits(scan.points.size());
  point_bits(scan, bits);
  decide(scan.points, bits, removed);
}

void FrequencyFilter::decide(std::span<const MapPoint> points, std::span<const std::uint8_t>,
                             std::span<std::uint8_t> removed) const {
  TEAMSCAN_EXPECTS(removed.size() == points.size());
  const double limit = threshold();  // eq. 4: count < μ − k·σ
  for (std::size_t i = 0; i < points.size(); ++i)
    removed[i] = static_cast<double>(map_.count_at(points[i])) < limit ? 1 : 0;
}

void VisibilityFilter::decide(std::span<const MapPoint> points, std::span<const std::uint8_t>,
                              std::span<std::uint8_t> removed) const {
  TEAMSCAN_EXPECTS(removed.size() == points.size());
  for (std::size_t i = 0; i < points.size(); ++i) {
    // Eq. 5: an occupied voxel strictly below in the same column hides this one from a floor view.
    const VoxelKey k = map_.key_of(points[i]);
    const auto lowest = map_.column_lowest_z(k.x, k.y);
    removed[i] = (lowest && *lowest < k.z) ? 1 : 0;
  }
}

void PositionFilter::point_bits(const ScanView& scan, std::span<std::uint8_t> removed) const {
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
  FilterParams p{{"half_angle_deg", rad_to_deg(options_.half_angle_rad)},
                 {"from_flags", options_.source == DirectionSource::flags ? 1.0 : 0.0}};
  if (options_.range_gate) p.emplace_back("range_gate_margin_m", options_.range_gate_margin_m);
  if (options_.height_gate) p.emplace_back("height_gate_margin_m", options_.height_gate_margin_m);
  if (options_.range_gate || options_.height_gate) {
    p.emplace_back("body_radius_m", options_.body_radius_m);
    p.emplace_back("height_m", options_.height_m);
  }
  return p;
}

bool DirectionFilter::cone_contains(Vec2 self_m, Vec2 other_m, const MapPoint& p) const {
  const cone::DirectionFilterParams params = onboard_params(options_);
  const cone::Teammate mate{0, to_mm(other_m.x), to_mm(other_m.y), to_mm(options_.body_radius_m), to_mm(options_.height_m)};
  cone::ConeFixed fixed;
  if (!cone::prepare_cone(to_mm(self_m.x), to_mm(self_m.y), mate, options_.half_angle_rad, params, fixed)) return false;
  return cone::cone_contains(fixed, to_mm(p.x), to_mm(p.y), to_mm(p.z));
}

void DirectionFilter::point_bits(const ScanView& scan, std::span<std::uint8_t> removed) const {
  TEAMSCAN_EXPECTS(removed.size() == scan.points.size());
  std::fill(removed.begin(), removed.end(), std::uint8_t{0});
  if (options_.source == DirectionSource::flags) {
    // The robot's own decision, as it flagged the point before sending it.
    for (std::size_t i = 0; i < scan.flags.size() && i < removed.size(); ++i)
      removed[i] = (scan.flags[i] & point_flags::kDirectionFiltered) ? 1 : 0;
    return;
  }
  if (!scan.team) return;
  const cone::DirectionFilterParams params = onboard_params(options_);
  const std::int32_t apex_x_mm = to_mm(scan.map_from_robot.x_m), apex_y_mm = to_mm(scan.map_from_robot.y_m);
  for (const RobotEstimate& other : scan.team->robots) {
    if (other.robot == scan.robot || !other.valid) continue;
    // The cone is prepared once per teammate and scan, exactly as the daemon does (PAPER_NOTES 7).
    const cone::Teammate mate{other.robot, to_mm(other.position_m.x), to_mm(other.position_m.y),
                                 to_mm(options_.body_radius_m), to_mm(options_.height_m)};
    cone::ConeFixed fixed;
    if (!cone::prepare_cone(apex_x_mm, apex_y_mm, mate, options_.half_angle_rad, params, fixed)) continue;
    for (std::size_t i = 0; i < scan.points.size(); ++i) {
      const MapPoint& p = scan.points[i];
      if (cone::cone_contains(fixed, to_mm(p.x), to_mm(p.y), to_mm(p.z))) removed[i] = 1;
    }
  }
}

FilterParams SequentialFilter::params() const {
  FilterParams out;
  for (const auto& [name, value] : first_->params()) out.emplace_back(first_->method() + "." + name, value);
  for (const auto& [name, value] : second_->params()) out.emplace_back(second_->method() + "." + name, value);
  return out;
}

void SequentialFilter::survivors(const ScanView& scan, std::span<const std::uint8_t> bits, Survivors& out) const {
  out.points.clear();
  out.flags.clear();
  out.kept_index.clear();
  std::vector<std::uint8_t> first_bits(scan.points.size()), removed(scan.points.size());
  for (std::size_t i = 0; i < bits.size(); ++i) first_bits[i] = bits[i] & 0x0Fu;
  first_->decide(scan.points, first_bits, removed);
  for (std::size_t i = 0; i < scan.points.size(); ++i) {
    if (removed[i]) continue;
    out.points.push_back(scan.points[i]);
    if (i < scan.flags.size()) out.flags.push_back(scan.flags[i]);
    out.kept_index.push_back(i);
  }
}

void SequentialFilter::point_bits(const ScanView& scan, std::span<std::uint8_t> bits) const {
  TEAMSCAN_EXPECTS(bits.size() == scan.points.size());
  first_->point_bits(scan, bits);
  Survivors kept;
  survivors(scan, bits, kept);
  ScanView reduced = scan;
  reduced.points = kept.points;
  reduced.flags = kept.flags;
  std::vector<std::uint8_t> second_bits(kept.points.size());
  second_->point_bits(reduced, second_bits);
  for (std::size_t j = 0; j < kept.kept_index.size(); ++j)
    bits[kept.kept_index[j]] = static_cast<std::uint8_t>((bits[kept.kept_index[j]] & 0x0Fu) | ((second_bits[j] & 0x0Fu) << 4));
}

void SequentialFilter::insert(const ScanView& scan, std::span<const std::uint8_t> bits) {
  first_->insert(scan, bits);
  Survivors kept;
  survivors(scan, bits, kept);
  ScanView reduced = scan;
  reduced.points = kept.points;
  reduced.flags = kept.flags;
  std::vector<std::uint8_t> second_bits(kept.points.size());
  for (std::size_t j = 0; j < kept.kept_index.size(); ++j) second_bits[j] = static_cast<std::uint8_t>(bits[kept.kept_index[j]] >> 4);
  second_->insert(reduced, second_bits);
}

void SequentialFilter::decide(std::span<const MapPoint> points, std::span<const std::uint8_t> bits,
                              std::span<std::uint8_t> removed) const {
  TEAMSCAN_EXPECTS(removed.size() == points.size() && bits.size() == points.size());
  std::vector<std::uint8_t> low(points.size()), high(points.size()), second_removed(points.size());
  for (std::size_t i = 0; i < bits.size(); ++i) {
    low[i] = bits[i] & 0x0Fu;
    high[i] = static_cast<std::uint8_t>(bits[i] >> 4);
  }
  first_->decide(points, low, removed);
  // The second filter's decision only matters for the first's survivors (it saw only those).
  second_->decide(points, high, second_removed);
  for (std::size_t i = 0; i < points.size(); ++i) removed[i] = static_cast<std::uint8_t>(removed[i] | second_removed[i]);
}

const std::vector<std::string>& known_methods() {
  static const std::vector<std::string> methods{"frequency", "visibility", "position", "direction", "combined"};
  return methods;
}

const std::vector<std::string>& extended_methods() {
  static const std::vector<std::string> methods{"freespace", "tracked", "best"};
  return methods;
}

std::unique_ptr<Filter> make_filter(const std::string& method, const MethodOptions& options) {
  if (method == "freespace") return std::make_unique<FreespaceFilter>(options.freespace);
  if (method == "tracked") return std::make_unique<TrackedFilter>(options.tracked);
  if (method == "best") return make_best(options);
  if (method == "frequency") return std::make_unique<FrequencyFilter>(options.frequency);
  if (method == "visibility") return std::make_unique<VisibilityFilter>(options.visibility);
  if (method == "position") return std::make_unique<PositionFilter>(options.position);
  if (method == "direction") return std::make_unique<DirectionFilter>(options.direction);
  if (method == "combined") {
    DirectionOptions direction = options.direction;
    direction.half_angle_rad = options.combined_half_angle_rad;
    return std::make_unique<SequentialFilter>("combined", std::make_unique<DirectionFilter>(direction),
                                              std::make_unique<VisibilityFilter>(
                                                  VisibilityOptions{options.combined_resolution_m, options.combined_grid_origin_z_m}));
  }
  return nullptr;
}

}  // namespace teamscan::mapping
