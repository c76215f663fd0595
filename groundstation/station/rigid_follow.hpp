// FusionStage::RigidFollow: the state of a rigid follow of the pose graph under way (fusion_follow.cpp),
// private to the station's fusion stage (fusion.hpp).
#pragma once

#include <cstdint>
#include <future>
#include <memory>
#include <vector>

#include "common/clock.hpp"
#include "groundstation/fusion/graph_backend.hpp"
#include "groundstation/fusion/model_move.hpp"
#include "groundstation/fusion/model_store.hpp"
#include "groundstation/station/fusion.hpp"
#include "groundstation/station/live_map.hpp"

namespace teamscan::station {

// The estimate followed; the moves from where the cores placed their scans to its poses, made on a thread
// (`preparing`, then `prepared`); the live map built from the primary's moved model and the scans
// released meanwhile; the old models, freed with it off the loop once the moved ones took their place.
struct FusionStage::RigidFollow {
  // Made on a thread: the moves, and the new models and live map with room for the old ones' voxels (a
  // large table's allocation and zeroing stays out of the loop).
  struct Prepared {
    fusion::ScanPlacement to;
    std::shared_ptr<const fusion::ScanMoves> moves;
    std::vector<std::unique_ptr<fusion::ModelStore>> stores;  // per core
    std::unique_ptr<LiveMap> map;
  };
  std::shared_ptr<const fusion::GraphEstimate> estimate;
  std::future<Prepared> preparing;
  Prepared prepared;
  std::unique_ptr<LiveMap> map;  // the primary's moved model and its releases since, as the live map will show it
  bool begun = false;            // the cores' moves begun
  bool exact = false;            // an exact follow is due: worth following, the session is decided again instead
  std::vector<std::unique_ptr<fusion::ModelStore>> old_stores;
  std::uint64_t moved_points = 0;
  Time started;
  std::uint64_t turns = 0;
  Duration slice_max{0};
};

}  // namespace teamscan::station
