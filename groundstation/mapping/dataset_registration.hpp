// Offline registration of a data set (`teamscan eval`; docs/registration.md): every scan in time
// order goes through groundstation/registration as the station would see it, its points are moved by
// its robot's correction, and so are its pose, its origin and the robot's odometry samples (what the
// tracker and every filter use). Ghost-flagged points (onboard direction filter) and points inside a
// teammate's tracked body never pull the match. With truth (simulated data sets) it measures the pose
// error (translation, rotation) and the point error before and after.
#pragma once

#include <cstdint>
#include <vector>

#include "common/dataset/dataset.hpp"
#include "groundstation/mapping/beyond_options.hpp"
#include "groundstation/mapping/tracker.hpp"
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
struct RevisitConsistency {
  double median_m = 0, p90_m = 0;
  std::uint64_t revisit_points = 0, points = 0;
};
[[nodiscard]] RevisitConsistency revisit_consistency(const Dataset& dataset, double min_age_s = 30.0, double radius_m = 0.5);

struct RegistrationReport {
  bool enabled = false;
  bool have_truth = false;
  ErrorStats pose_m_before, pose_m_after, pose_deg_before, pose_deg_after;  // per scan: pose vs true pose
  ErrorStats point_m_before, point_m_after;                                 // per non-ghost point: vs true hit
  std::vector<registration::RobotCorrection> robots;                        // counters and last correction
  std::uint64_t masked_points = 0;                                          // kept out of the match
  RevisitConsistency consistency_before, consistency_after;                 // also without truth
};

struct DatasetRegistrationOptions {
  registration::RegistrationOptions registration;
  TrackedOptions body;  // teammates' bodies: points inside never pull the match
};

// Error statistics of a data set as it is (no registration): for `--no-registration` and "before".
void measure_errors(const Dataset& dataset, ErrorStats& pose_m, ErrorStats& pose_deg, ErrorStats& point_m);

// Registers `dataset` in place (points, scan poses and origins, odometry) and reports.
[[nodiscard]] RegistrationReport register_dataset(Dataset& dataset, const TrackerOptions& tracker,
                                                  const DatasetRegistrationOptions& options = {});

}  // namespace teamscan::mapping
