// ViewFeeder: the station's side of the browser view (groundstation/view). From the receive loop it
// offers the view immutable copies, through the view's bounded ViewFeed: a team snapshot every period
// (tracked pose and covariance from the team source, heading of the newest pose, the station's per-robot
// counters, the fusion core's per-robot ghosts removed, scan latency) and the live map's changed voxels
// (the fused model's, each with its class and robot, at the core's release counter). Received scans'
// points never reach the view: what it draws is the model. It never waits for the view's thread.
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
// The fusion core's points of a robot's scans removed as ghosts so far (RobotCounters), by id 1..32.
using GhostCount = std::function<std::uint64_t(std::uint32_t robot_id)>;

class ViewFeeder {
 public:
  // `ghosts` empty: no ghost counts (no fusion).
  ViewFeeder(view::ViewFeed& feed, RobotLookup robots, const TeamSource& team, Duration period,
             std::uint32_t map_resolution_mm, GhostCount ghosts = {});

  // Pose hook: the heading of the robot's newest pose.
  void on_pose(const PoseObservation& pose);
  // Scan hook: the scan's latency (stamp -> taken by the station) and its placed points for the Foxglove
  // /robotN/scan channel (the page draws the fused model, never these). An accepted scan: its robot id
  // was checked at the edge (sample validation).
  void on_scan(const ScanPoints& scan, const Receipt& receipt);
  // Offers a team snapshot if a period has passed (CLOCK_MONOTONIC).
  void tick(Time now_monotonic);
  // Offers a team snapshot now (with the map release of the last offer_map): the station's last one.
  void offer_snapshot();
  // The live map's voxels as published on teamscan/map, `robots[i]` the robot of voxels[i] (or empty);
  // `whole`: all of them; `release`: the core's release counter they show (LiveMap::release).
  void offer_map(std::span<const teamscan_msg_MapVoxel> voxels, std::span<const std::uint8_t> robots, bool whole,
                 std::uint32_t total_voxels, std::uint64_t release);
  // The view dropped pending changes: the next offer_map should be the whole map.
  [[nodiscard]] bool wants_whole_map() const { return feed_.wants_full_map(); }

 private:
  struct PerRobot {
    double yaw_rad = 0.0;
    std::int64_t latency_sum_ns = 0;
    std::uint32_t latency_n = 0;
    double latency_ms = 0.0;
  };
  view::ViewFeed& feed_;
  RobotLookup robot_;
  const TeamSource& team_;
  Duration period_;
  std::uint32_t map_resolution_mm_;
  GhostCount ghosts_;
  Time next_;
  std::array<PerRobot, kMaxRobots + 1> robots_{};
  std::array<TeamMemberEstimate, kMaxRobots> estimates_{};
  std::vector<view::VoxelUpdate> voxels_;
  std::array<view::TapPoint, kMaxBeams> tap_{};  // on_scan's scratch
  view::TeamSnapshot snapshot_{};
};

// The built page: share/teamscan/view where installed (find_data_file), else the build tree's
// groundstation/view/web/site beside this executable's folder; empty if neither exists.
[[nodiscard]] std::string default_view_web_root();

}  // namespace teamscan::station
