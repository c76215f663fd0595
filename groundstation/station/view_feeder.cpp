// ViewFeeder: team snapshots, scan taps and map changes for the browser view (view_feeder.hpp).
#include "groundstation/station/view_feeder.hpp"

#include <filesystem>

#include "common/clock.hpp"
#include "common/data_paths.hpp"
#include "common/result.hpp"
#include "common/scan_points.hpp"
#include "teamscan.h"

namespace teamscan::station {

ViewFeeder::ViewFeeder(view::ViewFeed& feed, RobotLookup robots, const TeamSource& team, Duration period,
                       std::uint32_t map_resolution_mm, GhostCount ghosts)
    : feed_{feed},
      robot_{std::move(robots)},
      team_{team},
      period_{period},
      map_resolution_mm_{map_resolution_mm},
      ghosts_{std::move(ghosts)} {}

void ViewFeeder::on_pose(const PoseObservation& p) {
  if (p.robot_id == 0 || p.robot_id > kMaxRobots) return;
  robots_[p.robot_id].yaw_rad = p.yaw_rad;
}

void ViewFeeder::on_scan(const ScanPoints& s, const Receipt& receipt) {
  TEAMSCAN_EXPECTS(s.robot_id >= 1 && s.robot_id <= kMaxRobots);  // a scan hook's: validated at the edge
  PerRobot& r = robots_[s.robot_id];
  r.latency_sum_ns += receipt.recv_realtime_ns - s.stamp.ns();
  ++r.latency_n;
  // The scan's placed points for the Foxglove /robotN/scan channel (the page draws the model only).
  std::size_t n = 0;
  for (std::uint32_t i = 0; i < s.count && i < kMaxBeams; ++i) {
    const ScanPoint& p = s.points[i];
    if (p.flags & kPointUnplaced) continue;
    tap_[n++] = view::TapPoint{p.x_mm, p.y_mm, p.z_mm};
  }
  feed_.offer_scan(s.robot_id, std::span<const view::TapPoint>(tap_.data(), n));
}

void ViewFeeder::tick(Time now_monotonic) {
  if (now_monotonic < next_) return;
  next_ = now_monotonic + period_;
  offer_snapshot();
}

void ViewFeeder::offer_snapshot() {
  const Time now_rt = now_realtime();
  const std::size_t n = team_.estimate(now_rt, std::span<TeamMemberEstimate>(estimates_));
  view::TeamSnapshot& t = snapshot_;
  t.stamp_ns = now_rt.ns();
  t.map_resolution_mm = map_resolution_mm_;
  t.count = 0;
  for (std::size_t i = 0; i < n && i < estimates_.size(); ++i) {
    const TeamMemberEstimate& e = estimates_[i];
    if (e.robot_id == 0 || e.robot_id > kMaxRobots) continue;
    const RobotRecord& rec = robot_(e.robot_id);
    PerRobot& r = robots_[e.robot_id];
    if (r.latency_n > 0) {
      r.latency_ms = static_cast<double>(r.latency_sum_ns) / r.latency_n * 1e-6;
      r.latency_sum_ns = 0;
      r.latency_n = 0;
    }
    view::RobotState& s = t.robots[t.count++];
    s.robot_id = e.robot_id;
    s.lost = e.lost || rec.lost;
    s.x_m = e.x_m;
    s.y_m = e.y_m;
    s.yaw_rad = r.yaw_rad;
    s.cov_xx_m2 = e.cov_xx_m2;
    s.cov_xy_m2 = e.cov_xy_m2;
    s.cov_yy_m2 = e.cov_yy_m2;
    s.vx_mps = e.vx_mps;
    s.vy_mps = e.vy_mps;
    const Pose2 map_from_odom = e.correction.map_from_odom();
    s.map_from_odom_x_m = map_from_odom.x_m;
    s.map_from_odom_y_m = map_from_odom.y_m;
    s.map_from_odom_yaw_rad = map_from_odom.theta_rad;
    s.scans = rec.scans;
    s.scans_lost = rec.scans_missing;
    s.ghosts_removed = ghosts_ ? ghosts_(e.robot_id) : 0;
    s.latency_ms = r.latency_ms;
    // Store and forward: silent since it was last heard; its ring and back-fill as its status says.
    s.shadow_s = rec.lost && rec.seen ? to_seconds(now_monotonic() - rec.last_heard) : 0.0;
    s.scans_buffered = rec.ring_unconfirmed;
    s.backfill_pct = rec.backfilling && rec.backfill_total > 0
                         ? 100.0 * (rec.backfill_total - rec.backfill_remaining) / rec.backfill_total
                         : -1.0;
    s.last_shadow_s = rec.last_shadow_ms * 1e-3;
    s.whole_again_ns = rec.whole_again.ns();
  }
  feed_.offer_snapshot(t);
}

void ViewFeeder::offer_map(std::span<const teamscan_msg_MapVoxel> voxels, std::span<const std::uint8_t> robots, bool whole,
                           std::uint32_t total_voxels, std::uint64_t release) {
  voxels_.clear();
  voxels_.reserve(voxels.size());
  for (std::size_t i = 0; i < voxels.size(); ++i) {
    const teamscan_msg_MapVoxel& v = voxels[i];
    const std::uint8_t robot = i < robots.size() ? robots[i] : 0;
    voxels_.push_back(view::VoxelUpdate{v.x_mm, v.y_mm, v.z_mm, v.hits, static_cast<std::uint8_t>(v.flags & 1u), robot});
  }
  snapshot_.map_voxels = total_voxels;
  snapshot_.map_release = release;
  feed_.offer_voxels(voxels_, whole);
}

std::string default_view_web_root() {
  namespace fs = std::filesystem;
  std::error_code ec;
  const fs::path exe = fs::read_symlink("/proc/self/exe", ec);
  if (ec) return {};
  const fs::path dir = exe.parent_path();
  for (const fs::path& p :
       {dir / ".." / "share" / "teamscan" / "view", dir / ".." / ".." / "groundstation" / "view" / "web" / "site"}) {
    if (fs::exists(p / "index.html", ec)) return fs::weakly_canonical(p, ec).string();
  }
  return {};
}

}  // namespace teamscan::station
