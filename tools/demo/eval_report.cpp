// `teamscan eval`'s reports (eval_report.hpp).
#include "tools/demo/eval_report.hpp"

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <sstream>

#include "common/units.hpp"

namespace teamscan::demo {
namespace {

using namespace teamscan::mapping;
using fusion::EvalReport;
using fusion::MethodResult;

const char* class_name(std::size_t c) {
  static const char* const kNames[kPointClasses] = {"none", "floor", "wall", "ceiling", "furniture", "robot"};
  return c < kPointClasses ? kNames[c] : "?";
}

// A figure as the reports give it: 10 significant digits; not finite: null.
ReportJson number(double v) {
  if (!std::isfinite(v)) return nullptr;
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.10g", v);
  return std::strtod(buf, nullptr);
}

// The registration's drift rates as the report has always given them: 6 significant digits.
ReportJson rate(double v) {
  if (!std::isfinite(v)) return nullptr;
  char buf[64];
  std::snprintf(buf, sizeof buf, "%g", v);
  return std::strtod(buf, nullptr);
}

// The same figure as text (the Markdown report's parameters).
std::string number_text(double v) {
  if (!std::isfinite(v)) return "null";
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.10g", v);
  return buf;
}

std::string format_number(double v, int decimals) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.*f", decimals, v);
  return buf;
}

std::string md(double v, int decimals = 1) { return std::isfinite(v) ? format_number(v, decimals) : "–"; }

// The scene classes reported as "kept": floor, wall, ceiling, furniture.
constexpr std::size_t kSceneClasses[] = {1, 2, 3, 4};

ReportJson plane_json(const PlaneFit& f) {
  return {{"found", f.found},
          {"a", number(f.plane.normal.x())},
          {"b", number(f.plane.normal.y())},
          {"c", number(f.plane.normal.z())},
          {"d", number(f.plane.d)},
          {"points", f.points},
          {"inliers", f.inliers},
          {"inlier_share", number(f.inlier_share)},
          {"signed_mean_error_mm", number(f.signed_mean_error_m * 1e3)},
          {"mean_abs_error_mm", number(f.mean_abs_error_m * 1e3)},
          {"rms_error_mm", number(f.rms_error_m * 1e3)}};
}


ReportJson counts_json(const EvalReport& r) {
  ReportJson c = {{"points", r.points}, {"ghosts", r.ghosts}, {"others", r.points - r.ghosts},
                  {"scans", r.scans},   {"robots", r.robots}, {"orphan_points", r.orphan_points}};
  if (!r.methods.empty()) {
    ReportJson by_class = ReportJson::object();
    for (std::size_t k = 0; k < kPointClasses; ++k)
      by_class[class_name(k)] = r.methods.front().removal.by_class[k].total;
    c["by_class"] = by_class;
  }
  return c;
}

ReportJson options_json(const EvalReport& r, ReportJson& tracker) {
  const RansacOptions& rs = r.options.ransac;
  const TrackerOptions& tr = r.options.tracker;
  tracker = {{"accel_noise_mps2", number(tr.accel_noise_mps2)},
             {"position_noise_m", number(tr.position_noise_m)},
             {"velocity_noise_mps", number(tr.velocity_noise_mps)},
             {"use_velocity", tr.use_velocity},
             {"lost_after_s", number(tr.lost_after_s)},
             {"drift_m_per_m", number(tr.drift_m_per_m)},
             {"drift_heading_rad_per_m", number(tr.drift_heading_rad_per_m)},
             {"drift_heading_rad_per_rad", number(tr.drift_heading_rad_per_rad)}};
  return {{"threshold_m", number(rs.threshold_m)},
          {"iterations", rs.iterations},
          {"seed", rs.seed},
          {"max_tilt_deg", number(rs.max_tilt_deg)},
          {"max_height_m", number(rs.max_height_m)},
          {"error_reference", rs.error_reference == PlaneErrorReference::sample ? "sample" : "refit"}};
}

ReportJson method_json(const MethodResult& m) {
  ReportJson params = ReportJson::object();
  for (const auto& [name, value] : m.params) params[name] = number(value);
  ReportJson kept = ReportJson::object();
  for (std::size_t c : kSceneClasses) kept[class_name(c)] = number(m.removal.by_class[c].kept_pct());
  return {{"name", m.name},
          {"params", params},
          {"ghost_removed_pct", number(m.removal.ghost_removed_pct)},
          {"other_removed_pct", number(m.removal.other_removed_pct)},
          {"plane_error_improvement_pct", number(m.plane_error_improvement_pct)},
          {"plane_inlier_improvement_pct", number(m.plane_inlier_improvement_pct)},
          {"floor_bias_mm", number(m.floor_bias_after_m * 1e3)},
          {"floor_bias_improvement_pct", number(m.floor_bias_improvement_pct)},
          {"SA", number(m.removal.sa)},
          {"DA", number(m.removal.da)},
          {"AA", number(m.removal.aa)},
          {"HA", number(m.removal.ha)},
          {"kept_by_class", kept}};
}

ReportJson registration_json(const RegistrationReport& g) {
  auto share_on_earlier = [](const RevisitConsistency& k) {
    return k.points ? static_cast<double>(k.on_earlier_points) / static_cast<double>(k.points) : 0.0;
  };
  const bool placed = g.enabled || g.by_graph;
  const RevisitConsistency& after = placed ? g.consistency_after : g.consistency_before;
  ReportJson j = {{"enabled", g.enabled},
                  {"placed_by", g.by_graph ? "pose_graph" : g.enabled ? "registration" : "odometry"},
                  {"have_truth", g.have_truth},
                  {"consistency_before_median_m", number(g.consistency_before.median_m)},
                  {"consistency_after_median_m", number(after.median_m)},
                  {"consistency_before_on_earlier_share", number(share_on_earlier(g.consistency_before))},
                  {"consistency_after_on_earlier_share", number(share_on_earlier(after))}};
  if (g.have_truth) {
    j["pose_m_before"] = stats_json(g.pose_m_before);
    j["pose_deg_before"] = stats_json(g.pose_deg_before);
    j["point_m_before"] = stats_json(g.point_m_before);
    if (placed) {
      j["pose_m_after"] = stats_json(g.pose_m_after);
      j["pose_deg_after"] = stats_json(g.pose_deg_after);
      j["point_m_after"] = stats_json(g.point_m_after);
    }
  }
  ReportJson robots = ReportJson::array();
  for (const registration::RobotCorrection& c : g.robots)
    robots.push_back({{"robot", int(c.robot)},
                      {"matches", c.matches},
                      {"accepted", c.accepted},
                      {"degenerate", c.degenerate},
                      {"standing_still", c.standing_still},
                      {"first_lap", c.first_lap},
                      {"rejected_overlap", c.rejected_overlap},
                      {"rejected_fit", c.rejected_fit},
                      {"rejected_step", c.rejected_step},
                      {"too_few_features", c.too_few_features},
                      {"scale", rate(c.scale)},
                      {"drift_rad_per_m", rate(c.drift_rad_per_m)},
                      {"turn", rate(c.turn)}});
  j["robots"] = robots;
  return j;
}

}  // namespace

ReportJson stats_json(const mapping::ErrorStats& e) {
  return {{"p50", number(e.p50)}, {"p99", number(e.p99)}, {"max", number(e.max)}, {"count", e.count}};
}

ReportJson report_json_value(const EvalReport& r, const std::string& command) {
  ReportJson tracker;
  const ReportJson ransac = options_json(r, tracker);
  ReportJson plane_fits = {{"before", plane_json(r.plane_before)}};
  for (const MethodResult& m : r.methods) plane_fits[m.name] = plane_json(m.plane_after);
  ReportJson methods = ReportJson::array();
  for (const MethodResult& m : r.methods) methods.push_back(method_json(m));
  const Plane& ref = r.floor_reference;
  return {{"scenario", r.scenario},
          {"seed", r.seed},
          {"counts", counts_json(r)},
          {"ransac", ransac},
          {"tracker", tracker},
          {"table1",
           {{"with_ghosts", plane_json(r.table1.with_ghosts)},
            {"without_ghosts", plane_json(r.table1.without_ghosts)},
            {"ghost_share_of_inliers_pct", number(r.table1.ghost_share_of_inliers_pct)},
            {"plane_error_improvement_pct", number(r.table1.error_improvement_pct)},
            {"plane_inlier_improvement_pct", number(r.table1.inlier_improvement_pct)}}},
          {"floor_bias",
           {{"reference",
             {{"a", number(ref.normal.x())},
              {"b", number(ref.normal.y())},
              {"c", number(ref.normal.z())},
              {"d", number(ref.d)}}},
            {"all_points_mm", number(r.floor_bias_before_m * 1e3)},
            {"ghosts_removed_mm", number(r.floor_bias_ghost_free_m * 1e3)},
            {"ghosts_removed_improvement_pct",
             number(floor_bias_improvement_pct(r.floor_bias_before_m, r.floor_bias_ghost_free_m))}}},
          {"methods", methods},
          {"registration", registration_json(r.registration)},
          {"plane_fits", plane_fits},
          {"command", command}};
}

std::string report_json(const EvalReport& r, const std::string& command) {
  return json_report(report_json_value(r, command));
}

std::string report_markdown(const fusion::EvalReport& r, const std::string& command) {
  std::ostringstream o;
  const RansacOptions& rs = r.options.ransac;
  o << "## Data set `" << r.scenario << "` (seed " << r.seed << ")\n\n";
  o << r.points << " points, " << r.ghosts << " ghost points ("
    << md(r.points ? 100.0 * static_cast<double>(r.ghosts) / static_cast<double>(r.points) : 0.0) << " %), " << r.scans
    << " scans, " << r.robots << " robots";
  if (r.orphan_points) o << ", " << r.orphan_points << " points without a scans.csv row";
  o << ".\n\n";
  o << "| method | % ghost | % other | % impr. plane error | % impr. inliers | SA | DA | AA | HA | floor kept | wall "
       "kept | ceiling kept | furniture kept | % impr. floor bias |\n";
  o << "| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |\n";
  for (const MethodResult& m : r.methods) {
    o << "| " << m.name << " | " << md(m.removal.ghost_removed_pct) << " | " << md(m.removal.other_removed_pct) << " | "
      << md(m.plane_error_improvement_pct) << " | " << md(m.plane_inlier_improvement_pct) << " | " << md(m.removal.sa)
      << " | " << md(m.removal.da) << " | " << md(m.removal.aa) << " | " << md(m.removal.ha);
    for (std::size_t c : kSceneClasses) o << " | " << md(m.removal.by_class[c].kept_pct());
    o << " | " << md(m.floor_bias_improvement_pct) << " |\n";
  }
  if (r.registration.have_truth) {
    const RegistrationReport& g = r.registration;
    o << "\n**Registration** (pose error per scan and point error per non-ghost point, against the truth; "
      << (g.by_graph  ? "the scans placed by the pose graph, docs/slam.md"
          : g.enabled ? "scan-to-map registration, docs/registration.md"
                      : "registration off: odometry alone")
      << "):\n\n";
    o << "| poses | translation p50 / p99 / max (cm) | rotation p50 / p99 / max (°) | point error p50 / p99 / max (cm) "
         "|\n";
    o << "| --- | ---: | ---: | ---: |\n";
    auto stats = [&](const ErrorStats& e, double scale, int decimals) {
      return md(e.p50 * scale, decimals) + " / " + md(e.p99 * scale, decimals) + " / " + md(e.max * scale, decimals);
    };
    o << "| odometry | " << stats(g.pose_m_before, 100, 1) << " | " << stats(g.pose_deg_before, 1, 2) << " | "
      << stats(g.point_m_before, 100, 1) << " |\n";
    if (g.enabled || g.by_graph)
      o << (g.by_graph ? "| pose graph | " : "| registered | ") << stats(g.pose_m_after, 100, 1) << " | " << stats(g.pose_deg_after, 1, 2) << " | "
        << stats(g.point_m_after, 100, 1) << " |\n";
  }
  if (r.registration.consistency_before.points > 0) {
    const RegistrationReport& g = r.registration;
    auto c = [&](const RevisitConsistency& k) {
      const double n = k.points ? static_cast<double>(k.points) : 1.0;
      return md(k.median_m * 100, 1) + " / " + md(k.p90_m * 100, 1) + " cm (" +
             md(100.0 * static_cast<double>(k.revisit_points) / n) + " % of the points; within " +
             md(k.on_earlier_m * 100, 0) +
             " cm of the earlier pass: " + md(100.0 * static_cast<double>(k.on_earlier_points) / n) +
             " % of the points)";
    };
    o << "\nRevisit consistency (median / p90 distance of a revisit's points to the earlier pass, ≥ 30 s before, "
         "within 0.5 m; "
         "docs/registration.md): odometry "
      << c(g.consistency_before);
    if (g.enabled || g.by_graph) o << (g.by_graph ? ", pose graph " : ", registered ") << c(g.consistency_after);
    o << ".\n";
  }
  if (r.registration.enabled) {
    // The drift rates at the end (the odometry prior they started from: docs/registration.md "Odometry prior and
    // calibration").
    o << "\n| robot | matches | accepted | degenerate | standing still | first lap | too few features | rejected "
         "overlap / fit / step "
         "| rates at the end: scale % / drift °/m / turn % |\n";
    o << "| ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |\n";
    for (const registration::RobotCorrection& c : r.registration.robots)
      o << "| " << int(c.robot) << " | " << c.matches << " | " << c.accepted << " | " << c.degenerate << " | "
        << c.standing_still << " | " << c.first_lap << " | " << c.too_few_features << " | " << c.rejected_overlap
        << " / " << c.rejected_fit << " / " << c.rejected_step << " | " << md(100.0 * c.scale, 3) << " / "
        << md(rad_to_deg(c.drift_rad_per_m), 4) << " / " << md(100.0 * c.turn, 3) << " |\n";
    o << "\nPoints kept out of the match (onboard-flagged, inside a teammate's tracked body): "
      << r.registration.masked_points << ".\n";
  }
  const Table1& t = r.table1;
  o << "\n**Table 1** (floor plane by RANSAC, ghosts removed by label):\n\n";
  o << "| cloud | signed error (mm) | mean abs (mm) | RMS (mm) | inliers | inlier share % |\n";
  o << "| --- | ---: | ---: | ---: | ---: | ---: |\n";
  auto row = [&](const char* name, const PlaneFit& f) {
    o << "| " << name << " | " << md(f.signed_mean_error_m * 1e3, 3) << " | " << md(f.mean_abs_error_m * 1e3, 3)
      << " | " << md(f.rms_error_m * 1e3, 3) << " | " << f.inliers << " / " << f.points << " | "
      << md(100.0 * f.inlier_share) << " |\n";
  };
  row("all points", t.with_ghosts);
  row("ghosts removed", t.without_ghosts);
  o << "\nGhosts among the inliers with all points: " << md(t.ghost_share_of_inliers_pct)
    << " %; improvement in plane error " << md(t.error_improvement_pct) << " %, in inliers "
    << md(t.inlier_improvement_pct) << " %.\n\n";
  o << "Floor bias (deterministic; signed mean distance of the points within " << number_text(rs.threshold_m)
    << " m of the fixed least-squares floor of the ghost-free cloud): all points " << md(r.floor_bias_before_m * 1e3, 4)
    << " mm, ghosts removed " << md(r.floor_bias_ghost_free_m * 1e3, 4) << " mm (improvement "
    << md(floor_bias_improvement_pct(r.floor_bias_before_m, r.floor_bias_ghost_free_m)) << " %).\n\n";
  o << "Parameters:\n\n";
  for (const MethodResult& m : r.methods) {
    o << "- " << m.name << ":";
    for (const auto& [name, value] : m.params) o << " " << name << "=" << number_text(value);
    o << "\n";
  }
  o << "- RANSAC: threshold " << number_text(rs.threshold_m) << " m, " << rs.iterations << " iterations, seed "
    << rs.seed << ", normal within " << number_text(rs.max_tilt_deg) << "° of +z, plane height ≤ "
    << number_text(rs.max_height_m) << " m, signed error against the "
    << (rs.error_reference == PlaneErrorReference::sample ? "best sample" : "refit") << " plane\n";
  const TrackerOptions& tr = r.options.tracker;
  o << "- tracker: constant velocity, σ_a " << number_text(tr.accel_noise_mps2) << " m/s², σ_pos "
    << number_text(tr.position_noise_m) << " m, σ_vel " << number_text(tr.velocity_noise_mps) << " m/s, velocity "
    << (tr.use_velocity ? "measured" : "not measured") << ", drift " << number_text(tr.drift_m_per_m) << " m/m, "
    << number_text(tr.drift_heading_rad_per_m) << " rad/m, " << number_text(tr.drift_heading_rad_per_rad)
    << " rad/rad\n\n";
  o << "Reproduce: `" << command << "`\n";
  return o.str();
}

}  // namespace teamscan::demo
