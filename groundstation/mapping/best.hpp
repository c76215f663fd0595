// `best` (issue 7, docs/beyond.md): the combination that won on the numbers — a point goes when any
// part removes it. Each part sees every point of the scan (unlike SequentialFilter), so the map-based
// part's free-space evidence is built from all rays.
#pragma once

#include <memory>
#include <vector>

#include "groundstation/mapping/filter.hpp"

namespace teamscan::mapping {

class UnionFilter final : public Filter {
 public:
  UnionFilter(std::string method, std::vector<std::unique_ptr<Filter>> parts)
      : method_{std::move(method)}, parts_{std::move(parts)} {}
  [[nodiscard]] std::string method() const override { return method_; }
  [[nodiscard]] FilterParams params() const override;
  void observe(const ScanView& scan) override {
    for (auto& p : parts_) p->observe(scan);
  }
  void classify(const ScanView& scan, std::span<std::uint8_t> removed) const override;
  void reset() override {
    for (auto& p : parts_) p->reset();
  }

 private:
  std::string method_;
  std::vector<std::unique_ptr<Filter>> parts_;
};

// The default `best`: tracked ∪ freespace with the options in `options` (see docs/beyond.md).
[[nodiscard]] std::unique_ptr<Filter> make_best(const MethodOptions& options);

}  // namespace teamscan::mapping
