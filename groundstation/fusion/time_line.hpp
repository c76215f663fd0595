// A data set's odometry and scans as the fusion core's inputs in the one order both `teamscan eval` and
// the station's catch-up (station/fusion.hpp FusionStage::catch_up) feed a core: live = offline.
//
// The rule: by stamp; at one stamp the poses before the scans (the pose at a scan's stamp is its pose),
// then by robot, then by scan number; each (robot, scan) once (a DDS history replay or a back-fill the
// session holds twice counts once); a scan's arrival is its stamp. A point whose scan has no scan row
// still belongs to a scan (stamped 0: no team state).
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <map>
#include <utility>
#include <vector>

#include "common/dataset/dataset.hpp"
#include "common/result.hpp"
#include "groundstation/fusion/core.hpp"
#include "groundstation/fusion/core_set.hpp"

namespace teamscan::fusion {

// A data set's points read on demand, for a data set that holds its scan rows but not their points
// (Dataset::points empty): the station's session folder read back for its final model, whose points
// would not all fit in memory after a long mission.
class ScanPointsSource {
 public:
  virtual ~ScanPointsSource() = default;
  // The points of scan row `row` (Dataset::scans) into in.points, in.flags and in.beams, which come
  // cleared. false: they could not be read (the source counts it); the scan goes on without points.
  virtual bool read(std::size_t row, ScanInput& in) = 0;
};

class TimeLine {
 public:
  // `points` (optional, outliving the time line): where the scans' points are read from instead of
  // dataset.points, one scan at a time as it is fed.
  explicit TimeLine(const Dataset& dataset, ScanPointsSource* points = nullptr);

  // Calls on_pose / on_scan for every pose and scan in time order, with the input as the core takes it
  // (the callee may change it, e.g. add pose noise, before handing it to a core). A scan's input views
  // scratch storage that lives until the next call. `progress` (optional): the share fed so far, about
  // every 1 %.
  void feed(const std::function<void(PoseInput&)>& on_pose, const std::function<void(ScanInput&)>& on_scan,
            const std::function<void(double)>& progress = {}) const;
  // feed() in parts, the same calls in the same order: from event `from` on until `max_scans` scans were
  // fed (0: to the end). Returns the next event to feed (events() once all are fed).
  std::size_t feed_part(std::size_t from, std::size_t max_scans, const std::function<void(PoseInput&)>& on_pose,
                        const std::function<void(ScanInput&)>& on_scan) const;
  // The poses and scans to feed.
  [[nodiscard]] std::size_t events() const { return events_.size(); }

  // The scan rows fed (each (robot, scan) once) and every scan's point indices in Dataset::points.
  [[nodiscard]] const std::vector<ScanRecord>& records() const { return records_; }
  [[nodiscard]] const std::map<std::pair<std::uint8_t, std::uint32_t>, std::vector<std::size_t>>& points_by_scan()
      const {
    return by_scan_;
  }

 private:
  struct Event {
    std::int64_t stamp_ns;
    int kind;  // 0 pose, 1 scan
    std::uint8_t robot;
    std::uint32_t scan;
    std::size_t index;  // in Dataset::odom or records_
  };
  const Dataset& dataset_;
  ScanPointsSource* points_;
  std::map<std::pair<std::uint8_t, std::uint32_t>, std::vector<std::size_t>> by_scan_;
  std::vector<ScanRecord> records_;
  std::vector<std::size_t> rows_;  // with points_: each record's row in dataset.scans
  std::vector<Event> events_;
  mutable ScanInput scratch_;  // a fed scan's input: its vectors keep their capacity
};

// A data set through `core` in time order (TimeLine), then every held scan released (flush): the core's
// model is then the one `teamscan eval` decides. `flush` false: the newest scans stay held (a live
// station going on from there).
void feed_in_time_order(const Dataset& dataset, FusionCore& core, bool flush = true);

// Every core of `cores` reset (FusionCore::reset) and fed the data set in time order, the newest scans
// left held: the station's catch-up after a back-fill (station/fusion.hpp FusionStage::catch_up) and the
// demo's replay of it. Returns the scans fed. `progress` (optional) as TimeLine::feed's.
// `points` as TimeLine's.
[[nodiscard]] Result<std::size_t> refeed_in_time_order(const Dataset& dataset, CoreSet& cores,
                                                       const std::function<void(double)>& progress = {},
                                                       ScanPointsSource* points = nullptr);

}  // namespace teamscan::fusion
