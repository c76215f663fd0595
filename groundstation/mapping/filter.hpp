// The ghost-point filters behind one interface (DESIGN.md "The filters", PAPER_NOTES eqs. 4–8). The
// fusion core (groundstation/fusion/) runs them live and offline alike: a point part decided when a scan
// is fused, a map part read from the map when a decision is asked for. Later methods (`freespace`,
// `tracked`, `best`) are further Filter implementations.
#pragma once

#include <algorithm>
#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include "common/pose.hpp"
#include "groundstation/mapping/freespace_tracked_options.hpp"
#include "groundstation/mapping/tracker.hpp"
#include "groundstation/mapping/voxel_map.hpp"

namespace teamscan::mapping {

// One scan as a filter sees it: who measured it, when, from where, its points and their onboard
// flags (common/dataset point_flags), and the team's tracked state at the scan's time. Non-owning: the
// fusion core shows its held scan (groundstation/fusion/core.hpp ScanInput::view) to the filters and
// the release callback through one, with map_from_robot and team set; the evaluation views its
// prepared data set.
struct ScanView {
  std::uint8_t robot = 0;
  std::uint32_t scan = 0;
  std::int64_t stamp_ns = 0;
  Vec3 origin_m;                          // sensor origin, map frame
  Pose2 map_from_robot;                   // the robot's own odometry pose at the stamp
  std::span<const MapPoint> points;
  std::span<const std::uint16_t> flags;   // empty, or one per point
  const TeamState* team = nullptr;        // teammates predicted to stamp_ns (nullptr: none known)
};

// Named parameters of a filter, printed in reports and JSON ("params").
using FilterParams = std::vector<std::pair<std::string, double>>;

class Filter {
 public:
  virtual ~Filter() = default;
  // The method name as used on the command line, e.g. "visibility".
  [[nodiscard]] virtual std::string method() const = 0;
  [[nodiscard]] virtual FilterParams params() const = 0;

  // A filter's decision for a point has two parts (docs/groundstation.md "The fusion core"):
  //  - the point part, decided once when the scan is fused, from the scan and the team's state at the
  //    scan's time (the robot-based filters): a few bits per point, their meaning the filter's own;
  //  - the map part, read from the map's state whenever asked (the map-based filters): a function of
  //    the point's voxel and the map, so it is revised as the map grows.
  // The map state is a sum over the scans (counts), so it does not depend on the order scans come in:
  // live (scans in arrival order) and offline (in time order) reach the same map and the same decisions.
  //
  // The point part of every point of `scan` into `bits` (0 where nothing robot-based applies).
  virtual void point_bits(const ScanView& scan, std::span<std::uint8_t> bits) const = 0;
  // Folds the scan into the map state (nothing for the robot-based filters); `bits` from point_bits().
  virtual void insert(const ScanView& scan, std::span<const std::uint8_t> bits) = 0;
  // The decision for each point from its bits and the map as it is now: removed[i] = 1 filters point i.
  virtual void decide(std::span<const MapPoint> points, std::span<const std::uint8_t> bits,
                      std::span<std::uint8_t> removed) const = 0;
  // Forgets all state (a new survey).
  virtual void reset() = 0;
  // Heap bytes of the map state (0 for the robot-based filters, which keep none).
  [[nodiscard]] virtual std::size_t memory_bytes() const { return 0; }

  // Convenience for one scan at a time (tests, benchmarks): observe() = point_bits() + insert();
  // classify() = point_bits() + decide() against the map so far. Live: classify after observe of the
  // same scan. Offline: after observe() of every scan.
  void observe(const ScanView& scan);
  void classify(const ScanView& scan, std::span<std::uint8_t> removed) const;
};

// ---- options, defaults from PAPER_NOTES.md -------------------------------------------------------

// Eq. 4: filter a point if its voxel's count < μ − k·σ over occupied voxels.
struct FrequencyOptions {
  double resolution_m = 0.05;
  double k = 0.0;  // the paper gives no value
  double grid_origin_z_m = 0.0;  // vertical grid offset (VoxelMap); paper: 0
};

// Eq. 5: filter a point if an occupied voxel lies strictly below its voxel in the same column.
struct VisibilityOptions {
  double resolution_m = 0.05;
  // Vertical grid offset (VoxelMap). Paper: 0, which puts a floor at z = 0 on a voxel boundary so its
  // noise straddles two voxels and eq. 5 removes the upper half of the floor; −r/2 centres it.
  double grid_origin_z_m = 0.0;
};

// Eq. 6: filter p if its horizontal distance to another robot's position < n·σ.
struct PositionOptions {
  double sigma_m = 0.35;  // from the robot's size (Pioneer 3-AT footprint 0.626 × 0.505 m)
  double n = 1.0;
};

// Where the direction filter's decisions come from.
enum class DirectionSource : std::uint8_t {
  recompute = 0,  // evaluate eq. 7 here, from the own pose and the tracked teammates
  flags = 1,      // use point_flags::kDirectionFiltered as the onboard filter recorded it
};

// Eq. 7: filter p if it lies ahead of R1 along the horizontal line L from R1 to R2 and
// d_p(p, L) < d_r(p_L)·tan(ha). Recomputed offline with the robot's own fixed-point code
// (onboard/cone/direction_cone.hpp: cone::prepare_cone + cone::cone_contains on int32 mm), so offline and live
// decisions are the same arithmetic. Gates off = the paper's rule, unchanged.
struct DirectionOptions {
  double half_angle_rad = 0.12217304763960307;  // 7° (paper: 5° and 7°); the onboard code caps it at 60°
  DirectionSource source = DirectionSource::recompute;
  // Project's variant, range gate: only points whose distance along L is within
  // body_radius_m + range_gate_margin_m of the teammate's distance.
  bool range_gate = false;
  double range_gate_margin_m = 0.3;
  // Project's variant, height gate: only points no higher than height_m + height_gate_margin_m.
  bool height_gate = false;
  double height_gate_margin_m = 0.1;
  // The teammate's body (Pioneer 3-AT half-diagonal and height with the laser), as the onboard default.
  double body_radius_m = 0.36;
  double height_m = 0.5;
};

// ---- the filters --------------------------------------------------------------------------------

class FrequencyFilter final : public Filter {
 public:
  explicit FrequencyFilter(FrequencyOptions options)
      : options_{options}, map_{options.resolution_m, options.grid_origin_z_m} {}
  [[nodiscard]] std::string method() const override { return "frequency"; }
  [[nodiscard]] FilterParams params() const override;
  void point_bits(const ScanView&, std::span<std::uint8_t> bits) const override { std::fill(bits.begin(), bits.end(), 0); }
  void insert(const ScanView& scan, std::span<const std::uint8_t>) override { map_.insert(scan.points); }
  void decide(std::span<const MapPoint> points, std::span<const std::uint8_t> bits,
              std::span<std::uint8_t> removed) const override;
  void reset() override { map_.clear(); }
  [[nodiscard]] std::size_t memory_bytes() const override { return map_.memory_bytes(); }
  [[nodiscard]] const VoxelMap& map() const { return map_; }
  [[nodiscard]] double threshold() const { return map_.mean_count() - options_.k * map_.stddev_count(); }

 private:
  FrequencyOptions options_;
  VoxelMap map_;
};

class VisibilityFilter final : public Filter {
 public:
  explicit VisibilityFilter(VisibilityOptions options)
      : options_{options}, map_{options.resolution_m, options.grid_origin_z_m} {}
  [[nodiscard]] std::string method() const override { return "visibility"; }
  [[nodiscard]] FilterParams params() const override {
    return {{"resolution_m", options_.resolution_m}, {"grid_origin_z_m", options_.grid_origin_z_m}};
  }
  void point_bits(const ScanView&, std::span<std::uint8_t> bits) const override { std::fill(bits.begin(), bits.end(), 0); }
  void insert(const ScanView& scan, std::span<const std::uint8_t>) override { map_.insert(scan.points); }
  void decide(std::span<const MapPoint> points, std::span<const std::uint8_t> bits,
              std::span<std::uint8_t> removed) const override;
  void reset() override { map_.clear(); }
  [[nodiscard]] std::size_t memory_bytes() const override { return map_.memory_bytes(); }
  [[nodiscard]] const VoxelMap& map() const { return map_; }

 private:
  VisibilityOptions options_;
  VoxelMap map_;
};

class PositionFilter final : public Filter {
 public:
  explicit PositionFilter(PositionOptions options) : options_{options} {}
  [[nodiscard]] std::string method() const override { return "position"; }
  [[nodiscard]] FilterParams params() const override { return {{"sigma_m", options_.sigma_m}, {"n", options_.n}}; }
  void point_bits(const ScanView& scan, std::span<std::uint8_t> bits) const override;
  void insert(const ScanView&, std::span<const std::uint8_t>) override {}
  void decide(std::span<const MapPoint>, std::span<const std::uint8_t> bits, std::span<std::uint8_t> removed) const override {
    std::copy(bits.begin(), bits.end(), removed.begin());
  }
  void reset() override {}

 private:
  PositionOptions options_;
};

class DirectionFilter final : public Filter {
 public:
  explicit DirectionFilter(DirectionOptions options) : options_{options} {}
  [[nodiscard]] std::string method() const override { return "direction"; }
  [[nodiscard]] FilterParams params() const override;
  void point_bits(const ScanView& scan, std::span<std::uint8_t> bits) const override;
  void insert(const ScanView&, std::span<const std::uint8_t>) override {}
  void decide(std::span<const MapPoint>, std::span<const std::uint8_t> bits, std::span<std::uint8_t> removed) const override {
    std::copy(bits.begin(), bits.end(), removed.begin());
  }
  void reset() override {}
  // The decision for one point against one teammate, as the robot computes it (int32 mm, fixed point).
  [[nodiscard]] bool cone_contains(Vec2 self_m, Vec2 other_m, const MapPoint& p) const;

 private:
  DirectionOptions options_;
};

// Runs `first`, then `second` on the points `first` kept: `second` builds its state only from the
// survivors, as at the ground station when the robots already dropped what their filter removed.
// The paper's combined method is Sequential(direction ha 7°, visibility 0.1 m) (PAPER_NOTES 8).
// `first` must be robot-based (its decision a function of the point's bits alone), so the survivors are
// known when the scan is inserted; a point's bits are first's in the low 4 bits, second's in the high 4.
class SequentialFilter final : public Filter {
 public:
  SequentialFilter(std::string method, std::unique_ptr<Filter> first, std::unique_ptr<Filter> second)
      : method_{std::move(method)}, first_{std::move(first)}, second_{std::move(second)} {}
  [[nodiscard]] std::string method() const override { return method_; }
  [[nodiscard]] FilterParams params() const override;
  void point_bits(const ScanView& scan, std::span<std::uint8_t> bits) const override;
  void insert(const ScanView& scan, std::span<const std::uint8_t> bits) override;
  void decide(std::span<const MapPoint> points, std::span<const std::uint8_t> bits,
              std::span<std::uint8_t> removed) const override;
  void reset() override {
    first_->reset();
    second_->reset();
  }
  [[nodiscard]] std::size_t memory_bytes() const override { return first_->memory_bytes() + second_->memory_bytes(); }

 private:
  // The scan reduced to the points `first` keeps; `kept_index` maps back to the scan's indices.
  struct Survivors {
    std::vector<MapPoint> points;
    std::vector<std::uint16_t> flags;
    std::vector<std::size_t> kept_index;
  };
  void survivors(const ScanView& scan, std::span<const std::uint8_t> bits, Survivors& out) const;

  std::string method_;
  std::unique_ptr<Filter> first_;
  std::unique_ptr<Filter> second_;
};

// Every method's options in one place (a method picks the ones it uses).
struct MethodOptions {
  FrequencyOptions frequency;
  VisibilityOptions visibility;
  PositionOptions position;
  DirectionOptions direction;
  // combined = direction (this half-angle) then visibility (this resolution): the paper's Table 6.
  double combined_half_angle_rad = 0.12217304763960307;  // 7°
  double combined_resolution_m = 0.1;
  double combined_grid_origin_z_m = 0.0;
  // Beyond the paper (docs/beyond.md): freespace, tracked, and best = tracked ∪ freespace(best_freespace).
  FreespaceOptions freespace;
  TrackedOptions tracked;
  // best's freespace part demands 8 passes per hit: chosen on tables4/team3 (docs/beyond.md); it casts
  // every third ray of a scan: a third of the walk, the same DA/SA within 0.01 point on the nine
  // scenarios (docs/beyond.md "A cheaper free-space walk").
  FreespaceOptions best_freespace = [] {
    FreespaceOptions o;
    o.free_per_hit = 8.0;
    o.ray_stride = 3;
    return o;
  }();
  // best: a point only in the band the odometry drift adds to a body box goes when its voxel's free
  // passes ≥ this many per hit (and ≥ min_free): a lenient freespace rule, applied only there (docs/beyond.md).
  double best_drift_band_free_per_hit = 2.0;
};

// The methods this library knows, in report order.
[[nodiscard]] const std::vector<std::string>& known_methods();
// The methods beyond the paper: accepted by name, not part of "all".
[[nodiscard]] const std::vector<std::string>& extended_methods();
// A filter for `method` ("frequency", "visibility", "position", "direction", "combined"), or nullptr.
[[nodiscard]] std::unique_ptr<Filter> make_filter(const std::string& method, const MethodOptions& options);

}  // namespace teamscan::mapping
