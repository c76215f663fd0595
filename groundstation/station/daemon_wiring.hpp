// teamscan-groundstation's parts and how they are wired: the session store, the fusion stage, the team
// source, the station (DDS), the ROS 2 publisher, the browser view, and the station's hooks that feed
// them every stored sample. The run loop (daemon_loop.hpp) then drives them.
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "groundstation/station/config.hpp"
#include "groundstation/station/disk_sync.hpp"
#include "groundstation/station/fusion.hpp"
#include "groundstation/station/huge_page_heap.hpp"
#include "groundstation/station/ros2_publisher.hpp"
#include "groundstation/station/session_store.hpp"
#include "groundstation/station/station.hpp"
#include "groundstation/station/team_source.hpp"
#include "groundstation/station/view_feeder.hpp"
#include "groundstation/view/server.hpp"
#include "teamscan.h"

namespace teamscan::station::daemon {

// Every part the daemon runs, in the order they start (and stop in reverse). The hooks refer to the
// parts by reference, so a Daemon never moves; it outlives every thread the parts start.
struct Daemon {
  Daemon() = default;
  Daemon(const Daemon&) = delete;
  Daemon& operator=(const Daemon&) = delete;

  std::optional<SessionStore> store;
  std::unique_ptr<FusionStage> fusion;  // [fusion] enabled
  std::unique_ptr<TeamSource> team_source;
  std::unique_ptr<Station> station;
  std::unique_ptr<Ros2Publisher> ros2;  // [ros2] enabled
  std::vector<teamscan_msg_MapVoxel> map_voxels;  // the loop's teamscan/map publication
  std::vector<std::uint8_t> map_robots;           // the robot of each of map_voxels
  CorrectionShare corrections;  // each robot's new registration correction to the team source
  bool writer_told = false;     // the model writer thread's placement logged once
  bool match_told = false;      // a refused registration.cpus warned once
  std::unique_ptr<view::ViewFeed> view_feed;  // [view] listen, and the server started
  std::unique_ptr<ViewFeeder> view_feeder;
  std::unique_ptr<view::ViewServer> view_server;
  std::unique_ptr<DiskSync> disk_sync;  // started by the run loop, once the station is ready
};

// Opens the session folder (`session_dir`, or a new one under session_root) and starts every part in
// order, logging as it goes. A value: the failure is logged, exit with it (1).
[[nodiscard]] std::optional<int> start_daemon(const GroundStationConfig& cfg, const std::string& session_dir, HeapPages heap,
                                              const std::string& heap_why, Daemon& d);

}  // namespace teamscan::station::daemon
