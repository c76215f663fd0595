// Ros2Publisher: the receive loop's mailbox and the worker thread that publishes on ROS 2 wire names.
#include "groundstation/station/ros2_publisher.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <unordered_map>

#include <dds/dds.h>

#include "common/clock.hpp"
#include "dds/ros2/wire.hpp"
#include "teamscan.h"

namespace teamscan::station {
namespace {

// A heading older than this is not moved on further (a robot that stopped sending keeps its last yaw).
constexpr double kMaxHeadingExtrapolationS = 0.5;

struct VoxelKey {
  std::int32_t x, y, z;
  bool operator==(const VoxelKey&) const = default;
};
struct VoxelKeyHash {
  std::size_t operator()(const VoxelKey& k) const {
    std::uint64_t h = static_cast<std::uint32_t>(k.x);
    h = h * 0x9E3779B97F4A7C15ull ^ static_cast<std::uint32_t>(k.y);
    h = h * 0x9E3779B97F4A7C15ull ^ static_cast<std::uint32_t>(k.z);
    return static_cast<std::size_t>(h ^ (h >> 29));
  }
};

}  // namespace

std::vector<dds::ros2::FrameTransform> laser_transforms(const Ros2Config& config, std::int64_t stamp_ns) {
  std::vector<dds::ros2::FrameTransform> out;
  for (const Ros2Config::RobotLaserMount& m : config.laser_mounts)
    out.push_back(dds::ros2::laser_transform(m.robot_id, m.mount, stamp_ns));
  return out;
}

double heading_at(const Heading& h, Time at) {
  const double dt = std::clamp((at - h.stamp).count() * 1e-9, 0.0, kMaxHeadingExtrapolationS);
  return std::remainder(h.yaw_rad + h.yaw_rate_radps * dt, 2.0 * std::numbers::pi);
}

// The worker's state: the participant and writers, its copy of the map, the messages' buffers.
struct Ros2Publisher::Worker {
  std::unique_ptr<dds::ros2::Ros2Writers> writers;
  std::unordered_map<VoxelKey, std::uint32_t, VoxelKeyHash> index;  // voxel centre -> voxels
  std::vector<teamscan_msg_MapVoxel> voxels;
  std::vector<dds::ros2::CloudPoint> cloud_points;
  std::vector<dds::ros2::PlanarState> states;
  dds::ros2::PointCloudMessage cloud;
  dds::ros2::TfMessage tf;
  dds::ros2::OdometryMessage odometry;

  void merge(std::span<const teamscan_msg_MapVoxel> update) {
    for (const teamscan_msg_MapVoxel& v : update) {
      const auto [it, added] = index.try_emplace(VoxelKey{v.x_mm, v.y_mm, v.z_mm}, static_cast<std::uint32_t>(voxels.size()));
      if (added) {
        voxels.push_back(v);
      } else {
        voxels[it->second] = v;  // an update carries the voxel's whole count and flags
      }
    }
  }
  void clear() {
    index.clear();
    voxels.clear();
  }
};

Result<std::unique_ptr<Ros2Publisher>> Ros2Publisher::create(const Ros2Config& config, std::int32_t participant) {
  auto worker = std::make_unique<Worker>();
  auto writers = dds::ros2::Ros2Writers::create(participant);
  if (!writers) return writers.error();
  worker->writers = std::move(writers.value());
  // rt/tf_static once (transient local: a later tf2 listener gets it): each configured laser mount.
  if (!config.laser_mounts.empty()) {
    dds::ros2::TfMessage mounts;
    mounts.set_transforms(laser_transforms(config, now_realtime().ns()));
    if (Status st = worker->writers->write_tf_static(mounts); !st) return st.error();
  }
  return std::unique_ptr<Ros2Publisher>(new Ros2Publisher(config, std::move(worker)));
}

Ros2Publisher::Ros2Publisher(const Ros2Config& config, std::unique_ptr<Worker> worker)
    : config_{config}, next_poses_{now_monotonic()}, worker_{std::move(worker)} {
  pending_team_.reserve(kMaxRobots);
  thread_ = std::thread([this] { run(); });
}

Ros2Publisher::~Ros2Publisher() {
  {
    const std::lock_guard lock(mutex_);
    stop_ = true;
  }
  wake_.notify_one();
  thread_.join();
}

void Ros2Publisher::add_pose(const PoseObservation& pose) {
  if (pose.robot_id == 0 || pose.robot_id > kMaxRobots) return;  // the station counts these as bad samples
  Heading& h = headings_[pose.robot_id];
  if (h.known && pose.stamp < h.stamp) return;  // a replayed older pose does not turn the robot back
  h = Heading{true, pose.stamp, pose.yaw_rad, pose.yaw_rate_radps};
}

void Ros2Publisher::add_scan(const ScanPoints& scan, const Receipt& receipt, const Pose2* odom_from_base) {
  if (receipt.rejected != 0 || scan.robot_id == 0 || scan.robot_id > kMaxRobots) return;
  if (loop_scans_.scans.size() >= kMaxPendingScans) {  // the worker is behind: keep the newest
    ++loop_scans_dropped_;
    return;
  }
  PendingScan p{scan.robot_id, scan.stamp.ns(), loop_scans_.points.size(), 0, odom_from_base != nullptr};
  const Pose2 base_from_odom = odom_from_base != nullptr ? odom_from_base->inverse() : Pose2{};
  for (std::uint32_t i = 0; i < scan.count && i < kMaxBeams; ++i) {
    const ScanPoint& q = scan.points[i];
    if (q.flags & kPointUnplaced) continue;
    const Vec2 xy = base_from_odom.apply(Vec2{q.x_mm * 1e-3, q.y_mm * 1e-3});
    loop_scans_.points.push_back({static_cast<float>(xy.x), static_cast<float>(xy.y), static_cast<float>(q.z_mm * 1e-3),
                                  static_cast<float>(q.flags)});
    ++p.count;
  }
  loop_scans_.scans.push_back(p);
  hand_over();
}

void Ros2Publisher::offer_map(std::span<const teamscan_msg_MapVoxel> voxels, std::uint32_t total_voxels) {
  const Time t0 = now_monotonic();
  if (total_voxels == voxels.size()) {  // the whole map: what is not handed over yet is superseded
    loop_map_.clear();
    loop_full_ = true;
  }
  loop_map_.insert(loop_map_.end(), voxels.begin(), voxels.end());
  ++loop_updates_;
  hand_over();
  offer_max_ = std::max(offer_max_, now_monotonic() - t0);
}

void Ros2Publisher::tick(Time now_monotonic_time, const TeamSource& team) {
  const bool poses = now_monotonic_time >= next_poses_;
  if (!poses && loop_updates_ == 0) return;
  const Time t0 = now_monotonic();
  if (poses) {
    loop_team_count_ = team.estimate(now_realtime(), loop_team_);
    loop_team_pending_ = true;
    next_poses_ = now_monotonic_time + from_seconds(1.0 / config_.pose_rate_hz);
  }
  hand_over();
  offer_max_ = std::max(offer_max_, now_monotonic() - t0);
}

void Ros2Publisher::hand_over() {
  std::unique_lock lock(mutex_, std::try_to_lock);
  if (!lock.owns_lock()) {
    ++deferred_;
    return;
  }
  move_to_mailbox();
  lock.unlock();
  wake_.notify_one();
}

bool Ros2Publisher::flush(Duration timeout) {
  std::unique_lock lock(mutex_);
  move_to_mailbox();
  const std::uint64_t ticket = ++flushes_asked_;
  flush_timeout_ = timeout;
  wake_.notify_one();
  // The worker's round (a cloud's build and write) comes on top of the acknowledgement's wait.
  const bool done = flushed_.wait_for(lock, timeout + std::chrono::seconds(5), [&] { return flushes_done_ >= ticket || stop_; });
  return done && flushes_done_ >= ticket && flush_acknowledged_;
}

void Ros2Publisher::move_to_mailbox() {
  if (loop_updates_ > 0) {
    if (loop_full_ || pending_map_.empty()) {
      pending_map_.swap(loop_map_);  // O(1): the worker gets the loop's buffer, the loop its old one
      pending_full_ = pending_full_ || loop_full_;
    } else {
      pending_map_.insert(pending_map_.end(), loop_map_.begin(), loop_map_.end());
    }
    loop_map_.clear();
    loop_full_ = false;
    pending_updates_ += loop_updates_;
    loop_updates_ = 0;
  }
  if (!loop_scans_.scans.empty()) {
    if (pending_scans_.scans.empty()) {
      std::swap(pending_scans_, loop_scans_);  // O(1): the loop gets the worker's emptied buffers
    } else if (pending_scans_.scans.size() + loop_scans_.scans.size() <= kMaxPendingScans) {
      for (PendingScan p : loop_scans_.scans) {
        p.first += pending_scans_.points.size();
        pending_scans_.scans.push_back(p);
      }
      pending_scans_.points.insert(pending_scans_.points.end(), loop_scans_.points.begin(), loop_scans_.points.end());
    } else {
      loop_scans_dropped_ += loop_scans_.scans.size();
    }
    loop_scans_.clear();
  }
  if (loop_team_pending_) {
    pending_team_.assign(loop_team_.begin(), loop_team_.begin() + static_cast<std::ptrdiff_t>(loop_team_count_));
    pending_headings_ = headings_;
    team_pending_ = true;
    loop_team_pending_ = false;
  }
}

Ros2Counters Ros2Publisher::counters() const {
  const std::lock_guard lock(mutex_);
  Ros2Counters c = counters_;
  c.offer_max = offer_max_;  // the loop's own figures: read from the loop's thread
  c.handovers_deferred = deferred_;
  c.scans_dropped = loop_scans_dropped_;
  return c;
}

void Ros2Publisher::run() {
  Worker& w = *worker_;
  std::vector<teamscan_msg_MapVoxel> map_work;
  std::vector<TeamMemberEstimate> team_work;
  ScanBatch scan_work;
  dds::ros2::PointCloudMessage scan_cloud("flags");
  std::array<Heading, kMaxRobots + 1> headings{};
  const double yaw_var = std::pow(config_.heading_sigma_deg * std::numbers::pi / 180.0, 2);
  Time next_cloud = now_monotonic();
  for (;;) {
    bool full = false, team = false;
    std::uint64_t updates = 0, flush = 0;
    Duration flush_timeout{0};
    {
      std::unique_lock lock(mutex_);
      const Duration until_cloud = std::max(Duration{0}, next_cloud - now_monotonic());
      wake_.wait_for(lock, w.voxels.empty() ? Duration(std::chrono::seconds(1)) : until_cloud, [&] {
        return stop_ || pending_updates_ > 0 || team_pending_ || !pending_scans_.scans.empty() || flushes_asked_ > flushes_done_;
      });
      if (stop_) return;
      if (flushes_asked_ > flushes_done_) {
        flush = flushes_asked_;
        flush_timeout = flush_timeout_;
      }
      map_work.swap(pending_map_);
      pending_map_.clear();
      full = pending_full_;
      pending_full_ = false;
      updates = pending_updates_;
      pending_updates_ = 0;
      std::swap(scan_work, pending_scans_);
      pending_scans_.clear();
      if (team_pending_) {
        team_work.swap(pending_team_);
        headings = pending_headings_;
        team_pending_ = false;
        team = true;
      }
    }
    if (full) w.clear();
    w.merge(map_work);

    Ros2Counters done;  // this round's additions
    done.map_updates = updates;
    for (const PendingScan& p : scan_work.scans) {
      scan_cloud.set(p.stamp_ns, p.in_base_link ? dds::ros2::base_link_frame(p.robot_id) : dds::ros2::odom_frame(p.robot_id),
                     std::span<const dds::ros2::CloudPoint>(scan_work.points.data() + p.first, p.count));
      if (w.writers->write_scan(p.robot_id, scan_cloud).ok()) ++done.scans; else ++done.write_errors;
    }
    scan_work.clear();
    if (team) {
      w.states.clear();
      for (const TeamMemberEstimate& e : team_work) {
        // A lost robot's frame goes stale in RViz2 (tf2 keeps its last transform only for its buffer).
        if (e.lost || e.robot_id == 0 || e.robot_id > kMaxRobots || !headings[e.robot_id].known) continue;
        dds::ros2::PlanarState s;
        s.robot_id = e.robot_id;
        s.stamp_ns = e.valid.ns();
        s.x_m = e.x_m;
        s.y_m = e.y_m;
        s.yaw_rad = heading_at(headings[e.robot_id], e.valid);
        s.vx_mps = e.vx_mps;
        s.vy_mps = e.vy_mps;
        s.yaw_rate_radps = headings[e.robot_id].yaw_rate_radps;
        s.cov_xx_m2 = e.cov_xx_m2;
        s.cov_xy_m2 = e.cov_xy_m2;
        s.cov_yy_m2 = e.cov_yy_m2;
        s.yaw_var_rad2 = yaw_var;
        const Pose2 map_from_odom = e.correction.map_from_odom();  // REP-105: map -> odom -> base_link
        s.map_from_odom_x_m = map_from_odom.x_m;
        s.map_from_odom_y_m = map_from_odom.y_m;
        s.map_from_odom_yaw_rad = map_from_odom.theta_rad;
        w.states.push_back(s);
      }
      if (!w.states.empty()) {
        w.tf.set(w.states);
        if (w.writers->write_tf(w.tf).ok()) ++done.tf_messages; else ++done.write_errors;
        for (const dds::ros2::PlanarState& s : w.states) {
          w.odometry.set(s);
          if (w.writers->write_odometry(s.robot_id, w.odometry).ok()) ++done.odometry; else ++done.write_errors;
        }
      }
    }
    const Time now = now_monotonic();
    bool cloud_written = false;
    if ((now >= next_cloud || flush != 0) && !w.voxels.empty()) {
      w.cloud_points.clear();
      for (const teamscan_msg_MapVoxel& v : w.voxels) {
        if (v.flags != 0) continue;  // every point of the voxel removed as a ghost: not in the fused map
        w.cloud_points.push_back({static_cast<float>(v.x_mm * 1e-3), static_cast<float>(v.y_mm * 1e-3),
                                  static_cast<float>(v.z_mm * 1e-3), static_cast<float>(v.hits)});
      }
      w.cloud.set(now_realtime().ns(), dds::ros2::kFrameMap, w.cloud_points);
      cloud_written = w.writers->write_cloud(w.cloud).ok();
      if (cloud_written) ++done.clouds; else ++done.write_errors;
      const Duration took = now_monotonic() - now;
      done.cloud_max = took;
      done.cloud_total = took;
      done.last_cloud_points = w.cloud_points.size();
      next_cloud = now + config_.map_interval;
    }
    // A flush: the cloud is out once every matched reader acknowledged it (none: at once).
    const bool acknowledged =
        flush != 0 && (w.voxels.empty() || (cloud_written && dds_wait_for_acks(w.writers->cloud_writer(), flush_timeout.count()) == DDS_RETCODE_OK));
    const std::lock_guard lock(mutex_);
    if (flush != 0) {
      flushes_done_ = flush;
      flush_acknowledged_ = acknowledged;
      flushed_.notify_all();
    }
    counters_.map_updates += done.map_updates;
    counters_.clouds += done.clouds;
    counters_.tf_messages += done.tf_messages;
    counters_.odometry += done.odometry;
    counters_.scans += done.scans;
    counters_.write_errors += done.write_errors;
    if (done.cloud_total.count() > 0) {
      counters_.last_cloud_points = done.last_cloud_points;
      counters_.cloud_max = std::max(counters_.cloud_max, done.cloud_max);
      counters_.cloud_total += done.cloud_total;
    }
    counters_.map_voxels = w.voxels.size();
  }
}

}  // namespace teamscan::station
