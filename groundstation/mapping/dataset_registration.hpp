// The registration's figures on a data set (`teamscan eval`; docs/registration.md): pose error per
// scan (translation, rotation) and point error per non-ghost point against the simulator's truth, as
// odometry alone placed them (the data set as it is) and as the fusion core placed them with the
// registration on (groundstation/fusion: the one path, live and offline), and the revisit
// consistency, which needs no truth.
#pragma once

#include <cstdint>
#include <span>
#include <vector>

#include "common/dataset/dataset.hpp"
#include "groundstation/mapping/voxel_map.hpp"
#include "groundstation/registration/registration.hpp"

namespace teamscan::mapping {

struct ErrorStats {
  std::uint64_t count = 0;
  double p50 = 0, p99 = 0, max = 0;
};

// Revisit consistency, a figure that needs no truth: for every point measured at least `min_age_s`
// after the earliest point within `radius_m` of it (a revisit of a place mapped before), its
// horizontal distance to the nearest point of that earlier pass. A consistent map puts a revisit on
// the surfaces seen before (median ≈ range noise and beam spacing); drift shifts it by the pose
// error accumulated in between. Reported: median and p90 over the revisit points, and their share.
// The revisit set depends on the map (a revisit drawn > radius_m off counts as new ground), so the
// figure that compares two maps of one log over the same denominator is `on_earlier_points`: the
// points within `on_earlier_m` (10 cm) of the earlier pass, a share of all points (the more of the
// log lands on what was mapped before, the more consistent the map).
struct RevisitConsistency {
  double median_m = 0, p90_m = 0;
  std::uint64_t revisit_points = 0, points = 0;
  std::uint64_t on_earlier_points = 0;
  double on_earlier_m = 0.10;
};
// `placed`: one point per Dataset::points row where the map has it (empty: the data set's points).
[[nodiscard]] RevisitConsistency revisit_consistency(const Dataset& dataset, std::span<const MapPoint> placed = {},
                                                     double min_age_s = 30.0, double radius_m = 0.5);

struct RegistrationReport {
  bool enabled = false;   // the registration placed the scans (its counters below)
  bool by_graph = false;  // the pose graph's poses placed them (the "after" figures are the graph's)
  bool have_truth = false;
  ErrorStats pose_m_before, pose_m_after, pose_deg_before, pose_deg_after;  // per scan: pose vs true pose
  ErrorStats point_m_before, point_m_after;                                 // per non-ghost point: vs true hit
  std::vector<registration::RobotCorrection> robots;                        // counters and last correction
  std::uint64_t masked_points = 0;                                          // kept out of the match
  RevisitConsistency consistency_before, consistency_after;                 // also without truth
};

// Error statistics against the truth. Empty `placed` / `scan_poses`: the data set as it is (odometry
// alone); else one per Dataset::points row / Dataset::scans row as the fusion core placed them, with
// `scan_decided` (one per scans row) naming the scans the core decided (the others are not counted).
void measure_errors(const Dataset& dataset, ErrorStats& pose_m, ErrorStats& pose_deg, ErrorStats& point_m,
                    std::span<const MapPoint> placed = {}, std::span<const Pose2> scan_poses = {},
                    std::span<const std::uint8_t> scan_decided = {});

}  // namespace teamscan::mapping
