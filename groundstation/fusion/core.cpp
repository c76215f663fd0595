// FusionCore: held scans, release, point part + map, model store (core.hpp).
#include "groundstation/fusion/core.hpp"
#include "groundstation/fusion/model_move.hpp"

#include <algorithm>
#include <limits>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <system_error>

#include "common/dataset/pcd.hpp"
#include "groundstation/fusion/match_points.hpp"
#include "groundstation/mapping/tracked_filter.hpp"

namespace teamscan::fusion {

namespace {
bool is_identity(const Pose2& p) { return p.x_m == 0.0 && p.y_m == 0.0 && p.theta_rad == 0.0; }

}  // namespace

Result<std::unique_ptr<FusionCore>> FusionCore::create(const CoreOptions& options) {
  std::unique_ptr<mapping::Filter> filter = mapping::make_filter(options.method, options.methods);
  if (!filter) return Error{"fusion: unknown filter method (fusion.method)"};
  if (!(options.hold_s >= 0.0)) return Error{"fusion: hold_s must be >= 0"};
  if (!(options.tracker.team_lag_s >= 0.0 && options.tracker.team_lag_s <= 10.0))
    return Error{"fusion: team_lag_s must be in [0, 10] s"};
  if (!(options.pose_keep_s > 0.0)) return Error{"fusion: pose_keep_s must be > 0"};
  if (!(options.min_scan_interval_s >= 0.0 && options.min_scan_interval_s <= 1.0))
    return Error{"fusion: min_scan_interval_s must be in [0, 1] s"};
  if (options.max_points_per_voxel > 0 && !(options.model_resolution_m > 0.0))
    return Error{"fusion: model resolution must be > 0 (fusion.model_resolution_m)"};
  if (options.registration) {
    const registration::RegistrationOptions& r = options.registration_options;
    if (!(r.window_s > 0.0) || !(r.match_every_s >= 0.0) || !(r.surface.voxel_m > 0.0))
      return Error{"fusion: registration window_s and voxel_m must be > 0, match_every_s >= 0"};
    if (!(r.match_delay_s >= 0.0 && r.match_delay_s <= 10.0))
      return Error{"fusion: registration match_delay_s must be in [0, 10] s"};
  }
  try {
    return std::unique_ptr<FusionCore>(new FusionCore(options, std::move(filter)));
  } catch (const std::system_error&) {
    return Error{"fusion: cannot start the registration's match thread (the system refused a thread)"};
  }
}

FusionCore::FusionCore(const CoreOptions& options, std::unique_ptr<mapping::Filter> filter)
    : options_{options},
      filter_{std::move(filter)},
      poses_{PoseHistoryOptions{options.tracker, options.pose_keep_s}},
      odometry_poses_{PoseHistoryOptions{options.tracker, options.pose_keep_s}},
      seq_windows_(kMaxRobots + 1),
      model_{options.model_resolution_m, options.max_points_per_voxel} {
  if (options_.registration) registration_ = std::make_unique<registration::Registration>(options_.registration_options);
  bits_.reserve(kMaxBeams);
  removed_.reserve(kMaxBeams);
}

Status FusionCore::reset() {
  auto fresh = create(options_);
  if (!fresh) return fresh.error();
  std::function<void(const FusedScan&)> on_release = std::move(on_release_);
  *this = std::move(*fresh.value());
  on_release_ = std::move(on_release);
  return ok_status();
}

void FusionCore::take_state(FusionCore& other) {
  std::function<void(const FusedScan&)> on_release = std::move(on_release_);
  FusionCore old{std::move(*this)};
  *this = std::move(other);
  other = std::move(old);
  on_release_ = std::move(on_release);
}

bool FusionCore::holds(std::uint8_t robot, std::uint32_t scan) const {
  return std::any_of(held_.begin(), held_.end(), [&](const Held& h) { return h.robot == robot && h.scan == scan; });
}

void FusionCore::add_pose(const PoseInput& pose) {
  ++counters_.poses_in;
  if (first_arrival_ns_ == INT64_MIN) first_arrival_ns_ = pose.arrival_ns;
  if (!poses_.add(pose)) {
    ++counters_.poses_rejected;
  } else {
    if (options_.odometry_team) (void)odometry_poses_.add(pose);
    if (pose.robot <= kMaxRobots)
      last_pose_arrival_ns_[pose.robot] = std::max(last_pose_arrival_ns_[pose.robot], pose.arrival_ns);
    // A pose the released scans were decided without (a back-fill after a radio shadow).
    const auto hold_ns = static_cast<std::int64_t>(options_.hold_s * 1e9);
    if (newest_released_stamp_ns_ != INT64_MIN && newest_released_stamp_ns_ - pose.stamp_ns > hold_ns)
      ++counters_.poses_late;
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
  TEAMSCAN_EXPECTS(in.robot >= 1 && in.robot <= kMaxRobots);  // checked where the scan entered
  if (seen_before(in.robot, in.scan)) {
    ++counters_.duplicate_scans;
    return false;
  }
  std::uint32_t slot = 0;
  if (free_slots_.empty()) {
    slot = static_cast<std::uint32_t>(slots_.size());
    slots_.emplace_back();
  } else {
    slot = free_slots_.back();
    free_slots_.pop_back();
  }
  slots_[slot] = in;
  held_.push_back(Held{in.stamp_ns, in.arrival_ns, in.scan, slot, in.robot, false});
  newest_scan_stamp_ns_[in.robot] = std::max(newest_scan_stamp_ns_[in.robot], in.stamp_ns);
  last_scan_arrival_ns_[in.robot] = std::max(last_scan_arrival_ns_[in.robot], in.arrival_ns);
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
  for (Held& h : held_) h.arrival_ns = std::max(h.arrival_ns, arrival_ns);
  for (std::uint8_t r = 1; r <= kMaxRobots; ++r)
    if (poses_.known(r)) last_pose_arrival_ns_[r] = std::max(last_pose_arrival_ns_[r], arrival_ns);
  for (std::int64_t& t : last_scan_arrival_ns_)
    if (t != INT64_MIN) t = std::max(t, arrival_ns);
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
  // With the registration, the release order is part of the state (each match sees the reference the
  // scans released before it built; so is it for a pose graph fed the releases: CoreOptions::stamp_order),
  // so a scan also waits until no earlier-stamped scan can still arrive: a robot's scans arrive in
  // order, each stamped at least min_scan_interval_s after the one before (at least 1 ns), so robot r
  // sends nothing stamped before newest_r + interval. A scan stamped before that for every robot still
  // sending is released, and live releases in stamp order as `teamscan eval` does. Costs up to a scan
  // period minus the interval.
  std::int64_t scan_watermark = INT64_MAX;  // release what is stamped before it
  if (registration_ || options_.stamp_order) {
    const std::int64_t interval_ns = std::max<std::int64_t>(1, from_seconds(options_.min_scan_interval_s).count());
    for (std::uint8_t r = 1; r <= kMaxRobots; ++r) {
      if (last_scan_arrival_ns_[r] == INT64_MIN || now_ns - last_scan_arrival_ns_[r] >= hold_ns) continue;
      scan_watermark = std::min(scan_watermark, newest_scan_stamp_ns_[r] + interval_ns);
    }
  }
  // The ready scans go in stamp order (robot, seq on a tie), whatever order they arrived in: the
  // registration's state, and with it every later scan's correction, follows the release order.
  // The ready ones out, the rest kept in arrival order (one pass, no erase from the middle).
  releasing_.clear();
  std::size_t kept = 0;
  for (Held& h : held_) {
    // Its own robot's poses must have passed it too (own pose), unless that robot is silent.
    const std::int64_t cutoff = poses_.cutoff(h.stamp_ns);  // the newest pose stamp that decides it
    const bool own_ok = poses_.known(h.robot) &&
                        (poses_.newest_stamp(h.robot) >= cutoff || now_ns - last_pose_arrival_ns_[h.robot] >= hold_ns);
    const bool by_poses = own_ok && cutoff <= watermark && h.stamp_ns < scan_watermark;
    const bool forced = !by_poses && (all || now_ns - h.arrival_ns >= hold_ns);
    if (by_poses || forced) {
      h.forced = forced;
      releasing_.push_back(h);
    } else {
      held_[kept++] = h;
    }
  }
  held_.resize(kept);
  std::stable_sort(releasing_.begin(), releasing_.end(), [](const Held& x, const Held& y) {
    if (x.stamp_ns != y.stamp_ns) return x.stamp_ns < y.stamp_ns;
    if (x.robot != y.robot) return x.robot < y.robot;
    return x.scan < y.scan;
  });
  for (const Held& h : releasing_) {
    if (h.stamp_ns < newest_released_stamp_ns_) {
      ++counters_.scans_out_of_stamp_order;
      if (newest_released_stamp_ns_ - h.stamp_ns > hold_ns) ++counters_.scans_late;
    }
    newest_released_stamp_ns_ = std::max(newest_released_stamp_ns_, h.stamp_ns);
    release(slots_[h.slot], h.arrival_ns, h.forced);
    free_slots_.push_back(h.slot);
  }
  releasing_.clear();
}

void FusionCore::register_scan(const ScanInput& s) {
  const PoseHistory::ScanPose own = poses_.scan_pose(s.robot, s.stamp_ns);
  if (!own.found) return;  // no odometry of its own: nothing to correct
  // Teammates' bodies at the scan's time (their corrected tracks): hits on them must not pull the match.
  const mapping::TeamState team = poses_.team_at(s.stamp_ns);
  const Pose2 correction = poses_.map_from_odom(s.robot, s.stamp_ns);
  const Vec3 sensor = registration::corrected(correction, s.origin_m);
  registration_points_.clear();
  registration_usable_.clear();
  registration_corrected_.clear();
  for (std::size_t i = 0; i < s.points.size(); ++i) {
    const mapping::MapPoint& p = s.points[i];
    registration_points_.push_back({p.x, p.y, p.z});
    registration_usable_.push_back(match_usable_flags(i < s.flags.size() ? s.flags[i] : 0) ? 1 : 0);
    const Vec3 q = registration::corrected(correction, registration_points_.back());
    registration_corrected_.push_back({static_cast<float>(q.x), static_cast<float>(q.y), static_cast<float>(q.z)});
  }
  mask_teammates(team, s.robot, sensor, options_.methods.tracked, registration_corrected_, registration_usable_);
  for (const std::uint8_t u : registration_usable_)
    if (u == 0) ++counters_.registration_masked_points;
  const registration::RobotCorrection& c =
      registration_->add_scan(s.robot, s.stamp_ns, own.odom, registration_points_, registration_usable_);
  const Pose2& now = c.map_from_odom;
  if (now.x_m != correction.x_m || now.y_m != correction.y_m || now.theta_rad != correction.theta_rad) {
    // A matched correction is also a measurement for the robot's Kalman track (its covariance, about
    // the robot's position): the drift restarts from it. One the drift rates extrapolated between
    // matches is a change of frame only. Both carry their σ (teamscan/team hands it to the robot).
    poses_.set_map_from_odom(s.robot, s.stamp_ns, now, std::sqrt(std::max({0.0, c.covariance(0, 0), c.covariance(1, 1)})),
                             std::sqrt(std::max(0.0, c.covariance(2, 2))), c.matched);
    ++counters_.registration_corrections;
  }
}

void FusionCore::release(ScanInput& s, std::int64_t arrival_ns, bool forced) {
  ++counters_.scans_released;
  if (forced) ++counters_.scans_forced;
  // The registration first (it may correct this scan's robot from this scan's stamp on), then the
  // correction in force at the scan's stamp (identity until set): points and origin into the map frame.
  if (registration_) register_scan(s);
  const Pose2 correction = poses_.map_from_odom(s.robot, s.stamp_ns);
  const bool corrected = !is_identity(correction);
  const Vec3 odom_origin = s.origin_m;
  if (corrected && on_release_) odom_points_.assign(s.points.begin(), s.points.end());  // reused: no allocation once grown
  if (corrected) {
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
  mapping::ScanView view = s.view();
  // Without any pose of its own robot: at its sensor origin, heading 0 (as the station always did).
  view.map_from_robot = own.found ? own.map_from_robot : Pose2{view.origin_m.x, view.origin_m.y, 0.0};
  view.team = &team;
  const std::size_t n = s.points.size();
  bits_.assign(n, 0);
  removed_.assign(n, 0);
  filter_->point_bits(view, bits_);
  filter_->insert(view, bits_);
  filter_->decide(view.points, bits_, removed_);
  counters_.points += n;
  std::uint64_t removed = 0;
  for (std::uint8_t r : removed_) removed += r;
  counters_.removed_at_release += removed;
  RobotCounters& rc = robot_counters_[view.robot];
  ++rc.scans_released;
  rc.points += n;
  rc.removed_at_release += removed;
  stored_.clear();
  if (options_.max_points_per_voxel > 0) {
    const std::uint64_t before = counters_.stored_points;
    store(s);
    rc.stored_points += counters_.stored_points - before;
    if (moving_) moving_->robot_points[view.robot <= kMaxRobots ? view.robot : 0] += counters_.stored_points - before;
  }
  if (on_release_) {
    FusedScan f;
    f.view = &view;
    f.map_from_odom = correction;
    f.odom_from_robot = own.found ? own.odom : correction.inverse() * view.map_from_robot;
    f.odom_points = corrected ? std::span<const mapping::MapPoint>(odom_points_) : view.points;
    f.odom_origin_m = odom_origin;
    mapping::TeamState odom_team;
    if (options_.odometry_team) {
      odom_team = odometry_poses_.team_at(s.stamp_ns);
      f.odom_team = &odom_team;
    }
    f.arrival_ns = arrival_ns;
    f.forced = forced;
    f.beams = s.beams;
    f.bits = bits_;
    f.removed = removed_;
    f.stored = stored_;
    f.release = counters_.scans_released;
    on_release_(f);
  }
}

void FusionCore::store(const ScanInput& s) {
  model_points_.resize(s.points.size());
  for (std::size_t i = 0; i < s.points.size(); ++i) {
    ModelPoint& m = model_points_[i];
    m.p = s.points[i];
    m.seq = s.scan;
    m.beam = i < s.beams.size() ? s.beams[i] : static_cast<std::uint16_t>(i);
    m.robot = s.robot & 0x7Fu;
    m.bits = bits_[i];
    m.removed_at_release = removed_[i] != 0 ? 1 : 0;
  }
  stored_.resize(s.points.size());
  ModelStore& into = moving_ ? *moving_->store : model_;  // a move under way: the moved model's
  counters_.stored_points += into.add_all(model_points_, stored_);
  counters_.capped_points = capped_before_ + model_.capped_points() + (moving_ ? moving_->store->capped_points() : 0);
}

void FusionCore::begin_model_move(std::shared_ptr<const ScanMoves> moves, std::unique_ptr<ModelStore> store) {
  auto m = std::make_unique<ModelMove>();
  m->moves = std::move(moves);
  m->store = store ? std::move(store) : std::make_unique<ModelStore>(options_.model_resolution_m, options_.max_points_per_voxel);
  moving_ = std::move(m);
}

bool FusionCore::continue_model_move(std::size_t voxels, std::unique_ptr<ModelStore>& old,
                                     const std::function<void(const ModelPoint&)>& on_moved) {
  if (!moving_) return true;
  ModelMove& m = *moving_;
  const std::size_t end = std::min(model_.voxels(), m.next_voxel + voxels);
  for (std::size_t k = m.next_voxel; k < end; ++k) {
    model_.for_each_in_voxel(k, [&](ModelPoint p) {
      m.moves->at(p.robot, p.seq).apply(p.p);
      if (!m.store->add(p)) return;
      ++m.robot_points[p.robot];
      if (on_moved) on_moved(p);
    });
  }
  m.next_voxel = end;
  if (end < model_.voxels()) return false;
  std::swap(model_, *m.store);
  old = std::move(m.store);
  // The old store's caps stay counted; the moved model's points are the model's now.
  capped_before_ += old->capped_points();
  counters_.stored_points = model_.points();
  counters_.capped_points = capped_before_ + model_.capped_points();
  for (std::size_t r = 0; r < robot_counters_.size(); ++r) robot_counters_[r].stored_points = m.robot_points[r];
  moving_.reset();
  return true;
}

// One voxel's points and their decisions now, through the caller's scratch.
void FusionCore::decide_voxel(std::size_t k, std::vector<ModelPoint>& points, std::vector<mapping::MapPoint>& pts,
                              std::vector<std::uint8_t>& bits, std::vector<std::uint8_t>& removed) const {
  points.clear();
  pts.clear();
  bits.clear();
  model_.for_each_in_voxel(k, [&](const ModelPoint& m) {
    points.push_back(m);
    pts.push_back(m.p);
    bits.push_back(m.bits);
  });
  removed.assign(points.size(), 0);
  filter_->decide(pts, bits, removed);
}

void FusionCore::for_each_model_point(const std::function<void(const ModelPoint&, bool removed)>& f) const {
  std::vector<ModelPoint> points;
  std::vector<mapping::MapPoint> pts;
  std::vector<std::uint8_t> bits, removed;
  for (std::size_t k = 0; k < model_.voxels(); ++k) {
    decide_voxel(k, points, pts, bits, removed);
    for (std::size_t i = 0; i < points.size(); ++i) f(points[i], removed[i] != 0);
  }
}

std::size_t FusionCore::snapshot_model_part(ModelSnapshot& out, std::size_t from, std::size_t count) const {
  const std::size_t voxels = model_.voxels();
  const std::size_t to = std::min(voxels, from + std::min(count, voxels));
  std::vector<ModelPoint> points;
  std::vector<mapping::MapPoint> pts;
  std::vector<std::uint8_t> bits, removed;
  for (std::size_t k = from; k < to; ++k) {
    decide_voxel(k, points, pts, bits, removed);
    for (std::uint8_t r : removed) out.kept += r == 0 ? 1 : 0;
    out.points.insert(out.points.end(), points.begin(), points.end());
    out.removed.insert(out.removed.end(), removed.begin(), removed.end());
  }
  return std::max(from, to);
}

}  // namespace teamscan::fusion
