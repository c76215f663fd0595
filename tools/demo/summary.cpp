// The demo's summary on stdout (summary.hpp).
#include "tools/demo/summary.hpp"

#include <cstdio>

namespace teamscan::demo {
namespace {

template <typename... Args>
std::string line(const char* f, Args... args) {
  char b[512];
  std::snprintf(b, sizeof b, f, args...);
  return std::string(b) + "\n";
}

}  // namespace

std::string summary_text(const DemoSummary& s) {
  std::string t;
  char speed[48] = "";
  if (s.speed != 1.0) std::snprintf(speed, sizeof speed, " at %.2gx real time", s.speed);
  t += line("teamscan demo: %s, %zu robots, %.0f s of robot time%s, DDS %s; registration %s; pose graph %s", s.scenario.c_str(),
            s.robots, s.duration_s, speed, s.network.c_str(), s.registration_why.c_str(), s.pose_graph ? "on" : "off");
  t += line("  delivery: %llu scans stored from %zu robots, %llu missing from their sequence numbers, %llu poses "
            "missing: %s",
            static_cast<unsigned long long>(s.scans_stored), s.robots, static_cast<unsigned long long>(s.scans_missing),
            static_cast<unsigned long long>(s.poses_missing), s.none_lost ? "nothing lost" : "SCANS OR POSES LOST");
  if (s.model_present) {
    t += line(
        "  ghosts: the station's model (%s) removed %.1f %% of the ghost points (DA) and kept %.2f %% of the scene "
        "(SA)",
        s.station_method.c_str(), s.model_da, s.model_sa);
    if (s.offline_da && s.offline_sa)
      t += line(
          "  live vs offline: DA %.1f %% vs %.1f %%, SA %.2f %% vs %.2f %% (the same scenario simulated without "
          "devices)",
          s.model_da, *s.offline_da, s.model_sa, *s.offline_sa);
  } else {
    t += line("  ghosts: the station wrote no usable model (%s)", s.model_error.c_str());
  }
  if (s.onboard_da) t += line("  the robots' own direction filter removed %.1f %% of the ghosts live", *s.onboard_da);
  t += line("  same decisions as %s: %s", s.identity_what.c_str(), s.identity ? "yes, point by point" : "NO");
  if (s.pose_p99_odometry_m && s.pose_p99_corrected_m)
    t += line("  registration: pose error p99 %.1f cm with odometry alone, %.1f cm corrected",
              *s.pose_p99_odometry_m * 100, *s.pose_p99_corrected_m * 100);
  if (s.pose_p99_graph_m && s.pose_p99_graph_deg)
    t += line("  pose graph: pose error p99 %.1f cm / %.2f deg, %zu loop closures; the final model is on its poses",
              *s.pose_p99_graph_m * 100, *s.pose_p99_graph_deg, s.graph_closures);
  t += line("  latency scan -> fused map: p50 %.0f ms, p99 %.0f ms", s.fused_latency_p50_ms, s.fused_latency_p99_ms);
  t += line("  files: %s/", s.out.c_str());
  t += "    fused.pcd (the station's model), live-fused-top.png, report.md (every figure), summary.json, session/, "
       "logs/\n";
  const bool pass = s.none_lost && s.agree && s.clean;
  t += line("verdict: %s (nothing lost: %s, live agrees with offline and with the session: %s, clean exits: %s)",
            pass ? "PASS" : "FAIL", s.none_lost ? "yes" : "NO", s.agree ? "yes" : "NO", s.clean ? "yes" : "NO");
  return t;
}

}  // namespace teamscan::demo
