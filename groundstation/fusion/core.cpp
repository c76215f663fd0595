// FusionCore: held scans, release, point part + map, model store (core.hpp).
#include "groundstation/fusion/core.hpp"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>

#include "common/dataset/pcd.hpp"

namespace teamscan::fusion {

namespace {
bool is_identity(const Pose2& p) { return p.x_m == 0.0 && p.y_m == 0.0 && p.theta_rad == 0.0; }

Status write_atomically(const std::string& path, const PcdCloud& cloud, const std::vector<PcdField>& layout) {
  const std::string tmp = path + ".tmp";
  if (Status st = write_pcd(tmp, cloud, layout); !st.ok()) return st;
  if (std::rename(tmp.c_str(), path.c_str()) != 0) return Error{"fusion: cannot rename the fused PCD into place", errno};
  return ok_status();
}
}  // namespace

Result<std::unique_ptr<FusionCore>> FusionCore::create(const CoreOptions& options) {
  std::unique_ptr<mapping::Filter> filter = mapping::make_filter(options.method, options.methods);
  if (!filter) return Error{"fusion: unknown filter method (fusion.method)"};
  if (!(options.hold_s >= 0.0)) return Error{"fusion: hold_s must be >= 0"};
  if (!(options.tracker.team_lag_s >= 0.0 && options.tracker.team_lag_s <= 10.0))
    return Error{"fusion: team_lag_s must be in [0, 10] s"};
  if (!(options.pose_keep_s > 0.0)) return Error{"fusion: pose_keep_s must be > 0"};
  if (options.max_points_per_voxel > 0 && !(options.model_resolution_m > 0.0))
    return Error{"fusion: model resolution must be > 0 (fusion.model_resolution_m)"};
  return std::unique_ptr<FusionCore>(new FusionCore(options, std::move(filter)));
}

FusionCore::FusionCore(const CoreOptions& options, std::unique_ptr<mapping::Filter> filter)
    : options_{options},
      filter_{std::move(filter)},
      poses_{PoseHistoryOptions{options.tracker, options.pose_keep_s}},
      seq_windows_(kMaxRobots + 1) {
  if (options_.model_resolution_m > 0.0) inverse_model_resolution_ = 1.0 / options_.model_resolution_m;
  bits_.reserve(kMaxBeams);
  removed_.reserve(kMaxBeams);
}

void FusionCore::add_pose(const PoseInput& pose) {
  ++counters_.poses_in;
  if (first_arrival_ns_ == INT64_MIN) first_arrival_ns_ = pose.arrival_ns;
  if (!poses_.add(pose)) {
    ++counters_.poses_rejected;
  } else if (pose.robot <= kMaxRobots) {
    last_pose_arrival_ns_[pose.robot] = std::max(last_pose_arrival_ns_[pose.robot], pose.arrival_ns);
  }
  newest_arrival_ns_ = std::max(newest_arrival_ns_, pose.arrival_ns);
  release_ready(newest_arrival_ns_, false);
}

// True if (robot, seq) was fused before; else marks it. A seq far below the newest is a restarted robot.
bool FusionCore::seen_before(std::uint8_t robot, std::uint32_t seq) {
  SeqWindow& w = seq_windows_[robot];
  auto bit = [&](std::uint32_t k) -> bool { return (w.seen[k / 64] >> (k % 64)) & 1u; };
  auto set = [&](std::uint32_t k) { w.seen[k / 64] |= std::uint64_t{1} << (k % 64); };
  if (w.any && seq <= w.newest) {
    const std::uint32_t back = w.newest - seq;
    if (back < kSeqWindow) {
      if (bit(back)) return true;
      set(back);  // late but new (out of order)
      return false;
    }
    w = SeqWindow{};  // far below the newest: a restarted robot counts from 1 again
  }
  if (!w.any) {
    w.any = true;
    w.newest = seq;
    w.seen = {};
    set(0);
    return false;
  }
  const std::uint32_t shift = seq - w.newest;  // newer: shift the bitmap
  if (shift >= kSeqWindow) {
    w.seen = {};
  } else {
    const std::uint32_t words = shift / 64, bits = shift % 64;
    for (std::size_t i = w.seen.size(); i-- > 0;) {
      std::uint64_t v = i >= words ? w.seen[i - words] << bits : 0;
      if (bits != 0 && i >= words + 1) v |= w.seen[i - words - 1] >> (64 - bits);
      w.seen[i] = v;
    }
  }
  w.newest = seq;
  set(0);
  return false;
}

bool FusionCore::add_scan(const ScanInput& in) {
  ++counters_.scans_in;
  if (in.robot == 0 || in.robot > kMaxRobots) return false;
  if (seen_before(in.robot, in.seq)) {
    ++counters_.duplicate_scans;
    return false;
  }
  HeldScan s;
  s.robot = in.robot;
  s.seq = in.seq;
  s.stamp_ns = in.stamp_ns;
  s.arrival_ns = in.arrival_ns;
  s.origin_m = in.origin_m;
  s.points.assign(in.points.begin(), in.points.end());
  s.flags.assign(in.flags.begin(), in.flags.end());
  s.beams.assign(in.beams.begin(), in.beams.end());
  held_.push_back(std::move(s));
  newest_arrival_ns_ = std::max(newest_arrival_ns_, in.arrival_ns);
  release_ready(newest_arrival_ns_, false);
  return true;
}

void FusionCore::flush() { release_ready(newest_arrival_ns_, true); }

void FusionCore::advance_to(std::int64_t arrival_ns) {
  if (held_.empty() || arrival_ns <= newest_arrival_ns_) return;
  newest_arrival_ns_ = arrival_ns;
  release_ready(newest_arrival_ns_, false);
}

void FusionCore::resume_at(std::int64_t arrival_ns) {
  for (HeldScan& s : held_) s.arrival_ns = std::max(s.arrival_ns, arrival_ns);
  for (std::uint8_t r = 1; r <= kMaxRobots; ++r)
    if (poses_.known(r)) last_pose_arrival_ns_[r] = std::max(last_pose_arrival_ns_[r], arrival_ns);
  newest_arrival_ns_ = std::max(newest_arrival_ns_, arrival_ns);
}

void FusionCore::release_ready(std::int64_t now_ns, bool all) {
  if (held_.empty()) return;
  const std::int64_t hold_ns = static_cast<std::int64_t>(options_.hold_s * 1e9);
  // Start-up: the team is not known yet (a robot whose first pose is still on its way would be missing
  // from the scans' team states): nothing is released in the first hold_s of arrival time.
  if (first_arrival_ns_ == INT64_MIN) first_arrival_ns_ = held_.front().arrival_ns;
  if (!all && now_ns - first_arrival_ns_ < hold_ns) return;
  // The watermark: the oldest newest-pose stamp over the robots still talking (a robot silent for
  // hold_s of arrival time no longer holds scans back).
  std::int64_t watermark = INT64_MAX;
  for (std::uint8_t r = 1; r <= kMaxRobots; ++r) {
    if (!poses_.known(r)) continue;
    if (now_ns - last_pose_arrival_ns_[r] >= hold_ns) continue;
    watermark = std::min(watermark, poses_.newest_stamp(r));
  }
  for (auto it = held_.begin(); it != held_.end();) {
    // Its own robot's poses must have passed it too (own pose), unless that robot is silent.
    const std::int64_t cutoff = poses_.cutoff(it->stamp_ns);  // the newest pose stamp that decides it
    const bool own_ok = poses_.known(it->robot) &&
                        (poses_.newest_stamp(it->robot) >= cutoff || now_ns - last_pose_arrival_ns_[it->robot] >= hold_ns);
    const bool by_poses = own_ok && cutoff <= watermark;
    const bool forced = !by_poses && (all || now_ns - it->arrival_ns >= hold_ns);
    if (by_poses || forced) {
      release(*it, forced);
      it = held_.erase(it);
    } else {
      ++it;
    }
  }
}

void FusionCore::release(HeldScan& s, bool forced) {
  ++counters_.scans_released;
  if (forced) ++counters_.scans_forced;
  // The registration's correction (identity until set): points and origin into the corrected map frame.
  const Pose2& correction = poses_.map_from_odom(s.robot);
  if (!is_identity(correction)) {
    for (mapping::MapPoint& p : s.points) {
      const Vec2 q = correction.apply(Vec2{p.x, p.y});
      p.x = static_cast<float>(q.x);
      p.y = static_cast<float>(q.y);
    }
    const Vec2 o = correction.apply(Vec2{s.origin_m.x, s.origin_m.y});
    s.origin_m.x = o.x;
    s.origin_m.y = o.y;
  }
  const mapping::TeamState team = poses_.team_at(s.stamp_ns);
  const PoseHistory::ScanPose own = poses_.scan_pose(s.robot, s.stamp_ns);
  mapping::ScanView view;
  view.robot = s.robot;
  view.scan = s.seq;
  view.stamp_ns = s.stamp_ns;
  view.origin_m = s.origin_m;
  // Without any pose of its own robot: at its sensor origin, heading 0 (as the station always did).
  view.map_from_robot = own.found ? own.map_from_robot : Pose2{s.origin_m.x, s.origin_m.y, 0.0};
  view.points = s.points;
  view.flags = s.flags;
  view.team = &team;
  const std::size_t n = s.points.size();
  bits_.assign(n, 0);
  removed_.assign(n, 0);
  filter_->point_bits(view, bits_);
  filter_->insert(view, bits_);
  filter_->decide(view.points, bits_, removed_);
  counters_.points += n;
  for (std::uint8_t r : removed_) counters_.removed_at_release += r;
  if (options_.max_points_per_voxel > 0) store(s);
  if (on_release_) {
    FusedScan f;
    f.robot = s.robot;
    f.seq = s.seq;
    f.stamp_ns = s.stamp_ns;
    f.arrival_ns = s.arrival_ns;
    f.forced = forced;
    f.view = &view;
    f.beams = s.beams;
    f.bits = bits_;
    f.removed = removed_;
    on_release_(f);
  }
}

void FusionCore::store(const HeldScan& s) {
  auto index = [&](float v) {
    const double k = std::floor(static_cast<double>(v) * inverse_model_resolution_);
    return static_cast<std::int32_t>(std::clamp(k, -double(mapping::VoxelMap::kIndexLimit), double(mapping::VoxelMap::kIndexLimit - 1)));
  };
  for (std::size_t i = 0; i < s.points.size(); ++i) {
    const mapping::MapPoint& p = s.points[i];
    if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z)) continue;
    const std::uint64_t key = mapping::VoxelMap::pack({index(p.x), index(p.y), index(p.z)});
    bool inserted = false;
    std::uint32_t& slot = voxel_index_.get_or_insert(key, 0, &inserted);
    if (inserted) {
      slot = static_cast<std::uint32_t>(voxels_.size());
      voxels_.emplace_back();
    }
    std::vector<ModelPoint>& v = voxels_[slot];
    if (v.size() >= options_.max_points_per_voxel) {
      ++counters_.capped_points;
      continue;
    }
    ModelPoint m;
    m.p = p;
    m.seq = s.seq;
    m.beam = i < s.beams.size() ? s.beams[i] : static_cast<std::uint16_t>(i);
    m.robot = s.robot;
    m.bits = bits_[i];
    m.removed_at_release = removed_[i];
    v.push_back(m);
    ++counters_.stored_points;
  }
}

std::size_t FusionCore::model_memory_bytes() const {
  std::size_t n = voxel_index_.memory_bytes() + voxels_.capacity() * sizeof(std::vector<ModelPoint>);
  for (const auto& v : voxels_) n += v.capacity() * sizeof(ModelPoint);
  return n;
}

void FusionCore::for_each_model_point(const std::function<void(const ModelPoint&, bool removed)>& f) const {
  std::vector<mapping::MapPoint> pts;
  std::vector<std::uint8_t> bits, removed;
  for (const std::vector<ModelPoint>& v : voxels_) {
    pts.clear();
    bits.clear();
    for (const ModelPoint& m : v) {
      pts.push_back(m.p);
      bits.push_back(m.bits);
    }
    removed.assign(v.size(), 0);
    filter_->decide(pts, bits, removed);
    for (std::size_t i = 0; i < v.size(); ++i) f(v[i], removed[i] != 0);
  }
}

Result<FusionCore::ModelFigures> FusionCore::write_model(const std::string& kept_path, const std::string& all_path) const {
  const bool all = !all_path.empty();
  PcdCloud kept, every;
  kept.fields = {"x", "y", "z", "robot", "scan", "beam"};
  kept.columns.assign(kept.fields.size(), {});
  std::vector<PcdField> layout = {{"x", 4, 'F', 1},     {"y", 4, 'F', 1},    {"z", 4, 'F', 1},
                                  {"robot", 1, 'U', 1}, {"scan", 4, 'U', 1}, {"beam", 2, 'U', 1}};
  if (all) {
    every.fields = kept.fields;
    every.fields.push_back("keep");
    every.fields.push_back("live_keep");
    every.columns.assign(every.fields.size(), {});
  }
  ModelFigures fig;
  for_each_model_point([&](const ModelPoint& m, bool removed) {
    const double row[6] = {m.p.x, m.p.y, m.p.z, static_cast<double>(m.robot), static_cast<double>(m.seq),
                           static_cast<double>(m.beam)};
    if (!removed) {
      ++fig.kept;
      for (std::size_t c = 0; c < 6; ++c) kept.columns[c].push_back(row[c]);
    } else {
      ++fig.removed;
    }
    if (all) {
      for (std::size_t c = 0; c < 6; ++c) every.columns[c].push_back(row[c]);
      every.columns[6].push_back(removed ? 0.0 : 1.0);
      every.columns[7].push_back(m.removed_at_release ? 0.0 : 1.0);
    }
  });
  kept.width = fig.kept;
  kept.height = 1;
  if (Status st = write_atomically(kept_path, kept, layout); !st.ok()) return st.error();
  if (all) {
    every.width = fig.kept + fig.removed;
    every.height = 1;
    std::vector<PcdField> layout_all = layout;
    layout_all.push_back({"keep", 1, 'U', 1});
    layout_all.push_back({"live_keep", 1, 'U', 1});
    if (Status st = write_atomically(all_path, every, layout_all); !st.ok()) return st.error();
  }
  return fig;
}

}  // namespace teamscan::fusion
