// CoreRebuild: cores rebuilt from a data set in time order in slices, the live inputs queued behind it
// (core_rebuild.hpp).
#include "groundstation/fusion/core_rebuild.hpp"

#include <utility>

namespace teamscan::fusion {

Result<RebuildSource> make_rebuild_source(Dataset dataset, const CoreOptions& primary,
                                          const std::vector<std::string>& compared, std::unique_ptr<ScanPointsSource> points) {
  RebuildSource s;
  auto cores = CoreSet::create(primary, compared);
  if (!cores) return cores.error();
  s.cores = std::move(cores.value());
  s.dataset = std::make_unique<Dataset>(std::move(dataset));
  s.points = std::move(points);
  s.time_line = std::make_unique<TimeLine>(*s.dataset, s.points.get());
  return s;
}

std::size_t feed_time_line(RebuildSource& source, std::size_t max_scans) {
  CoreSet& cores = *source.cores;
  std::size_t fed = 0;
  source.events_fed = source.time_line->feed_part(
      source.events_fed, max_scans, [&](PoseInput& p) { cores.add_pose(p); },
      [&](ScanInput& s) {
        (void)cores.add_scan(s);
        ++fed;
      });
  source.scans_fed += fed;
  return fed;
}

void CoreRebuild::add_pose(const PoseInput& pose) {
  Input& in = queue_.emplace_back();
  in.kind = Input::Kind::pose;
  in.pose = pose;
  ++progress_.queued;
}

void CoreRebuild::add_scan(const ScanInput& scan) {
  Input& in = queue_.emplace_back();
  in.kind = Input::Kind::scan;
  in.scan = scan;
  ++progress_.queued;
}

void CoreRebuild::advance_to(std::int64_t arrival_ns) {
  Input& in = queue_.emplace_back();
  in.kind = Input::Kind::clock;
  in.clock_ns = arrival_ns;
  ++progress_.queued;
}

void CoreRebuild::load(RebuildSource source) {
  source_ = std::move(source);
  progress_.time_line_scans = source_.time_line->records().size();
  progress_.fed_scans = source_.scans_fed;
}

bool CoreRebuild::step(std::size_t max_scans) {
  if (!loaded()) return false;
  CoreSet& cores = *source_.cores;
  std::size_t fed = 0, inputs = 0;
  const std::size_t events = source_.time_line->events();
  if (source_.events_fed < events) {
    (void)feed_time_line(source_, max_scans);
    progress_.fed_scans = source_.scans_fed;
    ++progress_.steps;
    return false;  // the queue from the next call on: the caller sees the session's end in between
  }
  if (!resumed_) {
    cores.resume_at(resume_at_ns_);  // as the instant catch-up: the live clock goes on from its start
    resumed_ = true;
  }
  while (!queue_.empty() && (max_scans == 0 || fed < max_scans)) {
    Input& in = queue_.front();
    switch (in.kind) {
      case Input::Kind::pose:
        cores.add_pose(in.pose);
        break;
      case Input::Kind::scan:
        (void)cores.add_scan(in.scan);
        ++fed;
        ++progress_.queued_fed_scans;
        break;
      case Input::Kind::clock:
        cores.advance_to(in.clock_ns);
        break;
    }
    queue_.pop_front();
    --progress_.queued;
    ++inputs;
  }
  if (inputs > 0) ++progress_.steps;
  return queue_.empty();
}

}  // namespace teamscan::fusion
