// A data set's samples in the fusion core's time order, shared by `teamscan eval` and the station's
// catch-up (time_line.hpp).
#include "groundstation/fusion/time_line.hpp"

#include <algorithm>
#include <tuple>

namespace teamscan::fusion {

TimeLine::TimeLine(const Dataset& dataset, ScanPointsSource* points) : dataset_{dataset}, points_{points} {
  // Points grouped by (robot, scan), in data set order within a scan (read on demand: none here).
  if (points_ == nullptr)
    for (std::size_t i = 0; i < dataset.points.size(); ++i)
      by_scan_[{dataset.points[i].robot, dataset.points[i].scan}].push_back(i);
  std::map<std::pair<std::uint8_t, std::uint32_t>, bool> known;
  for (std::size_t row = 0; row < dataset.scans.size(); ++row) {
    const ScanRecord& r = dataset.scans[row];
    if (!known.emplace(std::make_pair(r.robot, r.scan), true).second) continue;
    records_.push_back(r);
    if (points_ != nullptr) rows_.push_back(row);
  }
  for (const auto& [key, indices] : by_scan_) {
    if (known.count(key)) continue;
    ScanRecord r;  // a scan with points but no row in scans.csv: at time 0 (no team state)
    r.robot = key.first;
    r.scan = key.second;
    records_.push_back(r);
  }
  events_.reserve(dataset.odom.size() + records_.size());
  for (std::size_t i = 0; i < dataset.odom.size(); ++i)
    events_.push_back({dataset.odom[i].stamp_ns, 0, dataset.odom[i].robot, 0, i});
  for (std::size_t i = 0; i < records_.size(); ++i)
    events_.push_back({records_[i].stamp_ns, 1, records_[i].robot, records_[i].scan, i});
  std::stable_sort(events_.begin(), events_.end(), [](const Event& a, const Event& b) {
    return std::tie(a.stamp_ns, a.kind, a.robot, a.scan) < std::tie(b.stamp_ns, b.kind, b.robot, b.scan);
  });
}

void TimeLine::feed(const std::function<void(PoseInput&)>& on_pose, const std::function<void(ScanInput&)>& on_scan,
                    const std::function<void(double)>& progress) const {
  const std::size_t progress_every = std::max<std::size_t>(1, events_.size() / 100);
  for (std::size_t k = 0; k < events_.size();) {
    if (progress) progress(static_cast<double>(k) / static_cast<double>(events_.size()));
    const std::size_t end = std::min(events_.size(), k + progress_every);
    while (k < end) k = feed_part(k, 1, on_pose, on_scan);  // one scan (and the poses before it) at a time
  }
}

std::size_t TimeLine::feed_part(std::size_t from, std::size_t max_scans, const std::function<void(PoseInput&)>& on_pose,
                                const std::function<void(ScanInput&)>& on_scan) const {
  std::size_t scans = 0;
  std::size_t k = from;
  for (; k < events_.size() && (max_scans == 0 || scans < max_scans); ++k) {
    const Event& e = events_[k];
    if (e.kind == 0) {
      const TrajectorySample& s = dataset_.odom[e.index];
      PoseInput p{s.robot, s.stamp_ns, s.stamp_ns, s.pose, s.v_mps, s.w_radps};
      on_pose(p);
      continue;
    }
    const ScanRecord& r = records_[e.index];
    ScanInput& in = scratch_;
    in.points.clear();
    in.flags.clear();
    in.beams.clear();
    if (points_ != nullptr) {
      (void)points_->read(rows_[e.index], in);  // a scan it cannot read goes on without points (counted there)
    } else if (auto it = by_scan_.find({r.robot, r.scan}); it != by_scan_.end()) {
      for (std::size_t i : it->second) {
        const LabelledPoint& lp = dataset_.points[i];
        in.points.push_back({lp.x, lp.y, lp.z});
        in.flags.push_back(lp.flags);
        in.beams.push_back(lp.beam);
      }
    }
    in.robot = r.robot;
    in.scan = r.scan;
    in.stamp_ns = r.stamp_ns;
    in.origin_m = r.origin;
    in.arrival_ns = r.stamp_ns;
    on_scan(in);
    ++scans;
  }
  return k;
}

void feed_in_time_order(const Dataset& dataset, FusionCore& core, bool flush) {
  TimeLine(dataset).feed([&](PoseInput& p) { core.add_pose(p); }, [&](ScanInput& s) { (void)core.add_scan(s); });
  if (flush) core.flush();
}

Result<std::size_t> refeed_in_time_order(const Dataset& dataset, CoreSet& cores, const std::function<void(double)>& progress,
                                         ScanPointsSource* points) {
  for (std::size_t i = 0; i < cores.size(); ++i)
    if (Status st = cores.at(i).reset(); !st.ok()) return st.error();
  const TimeLine time_line(dataset, points);
  time_line.feed([&](PoseInput& p) { cores.add_pose(p); }, [&](ScanInput& s) { (void)cores.add_scan(s); }, progress);
  return time_line.records().size();
}

}  // namespace teamscan::fusion
