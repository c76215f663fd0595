// Scoring of a `teamscan demo` run: the ground station's session turned into a labelled data set on the
// simulator's time base (with delivery counts per robot), the station's own fused model scored against
// the truth, the station's latency files, and the fault analyses read from the session.
#pragma once

#include <cstdint>
#include <map>
#include <string>
#include <unordered_map>
#include <utility>
#include <vector>

#include "common/dataset/dataset.hpp"
#include "common/odom_correction.hpp"
#include "groundstation/fusion/graph_backend.hpp"
#include "groundstation/mapping/dataset_registration.hpp"
#include "groundstation/mapping/metrics.hpp"
#include "groundstation/station/scan_record.hpp"
#include "sim/live.hpp"
#include "sim/scenario.hpp"
#include "sim/simulator.hpp"
#include "tools/demo/session_csv.hpp"

namespace teamscan::demo {

// What the ground station stored of one robot.
struct RobotDelivery {
  std::uint8_t id = 0;
  std::uint64_t stored = 0, duplicates = 0, gaps = 0;  // gaps: seq numbers missing between first and last
  std::uint32_t seq_first = 0, seq_last = 0;
  // Its poses (poses.csv): stored, stored twice, seq numbers missing between its first and last.
  std::uint64_t poses = 0, pose_duplicates = 0, pose_gaps = 0;
  std::uint32_t pose_seq_first = 0, pose_seq_last = 0;
  std::uint32_t last_status_published = 0;  // scans_published in the robot's last status
  std::uint64_t refused = 0;  // stored scans the station refused at the edge (docs/validation.md): never fused
  std::uint64_t in_window = 0, truth_matched = 0, truth_unmatched = 0;
  std::uint64_t measured = 0;  // scans the emulated LMS sent
  std::uint64_t truth_ghost_beams = 0;  // beams cast on a teammate within the run window
};

// Live session -> labelled data set on the simulator's time base (scenario start + world time).
struct LiveDataset {
  Dataset ds;
  std::vector<RobotDelivery> delivery;
  station::ScanDecodeStats decode;
  std::string session_error;       // a session file that could not be read as expected
  std::vector<double> latency_ms;  // scan stamp (sweep end) -> stored by the station, per stored scan
  std::vector<std::uint32_t> point_seq;  // per ds.points: the robot's scan sequence number (the station's `scan`)
  std::vector<std::uint32_t> scan_seq;   // per ds.scans: the same
  std::vector<double> point_error_mm;    // per point with a true hit: |measured − true hit point|
};

[[nodiscard]] LiveDataset build_live_dataset(const std::string& session, sim::LiveTeam& live,
                                             const std::vector<std::vector<sim::LiveScanTruth>>& truths,
                                             const sim::Scenario& scenario, const Dataset& offline,
                                             double duration_s);

// The station's latency.csv (groundstation/station/latency_histogram.hpp): the two histograms' summary
// lines, in file order scan -> stored, then scan -> fused map.
struct LatencySummary {
  bool present = false;
  double count = 0, p50_ms = 0, p90_ms = 0, p99_ms = 0, max_ms = 0;
};
[[nodiscard]] std::vector<LatencySummary> read_latency_csv(const std::string& path);

// The station's fused_latency.csv (fusion.latency_log): scan -> fused map per scan, ms, sorted, for the
// scans stamped in [from_ns, to_ns] (CLOCK_REALTIME).
[[nodiscard]] std::vector<double> read_fused_latency_log(const std::string& path, std::int64_t from_ns,
                                                         std::int64_t to_ns);

// The value at quantile q (0..1) of a sorted vector; 0 when empty.
[[nodiscard]] double sorted_pct(const std::vector<double>& v, double q);

// The ground station's own fused model scored against the truth: fused_all.pcd carries per point the
// robot, its scan sequence number, the beam, `keep` (the station's last model write) and `live_keep`
// (the live decision at arrival).
struct StationScore {
  bool present = false;
  std::string error;
  std::uint64_t model_points = 0, matched = 0, unmatched = 0;
  mapping::RemovalMetrics model, live;
  std::vector<std::uint8_t> removed;  // per LiveDataset point (1 = the station's model removed it)
};
[[nodiscard]] StationScore score_station_model(const std::string& fused_all_pcd, const std::vector<LabelledPoint>& points,
                                               const std::vector<std::uint32_t>& point_seq);

// The station's model against `teamscan eval` of its own session (station/model_check.hpp: the fusion
// core fed the session read back, in time order, with the options of the station's config): every
// point's decision compared, and the labelled points scored three ways (the model, eval, the decisions
// at release).
struct SessionEvalCheck {
  std::string error;   // the station config or the session could not be read; nothing compared
  std::string method;  // the method whose model was checked
  bool primary = false;  // the station's [fusion] method (else one of its compare_methods)
  std::uint64_t compared = 0, not_in_model = 0, mismatches = 0;
  std::size_t labelled = 0;  // model points with a truth label (`points`)
  mapping::RemovalMetrics station, eval, live;
  bool identical = false;  // no mismatch and something compared
};
// `method` empty: the station's [fusion] method; else one of its compare_methods (fused_all.<method>.pcd).
[[nodiscard]] SessionEvalCheck check_station_against_session_eval(const std::string& session, const std::string& station_config,
                                                                  const std::vector<LabelledPoint>& points,
                                                                  const std::vector<std::uint32_t>& point_seq,
                                                                  const std::string& method = {});
// Every model the station wrote: its [fusion] method first, then each of its compare_methods. A station
// config that cannot be read gives one failed check.
[[nodiscard]] std::vector<SessionEvalCheck> check_station_models_against_session_eval(
    const std::string& session, const std::string& station_config, const std::vector<LabelledPoint>& points,
    const std::vector<std::uint32_t>& point_seq);

// The station's models against its own fusion core replaying its session in arrival order (each
// sample with its receive time, as the station's restart rebuilds it: FusionStage::replay_session; when
// a scan was released late (CoreCounters::scans_late), a robot's back-fill, the session again in time order, as the
// station's catch-up feeds it: FusionStage::flush):
// every model row's decision (keep) and position compared, per model (its [fusion] method first, then
// each compare_method). With the registration on, this is the identity the demo requires: the
// registration's corrections follow the order the core releases scans in, which live is the arrival
// order, while `teamscan eval SESSION` feeds the session in stamp order (docs/demo.md "Registration").
struct ReplayModelCheck {
  std::string method;
  bool primary = false;
  std::string error;
  std::uint64_t model_points = 0, replay_points = 0, compared = 0;
  std::uint64_t decisions_differ = 0, placed_differ = 0;  // placed: more than 1 mm apart
  double placed_differ_max_m = 0;
  bool identical = false;  // something compared, every row in both, nothing differs
};
// The replay's checks and, with the registration on, the primary core's placement for the
// registration's figures (off: empty, the robots' own poses and points stand).
struct SessionReplay {
  std::string error;  // the config or the session could not be read; nothing compared
  std::vector<ReplayModelCheck> models;
  std::map<std::pair<std::uint8_t, std::uint32_t>, Pose2> scan_pose;  // (robot, seq) -> the pose it was decided with
  std::unordered_map<std::uint64_t, mapping::MapPoint> placed;         // point_key -> where the core put it
  std::vector<registration::RobotCorrection> robots;                   // the registration's counters (when on)
  // With the station's [pose_graph]: the back end fed the replay's releases (fusion/graph_backend.hpp),
  // (robot, seq) -> its pose after the last optimisation, and what the graph did.
  bool pose_graph = false;
  std::map<std::pair<std::uint8_t, std::uint32_t>, Pose2> graph_pose;
  std::map<std::uint8_t, std::string> graph_tum;  // robot -> robot<N>.graph.tum as the station writes it
  posegraph::SlamStats graph_stats;
};
// `scratch_dir`: where the replayed models are written (created; the caller removes it).
[[nodiscard]] SessionReplay replay_station_session(const std::string& session, const std::string& station_config,
                                                   const std::string& scratch_dir);

// The registration live (docs/demo.md "Registration"): pose error per scan and point error per non-ghost
// point against the live world's truth, as the robots' odometry placed them (the session as stored) and
// as the station corrected them (`replay`: its core on its session in arrival order, whose model is
// checked row by row against the station's). Only the scans and points of the run window (those with a
// truth in `live`) are measured, with `teamscan eval`'s metric (mapping::measure_errors).
struct LiveRegistrationScore {
  std::string error;     // the config or the session could not be read; nothing measured
  bool enabled = false;  // the station config's registration
  std::uint64_t scans = 0, points = 0;  // measured: scans with a true pose, non-ghost points with a true hit
  mapping::ErrorStats pose_m_odometry, pose_deg_odometry, point_m_odometry;
  mapping::ErrorStats pose_m_corrected, pose_deg_corrected, point_m_corrected;  // = odometry when off
  std::uint64_t points_moved = 0;   // session points the station placed more than 1 mm from the robot's point
  double points_moved_max_m = 0;
  // With the station's [pose_graph] (replay.pose_graph): the graph's poses against the truth, and whether
  // the station's robot<N>.graph.tum are the replay's to the byte (graph_files of them compared).
  bool graph = false;
  mapping::ErrorStats pose_m_graph, pose_deg_graph;
  std::size_t graph_files = 0, graph_files_differ = 0;
  std::string graph_error;  // a file missing or unreadable
};
[[nodiscard]] LiveRegistrationScore score_live_registration(const std::string& session, const std::string& station_config,
                                                            const SessionReplay& replay, const LiveDataset& live);

// The corrections back on the robots (docs/registration.md "Back on the robots"): per robot, what its
// daemon did with the corrections teamscan/team brought it (its last status: taken into use, refused),
// the stored scans that say they carry one (scans.bin records each scan's applied correction), and the
// pose error against the live world's truth of the run window's scans that carry one: as the robot
// placed them (the correction it applied on its odometry) and by its odometry alone.
struct RobotCorrectionScore {
  std::uint8_t robot = 0;
  std::uint64_t corrections_applied = 0, corrections_rejected = 0;  // the robot's last status
  std::uint64_t scans = 0, scans_corrected = 0;  // stored (accepted at the edge), and carrying a correction
  std::uint64_t corrections_carried = 0;         // distinct corrections (corr_seq) the scans carry
  OdomCorrection last;                           // the last scan's
  mapping::ErrorStats pose_m_odometry, pose_deg_odometry, pose_m_robot, pose_deg_robot;
};
struct RobotCorrections {
  std::string error;  // the session could not be read; nothing measured
  std::vector<RobotCorrectionScore> robots;  // by robot id
};
[[nodiscard]] RobotCorrections score_robot_corrections(const std::string& session, const LiveDataset& live);

// Fault `--unplug-robot`: the robot's lms_state sequence as the station stored it (consecutive
// duplicates merged) and its highest lms_reopens, from status.csv.
struct UnplugReport {
  std::vector<unsigned> lms_states;
  std::uint32_t lms_reopens = 0;
};
[[nodiscard]] UnplugReport unplug_report(const std::vector<StatusRow>& status, std::uint32_t robot_id);

// Fault `--kill-robot`: when the station marked the robot lost (events.log), and the other robots'
// points from 1 s after the kill (scans.bin).
struct KillReport {
  double lost_after_s = -1;  // -1: never marked lost after the kill
  std::uint64_t others_scans_after = 0;
  std::uint64_t team_stale_before = 0, team_stale_after = 0, direction_filtered_after = 0;
};
[[nodiscard]] KillReport kill_report(const std::string& session, std::uint32_t robot_id, std::int64_t kill_realtime_ns);

}  // namespace teamscan::demo
