// The winning combination (issue 7 "best"), chosen in docs/beyond.md from `teamscan eval` figures.
#include "groundstation/mapping/best.hpp"

#include "common/result.hpp"
#include "groundstation/mapping/freespace_filter.hpp"
#include "groundstation/mapping/tracked_filter.hpp"

namespace teamscan::mapping {

FilterParams UnionFilter::params() const {
  FilterParams out;
  for (const auto& p : parts_)
    for (const auto& [k, v] : p->params()) out.emplace_back(p->method() + "." + k, v);
  return out;
}

void UnionFilter::classify(const ScanView& scan, std::span<std::uint8_t> removed) const {
  TEAMSCAN_EXPECTS(removed.size() == scan.points.size());
  std::fill(removed.begin(), removed.end(), std::uint8_t{0});
  std::vector<std::uint8_t> part(scan.points.size());
  for (const auto& p : parts_) {
    p->classify(scan, part);
    for (std::size_t i = 0; i < part.size(); ++i) removed[i] = static_cast<std::uint8_t>(removed[i] | part[i]);
  }
}

std::unique_ptr<Filter> make_best(const MethodOptions& options) {
  std::vector<std::unique_ptr<Filter>> parts;
  parts.push_back(std::make_unique<TrackedFilter>(options.tracked));
  parts.push_back(std::make_unique<FreespaceFilter>(options.best_freespace));
  return std::make_unique<UnionFilter>("best", std::move(parts));
}

}  // namespace teamscan::mapping
