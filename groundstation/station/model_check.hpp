// The station's model checked against `teamscan eval` of its own session: every point of fused_all.pcd
// (robot, seq, beam, keep, live_keep) next to the decision the fusion core gives it when the session
// folder is read back and fed in time order (`teamscan eval SESSION`). The demo and the end-to-end test
// score with it; identical decisions are the fusion core's promise (docs/groundstation.md).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "common/result.hpp"
#include "groundstation/station/fusion.hpp"

namespace teamscan::station {

struct PointDecision {
  std::uint8_t robot = 0;
  std::uint32_t seq = 0;
  std::uint16_t beam = 0;
  bool in_model = false;      // in fused_all.pcd (the model store keeps at most max_points_per_voxel)
  bool model_removed = false; // fused_all.pcd keep == 0
  bool live_removed = false;  // fused_all.pcd live_keep == 0 (the decision at release)
  bool eval_removed = false;  // the core on the session read back, in time order
};

struct ModelCheck {
  std::vector<PointDecision> points;  // every point of the session (read back), in session order
  std::uint64_t model_points = 0;     // rows of fused_all.pcd
  std::uint64_t compared = 0;         // session points found in the model
  std::uint64_t mismatches = 0;       // of those, model decision != eval decision
  std::uint64_t not_in_model = 0;     // session points the model store did not keep (voxel cap)
  std::uint64_t model_unknown = 0;    // model rows not in the session (should be 0)
};

// Reads `session`/fused_all.pcd and the session files; `options` as the station ran (its config).
[[nodiscard]] Result<ModelCheck> check_model_against_eval(const std::string& session, const FusionOptions& options);

// The key a point's identity packs into (robot, seq, beam).
[[nodiscard]] inline std::uint64_t point_key(std::uint32_t robot, std::uint32_t seq, std::uint32_t beam) {
  return (static_cast<std::uint64_t>(robot) << 48) | (static_cast<std::uint64_t>(seq) << 16) | beam;
}

}  // namespace teamscan::station
