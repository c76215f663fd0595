// CoreSet: the primary core and the compared methods' cores, fed alike (core_set.hpp).
#include "groundstation/fusion/core_set.hpp"

#include <algorithm>

namespace teamscan::fusion {

Result<std::unique_ptr<CoreSet>> CoreSet::create(const CoreOptions& primary, const std::vector<std::string>& compared) {
  std::vector<std::string> methods{primary.method};
  for (const std::string& m : compared) {
    if (std::find(methods.begin(), methods.end(), m) != methods.end())
      return Error{"fusion: a compared method is the primary method or listed twice (fusion.compare_methods)"};
    methods.push_back(m);
  }
  std::vector<std::unique_ptr<FusionCore>> cores;
  for (const std::string& m : methods) {
    CoreOptions o = primary;
    o.method = m;
    auto core = FusionCore::create(o);
    if (!core.ok()) {
      if (m == primary.method) return core.error();
      return Error{"fusion: unknown compared method (fusion.compare_methods)"};
    }
    cores.push_back(std::move(core.value()));
  }
  return std::unique_ptr<CoreSet>(new CoreSet(std::move(cores)));
}

void CoreSet::add_pose(const PoseInput& pose) {
  for (const auto& c : cores_) c->add_pose(pose);
}

bool CoreSet::add_scan(const ScanInput& scan) {
  const bool fused = cores_.front()->add_scan(scan);
  for (std::size_t i = 1; i < cores_.size(); ++i) (void)cores_[i]->add_scan(scan);
  return fused;
}

void CoreSet::flush() {
  for (const auto& c : cores_) c->flush();
}

void CoreSet::advance_to(std::int64_t arrival_ns) {
  for (const auto& c : cores_) c->advance_to(arrival_ns);
}

void CoreSet::resume_at(std::int64_t arrival_ns) {
  for (const auto& c : cores_) c->resume_at(arrival_ns);
}

void CoreSet::take_state(CoreSet& other) {
  for (std::size_t i = 0; i < cores_.size() && i < other.cores_.size(); ++i) cores_[i]->take_state(*other.cores_[i]);
}

const FusionCore* CoreSet::compared(const std::string& method) const {
  for (std::size_t i = 1; i < cores_.size(); ++i)
    if (cores_[i]->options().method == method) return cores_[i].get();
  return nullptr;
}

}  // namespace teamscan::fusion
