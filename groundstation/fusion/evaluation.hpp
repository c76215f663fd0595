// Offline evaluation of the filters on a labelled data set (`teamscan eval`): the data set's poses and
// scans go through the fusion core (groundstation/fusion/core.hpp) in time order, the same code the
// ground station runs on live data, and the metrics are computed per method from the core's decisions.
#pragma once

#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "common/dataset/dataset.hpp"
#include "common/result.hpp"
#include "groundstation/fusion/graph_backend.hpp"
#include "groundstation/mapping/dataset_registration.hpp"
#include "groundstation/mapping/filter.hpp"
#include "groundstation/mapping/metrics.hpp"
#include "groundstation/mapping/tracker.hpp"

namespace teamscan::fusion {

// The data set rearranged for filtering: points grouped by scan in time order, each scan with the
// team's tracked state at its stamp.
struct PreparedScan {
  ScanRecord record;
  std::size_t first = 0, count = 0;  // range in PreparedDataset::points
  std::size_t team = 0;              // index in PreparedDataset::teams
};

struct PreparedDataset {
  std::vector<mapping::MapPoint> points;          // scan-grouped order
  std::vector<std::uint16_t> flags;      // per point, same order
  std::vector<std::size_t> source_index; // prepared index → index in Dataset::points
  std::vector<PreparedScan> scans;       // time order (stamp, robot, scan)
  std::vector<mapping::TeamState> teams;          // one per scan
  std::uint64_t orphan_points = 0;       // points whose scan is missing from scans.csv
  [[nodiscard]] mapping::ScanView view(std::size_t scan_index) const;
};

// Localisation noise added to what the filters see (σ 5 cm and 2°), for data sets whose
// simulator cannot inject it: every robot's odometry poses (fed to the tracker) and scan origins /
// poses are offset by a per-robot first-order Gauss–Markov error with stationary σ `sigma_m` per axis
// and `sigma_rad` in heading and correlation time `correlation_s`. The cloud itself is unchanged:
// the filters' idea of where the robots are is wrong relative to it. Deterministic for a seed.
struct PoseNoise {
  double sigma_m = 0.0;
  double sigma_rad = 0.0;
  double correlation_s = 1.0;
  std::uint64_t seed = 1;
  [[nodiscard]] bool active() const { return sigma_m > 0.0 || sigma_rad > 0.0; }
};

[[nodiscard]] PreparedDataset prepare_dataset(const Dataset& dataset, const mapping::TrackerOptions& tracker,
                                              const PoseNoise& noise = {});

// Offline: observe every scan, then classify every scan. Live: observe and classify each scan as it
// arrives (decisions against the map so far). Both return removed flags in Dataset::points order.
[[nodiscard]] std::vector<std::uint8_t> run_offline(const PreparedDataset& prepared, mapping::Filter& filter);
[[nodiscard]] std::vector<std::uint8_t> run_live(const PreparedDataset& prepared, mapping::Filter& filter);

// One evaluated method: a name for the report (e.g. "visibility@0.05m"), the method and its options.
struct MethodSpec {
  std::string name;
  std::string method;
  mapping::MethodOptions options;
};

// How the fusion core is set up for a data set (beyond the method): the tracker, the pose noise, and
// the scan-to-map registration (fusion/core.hpp CoreOptions::registration; off: odometry alone).
struct CoreRunOptions {
  mapping::TrackerOptions tracker;
  PoseNoise noise;
  bool registration = false;
  registration::RegistrationOptions registration_options{};
  // Called with the share of the data set's time line fed so far (0..1), about every 1 %.
  std::function<void(double)> progress;
  // The back end fed every released scan (nullptr: none).
  GraphBackend* graph = nullptr;
  // Per Dataset::scans row, the pose to decide that scan with (the pose graph's; none: the correction
  // of the robot's scan before it), or empty: before anything is fed, the core is given the corrections
  // that place each scan there (graph_map.hpp decide_with), so the scans' points, the team state the
  // filters read and every decision follow those poses. Not with the registration.
  std::vector<std::optional<Pose2>> decide_with{};
};

// What the fusion core made of a data set.
struct CoreRun {
  std::vector<std::uint8_t> removed;       // per point, 1 = removed (Dataset::points order)
  std::vector<mapping::MapPoint> placed;            // per point, where the core put it (registration applied)
  std::vector<Pose2> scan_poses;           // per Dataset::scans row, the pose the core decided it with
  std::vector<std::uint8_t> scan_decided;  // per Dataset::scans row, 1 = released by the core
  std::vector<registration::RobotCorrection> robots;  // registration counters per robot (when on)
  std::uint64_t masked_points = 0;         // kept out of the match
};

// The fusion core fed the data set's odometry and scans in time order (a pose before a scan of the
// same stamp), with `method`; no model store (the decisions are kept per point). With `noise` active,
// the poses and scan origins the core sees carry the PoseNoise error. An error (naming the option) when
// the core refuses the options.
[[nodiscard]] Result<CoreRun> run_through_core(const Dataset& dataset, const std::string& method, const mapping::MethodOptions& options,
                                       const CoreRunOptions& run);
// Whether every robot of a data set has a level 2-D laser (no roll, no pitch: an imported CARMEN log),
// whose walls the registration sees edge-on (SurfaceOptions::planar_scans).
[[nodiscard]] bool level_lasers(const Dataset& dataset);
// Every point's decision (run_through_core(...).removed), odometry alone.
[[nodiscard]] Result<std::vector<std::uint8_t>> decide_through_core(const Dataset& dataset, const std::string& method,
                                                             const mapping::MethodOptions& options, const mapping::TrackerOptions& tracker,
                                                             const PoseNoise& noise = {});

// Method list from the command line: "all" or a comma list of known_methods(). Without an explicit
// resolution / half-angle, "frequency" and "visibility" expand to 0.05 m and 0.1 m and "direction"
// to 5° and 7° (the paper's Tables 2, 3 and 5); with them, each method runs once at that setting.
[[nodiscard]] Result<std::vector<MethodSpec>> parse_methods(const std::string& list, std::optional<double> resolution_m,
                                                            std::optional<double> half_angle_deg,
                                                            const mapping::MethodOptions& base = {});

struct EvalOptions {
  std::vector<MethodSpec> methods;
  mapping::RansacOptions ransac;
  mapping::TrackerOptions tracker;
  PoseNoise pose_noise;  // off by default
  // Called at each stage ("table 1", each method name) and as a stage advances, with the share of the
  // whole evaluation done (0..1), so long runs can show progress.
  std::function<void(const std::string& stage, double fraction)> progress;
  // Scan-to-map registration inside the fusion core (docs/registration.md); off: odometry alone.
  bool registration = false;
  registration::RegistrationOptions registration_options{};
  // The pose graph as the core's back end (graph_backend.hpp), fed the releases of a first run of the
  // first method: its odometry is the core's decided poses (registered, or odometry alone). Then every
  // method runs with the graph's poses (CoreRunOptions::decide_with): the cloud, the decisions and the
  // metrics follow the graph. Unset: no graph.
  std::optional<GraphBackendOptions> pose_graph{};
};

struct MethodResult {
  std::string name;
  std::string method;
  mapping::FilterParams params;
  mapping::RemovalMetrics removal;
  mapping::PlaneFit plane_after;
  double plane_error_improvement_pct = 0;
  double plane_inlier_improvement_pct = 0;
  // Deterministic floor bias against the fixed reference (metrics.hpp floor_bias_m) and its improvement.
  double floor_bias_after_m = 0;
  double floor_bias_improvement_pct = 0;
  std::vector<std::uint8_t> removed;  // Dataset::points order (not serialised)
};

struct EvalReport {
  std::string scenario;
  std::uint64_t seed = 0;
  std::uint64_t points = 0, ghosts = 0, scans = 0, robots = 0, orphan_points = 0;
  EvalOptions options;
  mapping::PlaneFit plane_before;
  mapping::Table1 table1;
  // Floor-bias reference: the least-squares floor of the ghost-free cloud; bias of all points and of
  // the ghost-free cloud against it (the latter ~0: the ideal filter's result).
  mapping::Plane floor_reference;
  double floor_bias_before_m = 0;
  double floor_bias_ghost_free_m = 0;
  std::vector<MethodResult> methods;
  // Pose and point error against the truth with odometry alone and as the fusion core placed the
  // scans (registration on), the registration's counters, revisit consistency.
  mapping::RegistrationReport registration;
  // Every point where the core put it (registration applied; Dataset::points order): the cloud the
  // metrics above were computed on.
  std::vector<mapping::MapPoint> placed;
  // Per Dataset::scans row, the pose the core decided the scan with (registration applied); empty
  // when the core decided none.
  std::vector<Pose2> scan_poses;
  std::vector<std::uint8_t> scan_decided;
  // With EvalOptions::pose_graph: per Dataset::scans row, the graph's pose (the decided one for a scan
  // the core did not release), what it did, and its thread's time from the first release to the end.
  std::vector<Pose2> graph_poses;
  posegraph::SlamStats graph_stats;
  GraphBackendCounters graph_counters;
  double graph_seconds = 0.0;
};

[[nodiscard]] Result<EvalReport> evaluate(const Dataset& dataset, const EvalOptions& options);

// The reports of an evaluation are written by the tools (tools/demo/eval_report.hpp).

}  // namespace teamscan::fusion
