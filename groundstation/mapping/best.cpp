// The winning combination, chosen in docs/beyond.md from `teamscan eval` figures.
#include "groundstation/mapping/best.hpp"

#include <algorithm>

#include "common/result.hpp"

namespace teamscan::mapping {

namespace {
TrackedOptions with_drift(TrackedOptions o, bool drift) {
  o.include_drift = drift;
  return o;
}
}  // namespace

BestFilter::BestFilter(TrackedOptions tracked, FreespaceOptions freespace, double drift_band_free_per_hit)
    : core_{with_drift(tracked, false)},
      outer_{with_drift(tracked, true)},
      freespace_{freespace},
      drift_band_free_per_hit_{drift_band_free_per_hit},
      min_free_{freespace.min_free} {}

FilterParams BestFilter::params() const {
  FilterParams out;
  for (const auto& [k, v] : outer_.params())
    if (k != "include_drift") out.emplace_back("tracked." + k, v);
  for (const auto& [k, v] : freespace_.params()) out.emplace_back("freespace." + k, v);
  out.emplace_back("drift_band_free_per_hit", drift_band_free_per_hit_);
  return out;
}

void BestFilter::point_bits(const ScanView& scan, std::span<std::uint8_t> bits) const {
  TEAMSCAN_EXPECTS(bits.size() == scan.points.size());
  const std::size_t n = scan.points.size();
  // Scratch per call (not a firmware path: the ground station's fusion core, docs/groundstation.md).
  std::vector<std::uint8_t> core(n), band(n);
  core_.point_bits(scan, core);
  outer_.point_bits(scan, band);
  for (std::size_t i = 0; i < n; ++i) bits[i] = core[i] ? kCore : band[i] ? kBand : 0;
}

void BestFilter::decide(std::span<const MapPoint> points, std::span<const std::uint8_t> bits,
                        std::span<std::uint8_t> removed) const {
  TEAMSCAN_EXPECTS(removed.size() == points.size() && bits.size() == points.size());
  const FreespaceGrid& grid = freespace_.grid();
  const double min_free = static_cast<double>(std::max<std::uint32_t>(1, min_free_));
  FreespaceGrid::Lookup lookup;
  for (std::size_t i = 0; i < points.size(); ++i) {
    removed[i] = 0;
    if (bits[i] & kCore) {
      removed[i] = 1;
      continue;
    }
    const MapPoint& p = points[i];
    if (grid.transient(p, lookup)) {
      removed[i] = 1;
      continue;
    }
    if (!(bits[i] & kBand)) continue;
    const FreeCell c = grid.cell(grid.key_of(p.x, p.y, p.z), lookup);
    if (static_cast<double>(c.free) >= min_free && grid.rays_through(c) >= drift_band_free_per_hit_ * static_cast<double>(c.hits)) removed[i] = 1;
  }
}

std::unique_ptr<Filter> make_best(const MethodOptions& options) {
  return std::make_unique<BestFilter>(options.tracked, options.best_freespace, options.best_drift_band_free_per_hit);
}

}  // namespace teamscan::mapping
