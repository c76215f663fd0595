// The set of fusion cores a station runs: the primary method's core and one more per compared method,
// each with the primary's options but its method, every one fed the same poses and scans in the same
// order (live, in a session replay, in the demo's check of the station's models), so each decides as
// `teamscan eval --method <method>` does.
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "common/result.hpp"
#include "groundstation/fusion/core.hpp"

namespace teamscan::fusion {

class CoreSet {
 public:
  // Fails on a bad primary (its core's error), an unknown compared method, or a compared method that is
  // the primary or listed twice.
  [[nodiscard]] static Result<std::unique_ptr<CoreSet>> create(const CoreOptions& primary,
                                                               const std::vector<std::string>& compared);

  void add_pose(const PoseInput& pose);
  // Every core takes the scan; false: the primary found it a replay of a (robot, seq) fused recently.
  bool add_scan(const ScanInput& scan);
  void flush();
  void advance_to(std::int64_t arrival_ns);
  void resume_at(std::int64_t arrival_ns);
  // Every core takes over the state of `other`'s core of the same place (FusionCore::take_state): the
  // objects, their release callbacks and references to them stay; `other` is left with their old
  // states. `other` has the same methods.
  void take_state(CoreSet& other);

  [[nodiscard]] FusionCore& primary() { return *cores_.front(); }
  [[nodiscard]] const FusionCore& primary() const { return *cores_.front(); }
  // Core i: 0 the primary, then the compared methods in the order given.
  [[nodiscard]] std::size_t size() const { return cores_.size(); }
  [[nodiscard]] FusionCore& at(std::size_t i) { return *cores_[i]; }
  [[nodiscard]] const FusionCore& at(std::size_t i) const { return *cores_[i]; }
  // A compared method's core, or nullptr.
  [[nodiscard]] const FusionCore* compared(const std::string& method) const;

 private:
  explicit CoreSet(std::vector<std::unique_ptr<FusionCore>> cores) : cores_{std::move(cores)} {}
  std::vector<std::unique_ptr<FusionCore>> cores_;
};

}  // namespace teamscan::fusion
