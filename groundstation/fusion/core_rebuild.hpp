// A set of fusion cores rebuilt from a data set in time order a slice at a time, while the live cores go
// on: the station's catch-up after a radio shadow (station/fusion.hpp) without holding its loop. The
// inputs that come live after the data set's end are queued here in their order and fed behind it, so
// the rebuilt cores end as the instant catch-up (refeed_in_time_order, then the same live inputs) would
// have left them, however the work was sliced: live = offline stays exact.
//
// A state machine on the caller's thread (no threads): the data set is read elsewhere and handed to
// load(), its time line fed already or not (feed_time_line, on the reader's thread). No I/O once the time
// line is fed; before, a data set whose points are read on demand (RebuildSource::points) reads them.
#pragma once

#include <cstddef>
#include <cstdint>
#include <deque>
#include <memory>
#include <string>
#include <vector>

#include "common/dataset/dataset.hpp"
#include "common/result.hpp"
#include "groundstation/fusion/core.hpp"
#include "groundstation/fusion/core_set.hpp"
#include "groundstation/fusion/time_line.hpp"

namespace teamscan::fusion {

// What a rebuild starts from, made off the caller's loop (it reads and sorts the whole data set): the
// data set, its time line and a fresh set of cores.
struct RebuildSource {
  std::unique_ptr<Dataset> dataset;
  // Where the time line reads the scans' points when the data set holds only its rows (null: from
  // dataset->points). Feeding the time line then reads them: the station's loader feeds it whole.
  std::unique_ptr<ScanPointsSource> points;
  std::unique_ptr<TimeLine> time_line;  // over *dataset
  std::unique_ptr<CoreSet> cores;
  std::size_t events_fed = 0;  // the time line's events the cores were fed already (feed_time_line)
  std::size_t scans_fed = 0;   // ... of which scans
};
[[nodiscard]] Result<RebuildSource> make_rebuild_source(Dataset dataset, const CoreOptions& primary,
                                                        const std::vector<std::string>& compared,
                                                        std::unique_ptr<ScanPointsSource> points = nullptr);
// Feeds the source's cores its time line on from source.events_fed until `max_scans` scans were fed (0: to
// its end) and returns how many. CoreRebuild::step() feeds it a slice at a time; the station's loader
// feeds it whole on the thread that read the data set, the release callbacks set, so that step() only
// feeds what came live behind it: the same calls in the same order either way.
std::size_t feed_time_line(RebuildSource& source, std::size_t max_scans = 0);

struct RebuildProgress {
  std::size_t time_line_scans = 0;  // the data set's scans (0 before load())
  std::size_t fed_scans = 0;        // of those, fed
  std::size_t queued = 0;           // live inputs waiting (poses, scans, clock steps)
  std::size_t queued_fed_scans = 0; // live scans fed behind the data set
  std::uint64_t steps = 0;          // step() calls that fed anything
};

class CoreRebuild {
 public:
  // The live arrival clock the cores resume at after the data set (the instant the catch-up began).
  explicit CoreRebuild(std::int64_t resume_at_ns) : resume_at_ns_{resume_at_ns} {}

  // The live inputs after the data set's end, in the order the live cores took them.
  void add_pose(const PoseInput& pose);
  void add_scan(const ScanInput& scan);
  void advance_to(std::int64_t arrival_ns);

  // The data set to rebuild from (its time line fed already as far as source.events_fed); until then
  // step() feeds nothing.
  void load(RebuildSource source);
  [[nodiscard]] bool loaded() const { return source_.cores != nullptr; }
  // Feeds the cores at most `max_scans` scans (0: no limit), the data set's in time order first, then (from
  // the call after the one that fed its end) the queued live ones; poses and clock steps in between come
  // with them. True once everything loaded and queued so far is fed: the cores are then the instant
  // catch-up's followed by the live inputs.
  bool step(std::size_t max_scans);
  // The data set fed (the queue may still hold live inputs).
  [[nodiscard]] bool time_line_done() const { return loaded() && source_.events_fed >= source_.time_line->events(); }

  [[nodiscard]] CoreSet& cores() { return *source_.cores; }
  [[nodiscard]] const RebuildProgress& progress() const { return progress_; }

 private:
  struct Input {
    enum class Kind : std::uint8_t { pose, scan, clock } kind = Kind::pose;
    PoseInput pose{};
    ScanInput scan;
    std::int64_t clock_ns = 0;
  };
  std::int64_t resume_at_ns_;
  RebuildSource source_;
  bool resumed_ = false;
  std::deque<Input> queue_;
  RebuildProgress progress_;
};

}  // namespace teamscan::fusion
