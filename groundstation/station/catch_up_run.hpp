// FusionStage::CatchUpRun: the state of a catch-up in slices under way (fusion_catch_up.cpp), private to
// the station's fusion stage (fusion.hpp).
#pragma once

#include <cstdint>
#include <future>
#include <memory>
#include <set>
#include <utility>
#include <vector>

#include "common/clock.hpp"
#include "common/pose.hpp"
#include "common/result.hpp"
#include "groundstation/fusion/core_rebuild.hpp"
#include "groundstation/fusion/graph_backend.hpp"
#include "groundstation/station/fusion.hpp"

namespace teamscan::station {

// The catch-up in slices. The live cores go on as they are (the live map, the latency, the team state);
// a second set of cores is built from the session folder as it was at this turn (read on a loader thread)
// and fed it in time order, catch_up_slice_scans per turn, then the live inputs since this turn in their
// order; once it has caught up, the live cores take over its state.
struct FusionStage::CatchUpRun {
  explicit CatchUpRun(std::int64_t realtime_ns, double resolution_m) : rebuild{realtime_ns}, map{resolution_m} {}
  fusion::CoreRebuild rebuild;
  std::future<Result<fusion::RebuildSource>> loading;
  std::uint64_t scans_needed = 0;  // the scans the live cores had taken: the session read must hold them
  LiveMap map;                     // the rebuilt primary's model, as the live map will show it
  std::unique_ptr<fusion::GraphBackend> graph;  // fed the rebuilt primary's releases (a catch-up with pose_graph)
  std::shared_ptr<const fusion::GraphEstimate> on_graph;  // the estimate the cores are rebuilt on (none: as configured)
  bool follow = false;             // a rebuild on the estimate that keeps the live graph
  std::uint64_t scans = 0, points = 0, live_removed = 0;
  bool behind = false;             // the session is fed: the rebuilt cores take the queued live inputs
  std::uint64_t late_base = 0;     // the rebuilt primary's scans_late + poses_late after the session
  // The scans the live primary released since the start, and those the rebuilt one released from the
  // queue (its own release of a live input), with what their latency and trajectory need.
  std::set<std::pair<std::uint8_t, std::uint32_t>> live_released;
  struct Released {
    std::uint8_t robot;
    std::uint32_t scan;
    std::int64_t stamp_ns, arrival_ns;
    Pose2 map_from_robot;
  };
  std::vector<Released> rebuilt_released;
  Time started;
  std::uint64_t turns = 0;
  Duration slice_max{0};
};

}  // namespace teamscan::station
