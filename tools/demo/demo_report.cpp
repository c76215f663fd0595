// `teamscan demo`'s last stages (demo_run.hpp): collect what the run left (the live session as a
// labelled data set, the offline reference), score it (delivery, the station's model against the truth
// and against `teamscan eval` of its session, the registration, latency, faults), and report: every
// figure in report.md and summary.json, a short summary on stdout.
#include <signal.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdarg>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <vector>

#include "common/dataset/dataset.hpp"
#include "common/dataset/pcd.hpp"
#include "groundstation/fusion/evaluation.hpp"
#include "groundstation/station/config.hpp"
#include "sim/simulator.hpp"
#include "tools/demo/demo_run.hpp"
#include "tools/demo/eval_report.hpp"
#include "tools/demo/report_json.hpp"
#include "tools/demo/scoring.hpp"
#include "tools/demo/summary.hpp"
#include "tools/render/render.hpp"

namespace teamscan::demo {
namespace {

namespace fs = std::filesystem;

// printf into a std::string.
[[gnu::format(printf, 1, 2)]] std::string strf(const char* f, ...) {
  va_list args;
  va_start(args, f);
  char b[1024];
  std::vsnprintf(b, sizeof b, f, args);
  va_end(args);
  return b;
}

bool write_text(const std::string& path, const std::string& text) {
  std::ofstream o(path, std::ios::trunc);
  o << text;
  return static_cast<bool>(o);
}

// "p50 / p99 / max" of an error statistic, scaled.
std::string stats_text(const mapping::ErrorStats& e, double scale, const char* f) {
  return strf(f, e.p50 * scale) + " / " + strf(f, e.p99 * scale) + " / " + strf(f, e.max * scale);
}

ReportJson stats_json(const mapping::ErrorStats& e) {
  return {{"p50", e.p50}, {"p99", e.p99}, {"max", e.max}, {"count", e.count}};
}

bool map_based(const std::string& method) {
  return method == "frequency" || method == "visibility" || method == "combined";
}

// What the run left, read back and evaluated: the live session as a labelled data set and the offline
// simulation of the same scenario, both through `teamscan eval`'s evaluation.
struct Collected {
  LiveDataset live;
  sim::SimOutput offline;
  fusion::EvalReport offline_report, live_report;
};

// The scores and texts the report stage writes; `json` is summary.json.
struct DemoScore {
  ReportJson json = ReportJson::object();
  std::string delivery, station, compare, faults, resources;  // report.md sections
  bool none_lost = true, agree = true, clean = true;
  StationScore station_model;
  const fusion::MethodResult* station_offline = nullptr;
  bool identity = false;      // the identity the verdict requires (session eval, or the replay with the registration)
  std::string identity_what;  // which one
  std::uint64_t published = 0, stored = 0, missing = 0, poses_missing = 0;
  std::vector<ShadowReport> shadows;  // --shadow (link_faults.hpp)
  std::vector<double> fused_latency_ms;  // scan -> fused map in the run window, sorted
  LiveRegistrationScore registration;
  std::size_t graph_closures = 0;  // the replay's pose graph (the station's, to the byte)
};

// Every beam the ray caster put on a teammate: for checking the labels of the live map.
void write_ghost_beams(const DemoSetup& s, sim::LiveTeam& live, const RunRecord& r) {
  std::ofstream g(s.out + "/truth-ghost-beams.csv");
  g << "robot,world_time_s,beam,tx_m,ty_m,tz_m,hit_robot\n";
  for (std::size_t i = 0; i < live.robot_count(); ++i)
    for (const sim::LiveScanTruth& t : r.truths[i])
      for (std::size_t k = 0; k < t.beams.size(); ++k)
        if (t.beams[k].label == PointClass::robot)
          g << unsigned(live.spec(i).id) << ',' << live.world_time_of(t.sweep_end_realtime_ns) << ',' << k << ','
            << t.beams[k].tx << ',' << t.beams[k].ty << ',' << t.beams[k].tz << ',' << unsigned(t.beams[k].hit_robot)
            << '\n';
}

// Collect: the live session, the offline reference, both evaluated; 0, or the exit code (2: bad --method).
int collect(const DemoOptions& a, const DemoSetup& s, sim::LiveTeam& live, Progress& progress, const RunRecord& r,
            Collected& c) {
  progress.stage("teamscan demo: offline simulation of the same scenario for the reference...");
  sim::SimOptions so;
  so.seed = a.seed;
  so.duration_s = s.duration_s;
  so.device_streams = false;
  c.offline = sim::simulate(s.scenario, so);
  write_ghost_beams(s, live, r);
  c.live = build_live_dataset(s.session, live, r.truths, s.scenario, c.offline.dataset, s.duration_s);
  if (!c.live.session_error.empty())
    progress.event("teamscan demo: session " + s.session + ": " + c.live.session_error);

  auto methods = fusion::parse_methods(a.methods, std::nullopt, std::nullopt, {});
  if (!methods) {
    std::fprintf(stderr, "teamscan demo: --method %s: %s\n", a.methods.c_str(), methods.error().what);
    return 2;
  }
  fusion::EvalOptions eo;
  eo.methods = methods.value();
  // With the station's registration on, the offline and live evaluations run with it too
  // (`teamscan eval --registration`): the station's corrected model is compared with corrected evals.
  eo.registration = s.registration;
  eo.registration_options.prior = s.priors.prior;
  eo.registration_options.robot_priors = s.priors.robot_priors;
  // With the station's pose graph (its config decides), its final model is on the graph's poses: both
  // evaluations place their clouds with a graph of the station's options (`teamscan eval`'s default).
  {
    station::GroundStationConfig gcfg;
    station::ConfigError error;
    if (!station::load_groundstation_config(s.station_config, gcfg, error)) {
      std::fprintf(stderr, "teamscan demo: %s: %s\n", s.station_config.c_str(), error.message.c_str());
      return 1;
    }
    eo.pose_graph = gcfg.fusion.pose_graph;
  }
  // The station's own method is always evaluated offline too, so its live model has its comparison.
  if (std::none_of(eo.methods.begin(), eo.methods.end(),
                   [&](const fusion::MethodSpec& m) { return m.method == a.station_method; })) {
    if (auto extra = fusion::parse_methods(a.station_method, std::nullopt, std::nullopt, {})) {
      const std::vector<fusion::MethodSpec> specs = extra.value();
      eo.methods.insert(eo.methods.end(), specs.begin(), specs.end());
    }
  }
  progress.stage(
      strf("teamscan demo: evaluating the live map (%zu points, %zu scans) and the offline one (%zu points)...",
           c.live.ds.points.size(), c.live.ds.scans.size(), c.offline.dataset.points.size()));
  Result<fusion::EvalReport> offline_evaluated = fusion::evaluate(c.offline.dataset, eo);
  // The live map also with the robots' own direction-filter flags (what the onboard removed live).
  fusion::EvalOptions live_eo = eo;
  mapping::MethodOptions flags_opt;
  flags_opt.direction.source = mapping::DirectionSource::flags;
  live_eo.methods.push_back({"direction-onboard-flags", "direction", flags_opt});
  Result<fusion::EvalReport> live_evaluated = fusion::evaluate(c.live.ds, live_eo);
  if (!offline_evaluated || !live_evaluated) {
    std::fprintf(stderr, "teamscan demo: evaluation: %s\n",
                 (!offline_evaluated ? offline_evaluated : live_evaluated).error().what);
    return 1;
  }
  c.offline_report = std::move(offline_evaluated.value());
  c.live_report = std::move(live_evaluated.value());
  return 0;
}

// Post-run `teamscan eval` of the live session against offline, method by method.
void score_live_vs_offline(const DemoOptions& a, const Collected& c, DemoScore& sc) {
  std::string t =
      "| method | live DA % | offline DA % | ΔDA | live SA % | offline SA % | ΔSA | live AA | offline AA |\n"
      "| --- | --- | --- | --- | --- | --- | --- | --- | --- |\n";
  ReportJson rows = ReportJson::array();
  for (const fusion::MethodResult& lm : c.live_report.methods) {
    const fusion::MethodResult* om = nullptr;
    for (const fusion::MethodResult& m : c.offline_report.methods)
      if (m.name == lm.name) om = &m;
    if (!om) {
      t += strf("| %s | %.1f | – | – | %.2f | – | – | %.1f | – |\n", lm.name.c_str(), lm.removal.da, lm.removal.sa,
                lm.removal.aa);
      rows.push_back(
          {{"name", lm.name}, {"live_da", lm.removal.da}, {"live_sa", lm.removal.sa}, {"live_aa", lm.removal.aa}});
      continue;
    }
    const double dda = lm.removal.da - om->removal.da, dsa = lm.removal.sa - om->removal.sa;
    const bool mb = map_based(lm.method);
    const bool ok = std::fabs(dda) <= (mb ? a.tolerance_map_da_pct : a.tolerance_da_pct) &&
                    std::fabs(dsa) <= (mb ? a.tolerance_map_sa_pct : a.tolerance_sa_pct);
    sc.agree = sc.agree && ok;
    t += strf("| %s | %.1f | %.1f | %+.1f | %.2f | %.2f | %+.2f | %.1f | %.1f |%s\n", lm.name.c_str(), lm.removal.da,
              om->removal.da, dda, lm.removal.sa, om->removal.sa, dsa, lm.removal.aa, om->removal.aa,
              ok ? "" : " outside tolerance");
    rows.push_back({{"name", lm.name},
                    {"live_da", lm.removal.da},
                    {"offline_da", om->removal.da},
                    {"live_sa", lm.removal.sa},
                    {"offline_sa", om->removal.sa},
                    {"live_aa", lm.removal.aa},
                    {"offline_aa", om->removal.aa},
                    {"within_tolerance", ok}});
  }
  sc.compare = t;
  sc.json["methods"] = rows;
}

// The ground station's own live model, scored against the truth, next to the offline `teamscan eval`
// of the same method.
bool score_station(const DemoOptions& a, const DemoSetup& s, const Collected& c, DemoScore& sc) {
  const StationScore st = score_station_model(s.session + "/fused_all.pcd", c.live.ds.points, c.live.point_seq);
  sc.station_model = st;
  for (const fusion::MethodResult& m : c.offline_report.methods)
    if (m.method == a.station_method && !sc.station_offline) sc.station_offline = &m;
  const fusion::MethodResult* off = sc.station_offline;
  const double tol_da = map_based(a.station_method) ? a.tolerance_map_da_pct : a.tolerance_da_pct;
  const double tol_sa = map_based(a.station_method) ? a.tolerance_map_sa_pct : a.tolerance_sa_pct;
  const double off_da = off ? off->removal.da : 0.0, off_sa = off ? off->removal.sa : 0.0;
  bool agree = false;
  if (!st.present) {
    sc.station += "  the ground station wrote no usable fused_all.pcd (" + st.error + ")\n";
  } else {
    // Not evaluated offline (--method without it): reported, not compared.
    agree = off == nullptr || (std::fabs(st.model.da - off_da) <= tol_da && std::fabs(st.model.sa - off_sa) <= tol_sa);
    sc.station += strf(
        "  station model (%s, session/fused_all.pcd `keep`): DA %.1f %%, SA %.2f %%, AA %.1f  |  offline `teamscan "
        "eval` "
        "%s: DA %.1f %%, SA %.2f %%  |  ΔDA %+.1f, ΔSA %+.2f (tolerance %.0f / %.0f points): %s\n",
        a.station_method.c_str(), st.model.da, st.model.sa, st.model.aa,
        off ? off->name.c_str() : "(method not evaluated offline)", off_da, off_sa, st.model.da - off_da,
        st.model.sa - off_sa, tol_da, tol_sa,
        !off    ? "not compared"
        : agree ? "agree"
                : "OUTSIDE");
    sc.station +=
        strf("  station live decisions at arrival (`live_keep`): DA %.1f %%, SA %.2f %%\n", st.live.da, st.live.sa);
    sc.station += strf(
        "  %llu of %zu labelled live points found in the station's model (%llu not; the model has %llu points incl. "
        "bring-up)\n",
        static_cast<unsigned long long>(st.matched), c.live.ds.points.size(),
        static_cast<unsigned long long>(st.unmatched), static_cast<unsigned long long>(st.model_points));
  }
  sc.json["station_model"] = {
      {"present", st.present},  {"method", a.station_method}, {"da", st.model.da},
      {"sa", st.model.sa},      {"aa", st.model.aa},          {"live_da", st.live.da},
      {"live_sa", st.live.sa},  {"offline_da", off_da},       {"offline_sa", off_sa},
      {"tolerance_da", tol_da}, {"tolerance_sa", tol_sa},     {"within_tolerance", agree},
      {"matched", st.matched},  {"unmatched", st.unmatched},  {"model_points", st.model_points}};
  return agree;
}

// The station's models against `teamscan eval` of its own session (the fusion core fed the session
// read back, in time order): the same decision for every point (docs/groundstation.md "The fusion
// core"), for its method and for each of its [fusion] compare_methods.
bool score_session_eval(const DemoSetup& s, const Collected& c, DemoScore& sc) {
  bool agree = true;
  ReportJson by_method = ReportJson::array();
  for (const SessionEvalCheck& e :
       check_station_models_against_session_eval(s.session, s.station_config, c.live.ds.points, c.live.point_seq)) {
    agree = agree && e.identical;
    if (!e.error.empty()) {
      sc.station += "  station model (" + e.method + ") vs `teamscan eval SESSION`: " + e.error + "\n";
      continue;
    }
    sc.station += strf(
        "  station model vs `teamscan eval SESSION` (%s, the same core on the session read back): %llu of %llu session "
        "points in the model (%llu beyond the per-voxel cap), %llu decisions differ: %s\n",
        e.method.c_str(), static_cast<unsigned long long>(e.compared),
        static_cast<unsigned long long>(e.compared + e.not_in_model), static_cast<unsigned long long>(e.not_in_model),
        static_cast<unsigned long long>(e.mismatches), e.identical ? "identical" : "DIFFERENT");
    sc.station += strf(
        "    labelled (%zu points): station DA %.2f %%, SA %.3f %% | eval DA %.2f %%, SA %.3f %% | ΔDA %+.2f, ΔSA "
        "%+.3f; "
        "decisions at release (`live_keep`): DA %.2f %%, SA %.3f %%\n",
        e.labelled, e.station.da, e.station.sa, e.eval.da, e.eval.sa, e.station.da - e.eval.da,
        e.station.sa - e.eval.sa, e.live.da, e.live.sa);
    const ReportJson obj = {{"method", e.method},         {"compared", e.compared}, {"not_in_model", e.not_in_model},
                            {"mismatches", e.mismatches}, {"labelled", e.labelled}, {"station_da", e.station.da},
                            {"station_sa", e.station.sa}, {"eval_da", e.eval.da},   {"eval_sa", e.eval.sa},
                            {"live_da", e.live.da},       {"live_sa", e.live.sa},   {"identical", e.identical}};
    if (e.primary) sc.json["station_vs_session_eval"] = obj;
    by_method.push_back(obj);
  }
  sc.json["station_vs_session_eval_by_method"] = by_method;
  return agree;
}

// The station's models against its own core replaying its session in arrival order: with the
// registration on, the identity the verdict requires (the registration's corrections follow the
// release order, live the arrival order; docs/demo.md "Registration").
bool score_replay(const SessionReplay& replay, DemoScore& sc) {
  bool agree = replay.error.empty() && !replay.models.empty();
  if (!replay.error.empty())
    sc.station +=
        "  station models vs the station's core replaying its session in arrival order: " + replay.error + "\n";
  ReportJson by = ReportJson::array();
  for (const ReplayModelCheck& m : replay.models) {
    agree = agree && m.identical;
    if (!m.error.empty()) {
      sc.station += "  station model (" + m.method + ") vs the replay in arrival order: " + m.error + "\n";
    } else {
      sc.station += strf(
          "  station model vs its core replaying the session in arrival order (%s): %llu of %llu rows compared (replay "
          "%llu), %llu decisions and %llu positions (> 1 mm, largest %.1f mm) differ: %s\n",
          m.method.c_str(), static_cast<unsigned long long>(m.compared),
          static_cast<unsigned long long>(m.model_points), static_cast<unsigned long long>(m.replay_points),
          static_cast<unsigned long long>(m.decisions_differ), static_cast<unsigned long long>(m.placed_differ),
          m.placed_differ_max_m * 1e3, m.identical ? "identical" : "DIFFERENT");
    }
    by.push_back({{"method", m.method},
                  {"error", m.error},
                  {"model_points", m.model_points},
                  {"replay_points", m.replay_points},
                  {"compared", m.compared},
                  {"decisions_differ", m.decisions_differ},
                  {"placed_differ", m.placed_differ},
                  {"placed_differ_max_m", m.placed_differ_max_m},
                  {"identical", m.identical}});
  }
  sc.json["station_vs_session_replay_by_method"] = by;
  return agree;
}

// The registration live: pose and point error against the truth with the odometry alone and as the
// station corrected them (docs/demo.md "Registration").
void score_registration(const DemoSetup& s, const Collected& c, const SessionReplay& replay, DemoScore& sc) {
  const LiveRegistrationScore reg = score_live_registration(s.session, s.station_config, replay, c.live);
  sc.registration = reg;
  const mapping::RegistrationReport& off = c.offline_report.registration;
  std::string& t = sc.station;
  t += strf(
      "  registration %s; pose error per scan (%llu scans of the run window) and point error per non-ghost point "
      "(%llu) "
      "against the truth:\n",
      s.registration_why.c_str(), static_cast<unsigned long long>(reg.scans),
      static_cast<unsigned long long>(reg.points));
  if (!reg.error.empty()) t += "    not measured: " + reg.error + "\n";
  t += "    odometry alone:                translation p50 / p99 / max " +
       stats_text(reg.pose_m_odometry, 100, "%.1f") + " cm, rotation " + stats_text(reg.pose_deg_odometry, 1, "%.2f") +
       " deg, point error " + stats_text(reg.point_m_odometry, 100, "%.1f") + " cm\n";
  if (reg.enabled) {
    t += "    the station's corrected model: translation p50 / p99 / max " +
         stats_text(reg.pose_m_corrected, 100, "%.1f") + " cm, rotation " +
         stats_text(reg.pose_deg_corrected, 1, "%.2f") + " deg, point error " +
         stats_text(reg.point_m_corrected, 100, "%.1f") + " cm\n";
    // The offline evaluation's "after" poses: the pose graph's when it placed the scans (the default).
    if (off.enabled && off.have_truth)
      t += std::string(off.by_graph ? "    offline `teamscan eval --registration` of the same scenario, placed by the pose graph: translation "
                                    : "    offline `teamscan eval --registration --no-pose-graph` of the same scenario: translation ") +
           stats_text(off.pose_m_after, 100, "%.1f") + " cm, rotation " + stats_text(off.pose_deg_after, 1, "%.2f") +
           " deg, point error " + stats_text(off.point_m_after, 100, "%.1f") + " cm (odometry alone: translation p99 " +
           strf("%.1f", off.pose_m_before.p99 * 100) + " cm, rotation p99 " + strf("%.2f", off.pose_deg_before.p99) +
           " deg)\n";
    t += "    matches:";
    for (const registration::RobotCorrection& rc : replay.robots)
      t += strf(" robot%u %llu accepted of %llu (%llu too few features, %llu degenerate, %llu rejected);",
                unsigned(rc.robot), static_cast<unsigned long long>(rc.accepted),
                static_cast<unsigned long long>(rc.matches), static_cast<unsigned long long>(rc.too_few_features),
                static_cast<unsigned long long>(rc.degenerate),
                static_cast<unsigned long long>(rc.rejected_overlap + rc.rejected_fit + rc.rejected_step));
    t += strf(" %llu session points moved by the corrections (up to %.1f cm)\n",
              static_cast<unsigned long long>(reg.points_moved), reg.points_moved_max_m * 100);
  }
  // The pose graph as the station's back end: its poses against the truth, and its files against the
  // replay's graph (the agreement requires them to be the same to the byte).
  if (reg.graph) {
    const posegraph::SlamStats& g = replay.graph_stats;
    sc.graph_closures = g.closures;
    t += "    the station's pose graph:      translation p50 / p99 / max " + stats_text(reg.pose_m_graph, 100, "%.1f") +
         " cm, rotation " + stats_text(reg.pose_deg_graph, 1, "%.2f") +
         strf(" deg (%zu nodes, %zu submaps, %zu loop closures); robot<N>.graph.tum %s the replay's graph (%zu files)\n",
              g.nodes, g.submaps, g.closures,
              reg.graph_files > 0 && reg.graph_files_differ == 0 ? "identical to" : "DIFFER from", reg.graph_files);
    if (!reg.graph_error.empty()) t += "    pose graph: " + reg.graph_error + "\n";
    sc.agree = sc.agree && reg.graph_files > 0 && reg.graph_files_differ == 0;
  }
  ReportJson robots = ReportJson::array();
  for (const registration::RobotCorrection& rc : replay.robots)
    robots.push_back({{"robot", rc.robot},
                      {"matches", rc.matches},
                      {"accepted", rc.accepted},
                      {"degenerate", rc.degenerate},
                      {"too_few_features", rc.too_few_features}});
  sc.json["registration"] = {{"enabled", reg.enabled},
                             {"why", s.registration_why},
                             {"error", reg.error},
                             {"scans", reg.scans},
                             {"points", reg.points},
                             {"pose_m_odometry", stats_json(reg.pose_m_odometry)},
                             {"pose_deg_odometry", stats_json(reg.pose_deg_odometry)},
                             {"point_m_odometry", stats_json(reg.point_m_odometry)},
                             {"pose_m_corrected", stats_json(reg.pose_m_corrected)},
                             {"pose_deg_corrected", stats_json(reg.pose_deg_corrected)},
                             {"point_m_corrected", stats_json(reg.point_m_corrected)},
                             {"points_moved", reg.points_moved},
                             {"points_moved_max_m", reg.points_moved_max_m},
                             {"offline_pose_m_registered", stats_json(off.pose_m_after)},
                             {"offline_pose_deg_registered", stats_json(off.pose_deg_after)},
                             {"offline_point_m_registered", stats_json(off.point_m_after)},
                             {"robots", robots}};
  if (reg.graph)
    sc.json["pose_graph"] = {{"pose_m", stats_json(reg.pose_m_graph)},
                             {"pose_deg", stats_json(reg.pose_deg_graph)},
                             {"nodes", replay.graph_stats.nodes},
                             {"submaps", replay.graph_stats.submaps},
                             {"closures", replay.graph_stats.closures},
                             {"files", reg.graph_files},
                             {"files_differ", reg.graph_files_differ},
                             {"error", reg.graph_error}};
}

// The corrections back on the robots: what each daemon took from teamscan/team and applied to the
// scans it published, and the pose error of those scans as the robot placed them.
void score_corrections(const DemoSetup& s, const Collected& c, DemoScore& sc) {
  const RobotCorrections rc = score_robot_corrections(s.session, c.live);
  if (!rc.error.empty()) sc.station += "  corrections on the robots: not measured: " + rc.error + "\n";
  ReportJson robots = ReportJson::array();
  for (const RobotCorrectionScore& r : rc.robots) {
    sc.station += strf(
        "  robot%u applied %llu corrections from teamscan/team (refused %llu); %llu of %llu stored scans carry one "
        "(%llu "
        "distinct, the last (%d mm, %d mm, %.3f deg) #%u)",
        unsigned(r.robot), static_cast<unsigned long long>(r.corrections_applied),
        static_cast<unsigned long long>(r.corrections_rejected), static_cast<unsigned long long>(r.scans_corrected),
        static_cast<unsigned long long>(r.scans), static_cast<unsigned long long>(r.corrections_carried),
        static_cast<int>(r.last.x_mm), static_cast<int>(r.last.y_mm), r.last.yaw_urad * 1e-6 * kRadToDeg,
        static_cast<unsigned>(r.last.seq));
    if (r.pose_m_robot.count > 0)
      sc.station += strf("; pose error of the %llu run-window scans carrying one: as the robot placed them ",
                         static_cast<unsigned long long>(r.pose_m_robot.count)) +
                    stats_text(r.pose_m_robot, 100, "%.1f") + " cm, " + stats_text(r.pose_deg_robot, 1, "%.2f") +
                    " deg; odometry alone " + stats_text(r.pose_m_odometry, 100, "%.1f") + " cm, " +
                    stats_text(r.pose_deg_odometry, 1, "%.2f") + " deg";
    sc.station += "\n";
    robots.push_back({{"robot", r.robot},
                      {"corrections_applied", r.corrections_applied},
                      {"corrections_rejected", r.corrections_rejected},
                      {"scans", r.scans},
                      {"scans_corrected", r.scans_corrected},
                      {"corrections_carried", r.corrections_carried},
                      {"last_x_mm", r.last.x_mm},
                      {"last_y_mm", r.last.y_mm},
                      {"last_yaw_urad", r.last.yaw_urad},
                      {"last_seq", r.last.seq},
                      {"pose_m_robot", stats_json(r.pose_m_robot)},
                      {"pose_deg_robot", stats_json(r.pose_deg_robot)},
                      {"pose_m_odometry", stats_json(r.pose_m_odometry)},
                      {"pose_deg_odometry", stats_json(r.pose_deg_odometry)}});
  }
  sc.json["robot_corrections"] = {{"error", rc.error}, {"robots", robots}};
}

// Delivery: every scan a robot published reached the session.
void score_delivery(const Collected& c, DemoScore& sc) {
  ReportJson robots = ReportJson::array();
  for (const RobotDelivery& d : c.live.delivery) {
    const bool lost = d.gaps > 0 || d.stored == 0 || d.seq_last < d.last_status_published || d.pose_gaps > 0 || d.poses == 0;
    sc.none_lost = sc.none_lost && !lost;
    sc.published += d.last_status_published;
    sc.stored += d.stored;
    sc.missing += d.gaps;
    sc.poses_missing += d.pose_gaps;
    sc.delivery += strf(
        "  robot%u: %llu scans stored (seq %u..%u), %llu missing, %llu duplicates; robot's last status says %u "
        "published; "
        "%llu in the run window: %llu matched to the ray caster's truth, %llu not; the emulated LMS sent %llu (%llu "
        "beams on a teammate in the window); %llu poses stored (seq %u..%u), %llu missing, %llu duplicates\n",
        unsigned(d.id), static_cast<unsigned long long>(d.stored), d.seq_first, d.seq_last,
        static_cast<unsigned long long>(d.gaps), static_cast<unsigned long long>(d.duplicates), d.last_status_published,
        static_cast<unsigned long long>(d.in_window), static_cast<unsigned long long>(d.truth_matched),
        static_cast<unsigned long long>(d.truth_unmatched), static_cast<unsigned long long>(d.measured),
        static_cast<unsigned long long>(d.truth_ghost_beams), static_cast<unsigned long long>(d.poses),
        d.pose_seq_first, d.pose_seq_last, static_cast<unsigned long long>(d.pose_gaps),
        static_cast<unsigned long long>(d.pose_duplicates));
    robots.push_back({{"id", d.id},
                      {"stored", d.stored},
                      {"seq_first", d.seq_first},
                      {"seq_last", d.seq_last},
                      {"missing", d.gaps},
                      {"duplicates", d.duplicates},
                      {"refused", d.refused},
                      {"last_status_published", d.last_status_published},
                      {"in_window", d.in_window},
                      {"truth_matched", d.truth_matched},
                      {"truth_unmatched", d.truth_unmatched},
                      {"lms_sent", d.measured},
                      {"poses", d.poses},
                      {"pose_seq_first", d.pose_seq_first},
                      {"pose_seq_last", d.pose_seq_last},
                      {"poses_missing", d.pose_gaps},
                      {"pose_duplicates", d.pose_duplicates}});
  }
  sc.json["robots"] = robots;
}

// Fault analysis from the session (status.csv, events.log, scans.bin).
void score_faults(const DemoOptions& a, const DemoSetup& s, sim::LiveTeam& live, const RunRecord& r, DemoScore& sc) {
  for (const std::string& f : r.faults) sc.faults += "  " + f + "\n";
  if (!s.shadows.empty()) {  // --shadow: what the robots' statuses said (link_faults.hpp)
    Result<std::vector<StatusRow>> status = read_status_csv(s.session + "/status.csv");
    if (!status) sc.faults += "  " + s.session + "/status.csv: " + status.error().what + "\n";
    ReportJson shadows = ReportJson::array();
    const auto world_ns = [&](double t_s) { return live.t0_realtime_ns() + static_cast<std::int64_t>(t_s / a.speed * 1e9); };
    for (const LinkShadow& sh : s.shadows) {
      sc.shadows.push_back(shadow_report(status ? status.value() : std::vector<StatusRow>{}, sh, world_ns(sh.at_s),
                                         world_ns(sh.at_s + sh.for_s)));
      sc.faults += "  " + shadow_text(sc.shadows.back()) + "\n";
      shadows.push_back(shadow_json(sc.shadows.back()));
    }
    sc.json["link_faults"] = {{"loss_permille", s.loss_permille}, {"shadows", shadows}};
  }
  if (a.unplug_robot) {
    Result<std::vector<StatusRow>> status = read_status_csv(s.session + "/status.csv");
    if (!status) sc.faults += "  " + s.session + "/status.csv: " + status.error().what + "\n";
    const UnplugReport u =
        unplug_report(status ? status.value() : std::vector<StatusRow>{}, static_cast<std::uint32_t>(*a.unplug_robot));
    sc.faults += strf("  robot%d laser unplugged: lms_state sequence in status.csv:", *a.unplug_robot);
    for (unsigned st : u.lms_states) sc.faults += strf(" %u", st);
    sc.faults += strf("; lms reopens %u\n", u.lms_reopens);
    sc.json["unplug"] = {{"robot", *a.unplug_robot}, {"lms_states", u.lms_states}, {"lms_reopens", u.lms_reopens}};
  }
  if (a.kill_robot) {
    const std::int64_t kill_rt = live.t0_realtime_ns() + static_cast<std::int64_t>(a.kill_robot_at_s / a.speed * 1e9);
    const KillReport k = kill_report(s.session, static_cast<std::uint32_t>(*a.kill_robot), kill_rt);
    sc.faults += strf(
        "  robot%d daemon killed: station marked it lost after %.2f s; the others' scans from 1 s after: %llu, "
        "team-stale "
        "points %llu (before: %llu), direction-filtered points %llu\n",
        *a.kill_robot, k.lost_after_s, static_cast<unsigned long long>(k.others_scans_after),
        static_cast<unsigned long long>(k.team_stale_after), static_cast<unsigned long long>(k.team_stale_before),
        static_cast<unsigned long long>(k.direction_filtered_after));
    sc.json["kill_robot"] = {{"robot", *a.kill_robot},
                             {"lost_after_s", k.lost_after_s},
                             {"others_scans_after", k.others_scans_after},
                             {"others_team_stale_points_before", k.team_stale_before},
                             {"others_team_stale_points_after", k.team_stale_after},
                             {"others_direction_filtered_points_after", k.direction_filtered_after}};
  }
}

// Every process exited cleanly (a process killed by a fault with SIGKILL).
void score_processes(const DemoOptions& a, const RunRecord& r, DemoScore& sc) {
  ReportJson processes = ReportJson::array();
  for (std::size_t ci = 0; ci < r.children.size(); ++ci) {
    const Child& c = r.children[ci];
    const bool killed_by_fault =
        (r.killed_child != 0 && ci == r.killed_child) ||
        (c.name == "teamscan-groundstation" && a.kill_station_at_s && ci >= 1 + r.robot_children);
    sc.clean = sc.clean && (c.exit_code == 0 || (killed_by_fault && c.exit_code == 128 + SIGKILL));
    processes.push_back({{"name", c.name}, {"exit", c.exit_code}, {"cpu_s", c.cpu_s}, {"log", c.log}});
  }
  sc.json["processes"] = processes;
}

// Scan -> stored and scan -> fused map latency, point accuracy, CPU: the run's resources.
void score_resources(const DemoOptions& a, const DemoSetup& s, sim::LiveTeam& live, const RunRecord& r,
                     const Collected& c, DemoScore& sc) {
  std::vector<double> lat = c.live.latency_ms;  // the station stores before any mapping hook
  std::sort(lat.begin(), lat.end());
  double station_cpu_s = 0, onboard_cpu_s = 0, station_run_cpu_s = 0;
  for (const Child& ch : r.children) {
    if (ch.name.rfind("teamscan-groundstation", 0) == 0) {
      station_cpu_s += ch.cpu_s;
      station_run_cpu_s += ch.run_cpu_s;
    }
    if (ch.name.rfind("teamscan-onboard", 0) == 0) onboard_cpu_s += ch.run_cpu_s;
  }
  std::uint64_t sent = 0;
  for (std::size_t i = 0; i < live.robot_count(); ++i) sent += live.scans_measured(i);
  // Scan -> fused map, as the station measured it (session/latency.csv, last station process).
  const std::vector<LatencySummary> station_lat = read_latency_csv(s.session + "/latency.csv");
  const LatencySummary fused = station_lat.size() >= 2 ? station_lat[1] : LatencySummary{};
  sc.fused_latency_ms =
      read_fused_latency_log(s.session + "/fused_latency.csv", live.t0_realtime_ns(),
                             live.t0_realtime_ns() + static_cast<std::int64_t>(s.duration_s / a.speed * 1e9));
  const std::vector<double>& win = sc.fused_latency_ms;
  // Point accuracy: every live point with a true hit against the ray caster's hit point (mm): the range
  // noise, the odometry's drift, the stamp and the odometry interpolation (max_hold_s).
  std::vector<double> err = c.live.point_error_mm;
  std::sort(err.begin(), err.end());
  auto last = [](const std::vector<double>& v) { return v.empty() ? 0.0 : v.back(); };
  std::string& t = sc.resources;
  t += strf(
      "  CPU over the run (%.1f s): ground station %.2f s (%.0f %% of a core; %.2f s with its final model write), "
      "onboard daemons "
      "%.2f s together, device feeder (this process) %.2f s (ray casting %.2f s)\n",
      r.run_wall_s, station_run_cpu_s, 100.0 * station_run_cpu_s / r.run_wall_s, station_cpu_s, onboard_cpu_s,
      r.feeder_cpu_s, r.cast_cpu_s);
  t += strf("  scans from the precast table: %llu of %llu sent (casting ahead took %.2f s CPU before the run)\n",
            static_cast<unsigned long long>(live.scans_from_precast()), static_cast<unsigned long long>(sent),
            r.precast_cpu_s);
  t += strf("  scan -> stored latency in the run window: p50 %.1f ms, p99 %.1f ms, max %.1f ms over %zu scans\n",
            sorted_pct(lat, 0.5), sorted_pct(lat, 0.99), last(lat), lat.size());
  t += strf(
      "  scan -> fused map latency in the run window: p50 %.1f ms, p99 %.1f ms, max %.1f ms over %zu scans "
      "(session/fused_latency.csv)\n",
      sorted_pct(win, 0.5), sorted_pct(win, 0.99), last(win), win.size());
  if (fused.present)
    t += strf(
        "  scan -> fused map latency, every scan incl. bring-up and shutdown (the station's histogram): p50 %.1f ms, "
        "p90 %.1f ms, "
        "p99 %.1f ms, max %.1f ms over %.0f scans\n",
        fused.p50_ms, fused.p90_ms, fused.p99_ms, fused.max_ms, fused.count);
  else
    t += "  scan -> fused map latency: the station wrote no " + s.session + "/latency.csv\n";
  t += strf("  point error vs truth: p50 %.1f mm, p99 %.1f mm, max %.1f mm over %zu points (onboard max_hold_s %s)\n",
            sorted_pct(err, 0.5), sorted_pct(err, 0.99), last(err), err.size(),
            a.max_hold_s ? strf("%.3f", *a.max_hold_s).c_str() : "default");
  ReportJson& j = sc.json;
  j["latency_ms_p50"] = sorted_pct(lat, 0.5);
  j["latency_ms_p99"] = sorted_pct(lat, 0.99);
  j["latency_ms_max"] = last(lat);
  j["fused_latency_present"] = fused.present;
  j["fused_latency_scans"] = fused.count;
  j["fused_latency_ms_p50"] = sorted_pct(win, 0.5);
  j["fused_latency_ms_p99"] = sorted_pct(win, 0.99);
  j["fused_latency_ms_max"] = last(win);
  j["fused_latency_window_scans"] = win.size();
  j["station_hist_fused_ms_p50"] = fused.p50_ms;
  j["station_hist_fused_ms_p99"] = fused.p99_ms;
  j["station_hist_fused_ms_max"] = fused.max_ms;
  j["point_error_mm_p50"] = sorted_pct(err, 0.5);
  j["point_error_mm_p99"] = sorted_pct(err, 0.99);
  j["point_error_mm_max"] = last(err);
  j["max_hold_s"] = a.max_hold_s ? *a.max_hold_s : -1.0;
  j["station_cpu_s"] = station_cpu_s;
  j["station_run_cpu_s"] = station_run_cpu_s;
  j["feeder_cpu_s"] = r.feeder_cpu_s;
  j["cast_cpu_s"] = r.cast_cpu_s;
  j["precast_cpu_s"] = r.precast_cpu_s;
  j["scans_from_precast"] = live.scans_from_precast();
  j["onboard_cpu_s"] = onboard_cpu_s;
  j["scan_file_bad_crc"] = c.live.decode.bad_crc;
}

// Score everything; the flags and the summary.json object in `sc`.
void score(const DemoOptions& a, const DemoSetup& s, sim::LiveTeam& live, const RunRecord& r, const Collected& c,
           DemoScore& sc) {
  // Top-level keys first, in the order summary.json has always had them; the scores fill them in.
  sc.json = {{"scenario", s.scenario.name},
             {"secure", a.secure},
             {"duration_s", s.duration_s},
             {"speed", a.speed},
             {"wall_s", 0.0},
             {"none_lost", true},
             {"agree", true},
             {"clean_exit", true},
             {"tolerance_da_pct", a.tolerance_da_pct},
             {"tolerance_sa_pct", a.tolerance_sa_pct}};
  score_resources(a, s, live, r, c, sc);
  score_faults(a, s, live, r, sc);
  score_live_vs_offline(a, c, sc);
  const bool station_agree = score_station(a, s, c, sc);
  const bool session_agree = score_session_eval(s, c, sc);
  const std::string replay_dir = s.out + "/session-replay";
  const SessionReplay replay = replay_station_session(s.session, s.station_config, replay_dir);
  std::error_code ec;
  fs::remove_all(replay_dir, ec);
  const bool replay_agree = score_replay(replay, sc);
  score_registration(s, c, replay, sc);
  score_corrections(s, c, sc);
  // The identity the verdict requires: with the registration off, `teamscan eval SESSION` (stamp order:
  // the decisions do not depend on the order); with it on, the station's own core on its session in
  // arrival order (the corrections follow the order), and the eval's differences are reported above.
  sc.identity = s.registration ? replay_agree : session_agree;
  sc.identity_what =
      s.registration ? "its core replaying the session in arrival order" : "`teamscan eval` of its session";
  sc.agree = sc.agree && station_agree && sc.identity;
  score_delivery(c, sc);
  if (!sc.shadows.empty()) add_shadows_to_robots(sc.shadows, sc.json["robots"]);
  score_processes(a, r, sc);
  sc.clean = sc.clean && !r.child_died;
  // The methods, robots and processes arrays go last, as they always have.
  for (const char* key : {"robots", "methods", "processes"}) {
    ReportJson v = sc.json[key];
    sc.json.erase(key);
    sc.json[key] = v;
  }
  sc.json["none_lost"] = sc.none_lost;
  sc.json["agree"] = sc.agree;
  sc.json["clean_exit"] = sc.clean;
}

// The station's model as the demo's fused.pcd (its session's fused.pcd, copied), and its pictures drawn
// from its fused_all.pcd (every point where the station placed it, `keep` 0 for a removed one); the
// points as the robots sent them (classes from the truth) beside it. Markdown image lines.
std::string write_model_files(const DemoSetup& s, const Collected& c, Progress& progress) {
  std::error_code ec;
  fs::copy_file(s.session + "/fused.pcd", s.out + "/fused.pcd", fs::copy_options::overwrite_existing, ec);
  if (ec) progress.event("teamscan demo: fused.pcd: the station's " + s.session + "/fused.pcd: " + ec.message());
  std::string pictures;
  render::RenderOptions ro;
  ro.view = render::View::top;
  ro.color = render::ColorMode::class_label;
  ro.title = s.scenario.name + " live: points as the robots sent them (ghosts black)";
  if (render::render_dataset_png(s.out + "/live-all-top.png", c.live.ds, {}, ro))
    pictures += "![live, all points](live-all-top.png)\n";
  auto cloud = read_pcd(s.session + "/fused_all.pcd");
  if (!cloud) {
    progress.event(std::string("teamscan demo: no pictures of the station's model: ") + cloud.error().what);
    return pictures;
  }
  const render::PcdScene scene = render::scene_from_pcd(*cloud);
  render::RenderInput in;
  in.points = scene.points;
  in.keep = scene.keep;
  in.has_labels = scene.has_labels;
  ro.color = render::ColorMode::filter;
  for (const render::View v : {render::View::top, render::View::side}) {
    ro.view = v;
    const std::string name = v == render::View::top ? "live-fused-top.png" : "live-fused-side.png";
    ro.title = s.scenario.name + " live: the station's fused model (removed points white)";
    auto image = render::render(in, ro);
    if (image && render::write_png(s.out + "/" + name, *image))
      pictures += "![the station's model, " + std::string(render::to_string(v)) + "](" + name + ")\n";
  }
  return pictures;
}

std::string demo_report_markdown(const DemoOptions& a, const DemoSetup& s, sim::LiveTeam& live, const RunRecord& r,
                                 const Collected& c, const DemoScore& sc, const std::string& pictures, double wall_s) {
  const std::string live_ds = s.out + "/live-dataset", off_ds = s.out + "/offline-dataset";
  std::ostringstream md;
  md << "# teamscan demo: " << s.scenario.name << "\n\n"
     << live.robot_count() << " robots, " << s.duration_s << " s of robot time at " << a.speed << "x real time, "
     << wall_s << " s wall clock; DDS domain " << s.domain << (s.namespaces ? " in network namespaces, " + std::to_string(s.loss_permille) + " per mille of the datagrams dropped" : std::string{" on loopback"}) << " (`" << s.dds << "`); registration "
     << s.registration_why << (a.secure ? "; DDS Security on (site PKI in `pki/`)" : "") << ".\n\n"
     << "Verdict: nothing lost " << (sc.none_lost ? "yes" : "NO") << ", agree within tolerance "
     << (sc.agree ? "yes" : "NO") << ", clean exits " << (sc.clean ? "yes" : "NO") << ".\n\n## Delivery\n\n```\n"
     << sc.delivery << "```\n\n## The ground station's live fused model vs the truth\n\n```\n"
     << sc.station << "```\n\n## Post-run `teamscan eval` of the live session vs offline (`teamscan eval " << off_ds
     << "`)\n\nTolerance: |ΔDA| ≤ " << a.tolerance_da_pct << " points, |ΔSA| ≤ " << a.tolerance_sa_pct
     << " points (position, direction); |ΔDA| ≤ " << a.tolerance_map_da_pct << ", |ΔSA| ≤ " << a.tolerance_map_sa_pct
     << " points (frequency, visibility, combined: map-based, "
     << "docs/demo.md).\n\n"
     << sc.compare << "\n## Latency, accuracy, CPU\n\n```\n"
     << sc.resources << "```\n\n";
  if (!sc.faults.empty()) md << "## Faults\n\n```\n" << sc.faults << "```\n\n";
  md << "## Live report\n\n"
     << report_markdown(c.live_report, "teamscan eval " + live_ds) << "\n## Offline report\n\n"
     << report_markdown(c.offline_report, "teamscan eval " + off_ds) << "\n"
     << pictures << "\n## Processes and logs\n\n";
  for (const Child& ch : r.children) md << "- " << ch.name << ": `" << ch.log << "` (exit " << ch.exit_code << ")\n";
  return md.str();
}

// The figures of the stdout summary (summary.hpp).
DemoSummary summary_of(const DemoOptions& a, const DemoSetup& s, sim::LiveTeam& live, const Collected& c,
                       const DemoScore& sc) {
  DemoSummary d;
  d.scenario = s.scenario.name;
  d.robots = live.robot_count();
  d.duration_s = s.duration_s;
  d.speed = a.speed;
  d.registration_why = s.registration_why;
  d.network = (s.links ? "in network namespaces (" : "on loopback (") + s.dds + ")";
  d.scans_stored = sc.stored;
  d.scans_missing = sc.missing;
  d.poses_missing = sc.poses_missing;
  d.none_lost = sc.none_lost;
  d.model_present = sc.station_model.present;
  d.model_error = sc.station_model.error;
  d.station_method = a.station_method;
  d.model_da = sc.station_model.model.da;
  d.model_sa = sc.station_model.model.sa;
  if (sc.station_offline) {
    d.offline_da = sc.station_offline->removal.da;
    d.offline_sa = sc.station_offline->removal.sa;
  }
  for (const fusion::MethodResult& m : c.live_report.methods)
    if (m.name == "direction-onboard-flags") d.onboard_da = m.removal.da;
  d.identity_what = sc.identity_what;
  d.identity = sc.identity;
  if (sc.registration.enabled && sc.registration.error.empty()) {
    d.pose_p99_odometry_m = sc.registration.pose_m_odometry.p99;
    d.pose_p99_corrected_m = sc.registration.pose_m_corrected.p99;
  }
  d.pose_graph = s.pose_graph;
  if (sc.registration.graph && sc.registration.error.empty() && sc.registration.graph_error.empty() &&
      sc.registration.pose_m_graph.count > 0) {
    d.pose_p99_graph_m = sc.registration.pose_m_graph.p99;
    d.pose_p99_graph_deg = sc.registration.pose_deg_graph.p99;
    d.graph_closures = sc.graph_closures;
  }
  d.fused_latency_p50_ms = sorted_pct(sc.fused_latency_ms, 0.5);
  d.fused_latency_p99_ms = sorted_pct(sc.fused_latency_ms, 0.99);
  d.out = s.out;
  d.agree = sc.agree;
  d.clean = sc.clean;
  return d;
}

int write_outputs(const DemoOptions& a, const DemoSetup& s, sim::LiveTeam& live, const RunRecord& r, const Collected& c,
                  DemoScore& sc, Progress& progress) {
  // The live data set (for `teamscan eval`), the offline one, the station's model and its pictures.
  const std::string live_ds = s.out + "/live-dataset", off_ds = s.out + "/offline-dataset";
  if (Status st = write_dataset(live_ds, c.live.ds); !st)
    progress.event("teamscan demo: " + live_ds + ": " + st.error().what);
  if (Status st = write_dataset(off_ds, c.offline.dataset); !st)
    progress.event("teamscan demo: " + off_ds + ": " + st.error().what);
  const std::string pictures = write_model_files(s, c, progress);
  const double wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - s.wall_start).count();
  sc.json["wall_s"] = wall_s;
  write_text(s.out + "/report.md", demo_report_markdown(a, s, live, r, c, sc, pictures, wall_s));
  write_text(s.out + "/report-live.json", report_json(c.live_report, "teamscan eval " + live_ds));
  write_text(s.out + "/report-offline.json", report_json(c.offline_report, "teamscan eval " + off_ds));
  write_text(s.out + "/summary.json", json_report(sc.json));
  progress.finish();
  std::fputs(summary_text(summary_of(a, s, live, c, sc)).c_str(), stdout);
  std::fflush(stdout);
  return (sc.none_lost && sc.agree && sc.clean) ? 0 : 1;
}

}  // namespace

int score_and_report(const DemoOptions& a, const DemoSetup& s, sim::LiveTeam& live, Progress& progress, RunRecord& r) {
  Collected c;
  if (int rc = collect(a, s, live, progress, r, c)) return rc;
  progress.stage("teamscan demo: scoring the station's model (against the truth, its session, its replay)...");
  DemoScore sc;
  score(a, s, live, r, c, sc);
  progress.stage("teamscan demo: writing the report, the pictures and the data sets...");
  return write_outputs(a, s, live, r, c, sc, progress);
}

}  // namespace teamscan::demo
