// The demo's summary on stdout: at most 15 lines a newcomer reads (what ran, nothing lost, ghosts
// removed, live vs offline, latency, where the files are, the verdict). Every figure is in report.md.
#pragma once

#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>

namespace teamscan::demo {

// The figures the summary shows, filled by the report stage (demo_report.cpp).
struct DemoSummary {
  std::string scenario;
  std::size_t robots = 0;
  double duration_s = 0, speed = 1;
  std::string registration_why;  // "off: the scenario's robots do not drift", ...
  std::string network;           // "on loopback (cyclonedds-lo.xml)", "in network namespaces (...)"
  std::uint64_t scans_stored = 0, scans_missing = 0, poses_missing = 0;
  bool none_lost = false;
  bool model_present = false;  // the station wrote its model
  std::string model_error;     // why not
  std::string station_method;
  double model_da = 0, model_sa = 0;             // the station's model against the truth, %
  std::optional<double> offline_da, offline_sa;  // `teamscan eval` of the offline simulation, same method
  std::optional<double> onboard_da;              // the robots' own direction filter, live
  std::string identity_what;                     // "`teamscan eval` of its session", ...
  bool identity = false;
  std::optional<double> pose_p99_odometry_m, pose_p99_corrected_m;  // registration on and measured
  bool pose_graph = false;                                         // the station's back end on
  // The station's pose graph against the truth (measured), and its loop closures.
  std::optional<double> pose_p99_graph_m, pose_p99_graph_deg;
  std::size_t graph_closures = 0;
  double fused_latency_p50_ms = 0, fused_latency_p99_ms = 0;
  std::string out;  // the output folder
  bool agree = false, clean = false;
};

// At most kSummaryLines lines, each ending in '\n'.
inline constexpr int kSummaryLines = 15;
[[nodiscard]] std::string summary_text(const DemoSummary& s);

}  // namespace teamscan::demo
