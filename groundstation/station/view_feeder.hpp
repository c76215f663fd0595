// ViewFeeder: the station's side of the browser view (groundstation/view). From the receive loop it
// offers the view immutable copies, through the view's bounded ViewFeed: a team snapshot every period
// (tracked pose and covariance from the team source, heading of the newest pose, the station's per-robot
// counters, ghosts removed by the live classification, scan latency), each scan's placed points (for the
// robot a voxel came from) and the live map's changed voxels. It never waits for the view's thread.
#pragma once

#include <array>
#include <cstdint>
#include <functional>
#include <span>
#include <string>

#include "common/capacities.hpp"
#include "common/time.hpp"
#include "groundstation/station/scan_record.hpp"
#include "groundstation/station/station.hpp"
#include "groundstation/station/team_source.hpp"
#include "groundstation/view/feed.hpp"

struct teamscan_msg_MapVoxel;

namespace teamscan::station {

// The station's record of a robot (Station::robot), by id 1..32.
using RobotLookup = std::function<const RobotRecord&(std::uint32_t robot_id)>;

class ViewFeeder {
 public:
  ViewFeeder(view::ViewFeed& feed, RobotLookup robots, const TeamSource& team, Duration period,
             std::uint32_t map_resolution_mm);

  // Pose hook: the heading of the robot's newest pose.
  void on_pose(const PoseObservation& pose);
  // Scan hook, run after the fusion stage's: `removed_total` is the fusion stage's live_removed counter
  // now (its growth since the previous scan are this scan's ghosts).
  void on_scan(const StoredScan& scan, std::uint64_t removed_total);
  // Offers a team snapshot if a period has passed (CLOCK_MONOTONIC).
  void tick(Time now_monotonic);
  // The live map's voxels as published on teamscan/map; `whole`: all of them.
  void offer_map(std::span<const teamscan_msg_MapVoxel> voxels, bool whole, std::uint32_t total_voxels);
  // The view dropped pending changes: the next offer_map should be the whole map.
  [[nodiscard]] bool wants_whole_map() const { return feed_.wants_full_map(); }

 private:
  struct PerRobot {
    double yaw_rad = 0.0;
    std::uint64_t ghosts = 0;
    std::int64_t latency_sum_ns = 0;
    std::uint32_t latency_n = 0;
    double latency_ms = 0.0;
  };
  view::ViewFeed& feed_;
  RobotLookup robot_;
  const TeamSource& team_;
  Duration period_;
  std::uint32_t map_resolution_mm_;
  Time next_;
  std::uint64_t removed_seen_ = 0;
  std::array<PerRobot, kMaxRobots + 1> robots_{};
  std::array<view::TapPoint, kMaxBeams> tap_{};
  std::array<TeamMemberEstimate, kMaxRobots> estimates_{};
  std::vector<view::VoxelUpdate> voxels_;
  view::TeamSnapshot snapshot_{};
};

// The built page: share/teamscan/view where installed (find_data_file), else the build tree's
// groundstation/view/web/site beside this executable's folder; empty if neither exists.
[[nodiscard]] std::string default_view_web_root();

}  // namespace teamscan::station
