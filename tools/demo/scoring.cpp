// Scoring of a demo run from the ground station's session (scoring.hpp).
#include "tools/demo/scoring.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <map>
#include <set>
#include <unordered_map>

#include "common/dataset/pcd.hpp"
#include "common/laser_geometry.hpp"
#include "common/point_flags.hpp"
#include "common/pose.hpp"
#include "groundstation/station/config.hpp"
#include "groundstation/fusion/core.hpp"
#include "groundstation/fusion/core_set.hpp"
#include "groundstation/fusion/evaluation.hpp"
#include "groundstation/fusion/graph_map.hpp"
#include "groundstation/fusion/time_line.hpp"
#include "groundstation/station/model_check.hpp"
#include "groundstation/station/scan_record_read.hpp"
#include "groundstation/station/session_replay.hpp"
#include "groundstation/trajectory/tum.hpp"

namespace teamscan::demo {
namespace {

Pose2 interpolate_pose(const std::vector<TrajectorySample>& s, std::int64_t t) {
  if (s.empty()) return {};
  auto it = std::lower_bound(s.begin(), s.end(), t, [](const TrajectorySample& a, std::int64_t v) { return a.stamp_ns < v; });
  if (it == s.begin()) return s.front().pose;
  if (it == s.end()) return s.back().pose;
  const TrajectorySample& b = *it;
  const TrajectorySample& a = *std::prev(it);
  const double f = static_cast<double>(t - a.stamp_ns) / static_cast<double>(std::max<std::int64_t>(1, b.stamp_ns - a.stamp_ns));
  return interpolate(a.pose, b.pose, f);
}


// The station's config as the demo wrote it; false with `error` set.
bool read_station_config(const std::string& path, station::GroundStationConfig& cfg, std::string& error) {
  station::ConfigError e;
  if (station::load_groundstation_config(path, cfg, e)) return true;
  error = "cannot read the station config (" + e.message + ")";
  return false;
}
}  // namespace

LiveDataset build_live_dataset(const std::string& session, sim::LiveTeam& live,
                               const std::vector<std::vector<sim::LiveScanTruth>>& truths, const sim::Scenario& scenario,
                               const Dataset& offline, double duration_s) {
  LiveDataset L;
  Dataset& ds = L.ds;
  ds.scenario = offline.scenario;
  ds.seed = offline.seed;
  ds.duration_s = duration_s;
  std::copy(std::begin(offline.room_m), std::end(offline.room_m), std::begin(ds.room_m));
  std::map<std::uint8_t, std::size_t> live_index;  // robot id -> LiveTeam index
  for (std::size_t i = 0; i < live.robot_count(); ++i) live_index[live.spec(i).id] = i;
  for (const DatasetRobot& r : offline.robots)
    if (live_index.count(r.id)) ds.robots.push_back(r);
  auto to_sim_ns = [&](std::int64_t realtime_ns) {
    return scenario.start_time_ns + static_cast<std::int64_t>(std::llround(live.world_time_of(realtime_ns) * 1e9));
  };
  const std::int64_t end_ns = scenario.start_time_ns + static_cast<std::int64_t>(duration_s * 1e9);

  // Odometry as the robots published it (poses.csv), truth from the tracks at the same instants.
  Result<std::vector<PoseRow>> poses = read_poses_csv(session + "/poses.csv");
  if (!poses) L.session_error = std::string("poses.csv: ") + poses.error().what;
  std::map<std::uint8_t, std::vector<std::uint32_t>> pose_seqs;
  for (const PoseRow& p : poses ? poses.value() : std::vector<PoseRow>{}) {
    const auto id = static_cast<std::uint8_t>(p.robot_id);
    if (!live_index.count(id)) continue;
    pose_seqs[id].push_back(p.seq);
    const std::int64_t t = to_sim_ns(p.stamp_ns);
    if (t < scenario.start_time_ns || t > end_ns + 200'000'000) continue;
    TrajectorySample o;
    o.robot = id;
    o.stamp_ns = t;
    o.pose = {p.x_mm * 1e-3, p.y_mm * 1e-3, p.yaw_urad * 1e-6};
    // The tracker is fed the forward speed, as the station's (common/pose.hpp).
    o.v_mps = forward_speed_mps(p.vx_mmps * 1e-3, p.vy_mmps * 1e-3, o.pose.theta_rad);
    o.w_radps = p.yaw_rate_mradps * 1e-3;
    ds.odom.push_back(o);
    // The live world's truth: a robot whose client went silent stood still (sim/live.hpp true_motion).
    const sim::LiveTruth truth = live.true_motion(live_index[id], static_cast<double>(t - scenario.start_time_ns) * 1e-9);
    ds.truth.push_back({id, t, truth.pose, truth.v_mps, truth.w_radps});
  }
  auto by_time = [](const TrajectorySample& a, const TrajectorySample& b) {
    return a.robot != b.robot ? a.robot < b.robot : a.stamp_ns < b.stamp_ns;
  };
  std::sort(ds.odom.begin(), ds.odom.end(), by_time);
  std::sort(ds.truth.begin(), ds.truth.end(), by_time);
  std::map<std::uint8_t, std::vector<TrajectorySample>> odom_of;
  for (const TrajectorySample& s : ds.odom) odom_of[s.robot].push_back(s);

  std::map<std::uint8_t, RobotDelivery> del;
  std::map<std::uint8_t, std::vector<std::uint32_t>> seqs;
  std::map<std::uint8_t, std::uint32_t> next_scan;
  std::map<std::uint8_t, std::set<std::uint32_t>> seen;
  std::string err;
  station::read_scan_file(session + "/scans.bin", [&](const ScanPoints& s, const station::Receipt& receipt) {
    const auto id = static_cast<std::uint8_t>(s.robot_id);
    if (!live_index.count(id)) return;
    RobotDelivery& d = del[id];
    d.id = id;
    ++d.stored;
    seqs[id].push_back(s.seq);
    // A restarted ground station gets the robots' history again (DDS transient-local, depth 300): a scan
    // already stored is stored twice; the data set keeps the first.
    if (!seen[id].insert(s.seq).second) return;
    if (receipt.rejected != 0) {  // refused at the edge (docs/validation.md): stored, never fused
      ++d.refused;
      return;
    }
    const std::int64_t t = to_sim_ns(s.stamp.ns());
    if (t < scenario.start_time_ns || t > end_ns) return;  // bring-up (robots standing) or after the end
    // Latency in the run window only: bring-up (the station matching the robots' writers gets their
    // history) and the ordered shutdown are not the steady state.
    L.latency_ms.push_back(static_cast<double>(receipt.recv_realtime_ns - s.stamp.ns()) * 1e-6);
    ++d.in_window;
    const sim::LiveScanTruth* truth = sim::match_truth(truths[live_index[id]], s.stamp.ns(), 6'000'000);
    if (!truth) {
      ++d.truth_unmatched;
      return;
    }
    ++d.truth_matched;
    ScanRecord rec;
    rec.robot = id;
    rec.scan = next_scan[id]++;
    rec.stamp_ns = t;
    rec.beams = static_cast<std::uint16_t>(truth->beams.size());
    rec.origin = {s.origin_x_mm * 1e-3, s.origin_y_mm * 1e-3, s.origin_z_mm * 1e-3};
    rec.pose = interpolate_pose(odom_of[id], t);
    rec.true_pose = live.true_motion(live_index[id], static_cast<double>(t - scenario.start_time_ns) * 1e-9).pose;
    for (std::uint16_t k = 0; k < s.count; ++k) {
      const ScanPoint& p = s.points[k];
      if (p.flags & kPointUnplaced) continue;  // no 3-D point (as the simulator's data set)
      if (p.beam >= truth->beams.size()) continue;
      const sim::LiveBeamTruth& b = truth->beams[p.beam];
      LabelledPoint lp;
      lp.x = static_cast<float>(p.x_mm * 1e-3);
      lp.y = static_cast<float>(p.y_mm * 1e-3);
      lp.z = static_cast<float>(p.z_mm * 1e-3);
      lp.robot = id;
      lp.scan = rec.scan;
      lp.beam = p.beam;
      lp.label = b.label;
      lp.hit_robot = b.hit_robot;
      lp.flags = dataset_flags_from_wire(p.flags);
      lp.tx = b.tx;
      lp.ty = b.ty;
      lp.tz = b.tz;
      ds.points.push_back(lp);
      L.point_seq.push_back(s.seq);
      if (b.label != PointClass::none) {
        const double ex = lp.x - b.tx, ey = lp.y - b.ty, ez = lp.z - b.tz;
        L.point_error_mm.push_back(1e3 * std::sqrt(ex * ex + ey * ey + ez * ez));
      }
      ++rec.points;
    }
    ds.scans.push_back(rec);
    L.scan_seq.push_back(s.seq);
  }, L.decode, err);

  // The last scans_published each robot reported (status.csv, by column name).
  std::map<std::uint8_t, std::uint32_t> last_pub;
  Result<std::vector<StatusRow>> status = read_status_csv(session + "/status.csv");
  if (!status && L.session_error.empty()) L.session_error = std::string("status.csv: ") + status.error().what;
  for (const StatusRow& s : status ? status.value() : std::vector<StatusRow>{})
    last_pub[static_cast<std::uint8_t>(s.robot_id)] = s.scans_published;
  for (std::size_t i = 0; i < live.robot_count(); ++i) {
    const std::uint8_t id = live.spec(i).id;
    RobotDelivery d = del[id];
    d.id = id;
    std::vector<std::uint32_t>& q = seqs[id];
    std::sort(q.begin(), q.end());
    const std::size_t unique = static_cast<std::size_t>(std::unique(q.begin(), q.end()) - q.begin());
    d.duplicates = q.size() - unique;
    q.resize(unique);
    if (!q.empty()) {
      d.seq_first = q.front();
      d.seq_last = q.back();
      d.gaps = (static_cast<std::uint64_t>(q.back()) - q.front() + 1) - q.size();
    }
    std::vector<std::uint32_t>& pq = pose_seqs[id];
    std::sort(pq.begin(), pq.end());
    d.poses = pq.size();
    pq.erase(std::unique(pq.begin(), pq.end()), pq.end());
    d.pose_duplicates = d.poses - pq.size();
    if (!pq.empty()) {
      d.pose_seq_first = pq.front();
      d.pose_seq_last = pq.back();
      d.pose_gaps = (static_cast<std::uint64_t>(pq.back()) - pq.front() + 1) - pq.size();
    }
    d.last_status_published = last_pub[id];
    d.measured = live.scans_measured(i);
    for (const sim::LiveScanTruth& t : truths[i]) {
      const std::int64_t ts = to_sim_ns(t.sweep_end_realtime_ns);
      if (ts < scenario.start_time_ns || ts > end_ns) continue;
      for (const sim::LiveBeamTruth& b : t.beams) d.truth_ghost_beams += b.label == PointClass::robot ? 1 : 0;
    }
    L.delivery.push_back(d);
  }
  return L;
}

std::vector<LatencySummary> read_latency_csv(const std::string& path) {
  std::vector<LatencySummary> out;
  std::ifstream in(path);
  for (std::string line; std::getline(in, line);) {
    const auto comma = line.find(',');
    if (comma == std::string::npos) continue;
    const std::string key = line.substr(0, comma);
    char* end = nullptr;
    const std::string value = line.substr(comma + 1);
    const double v = std::strtod(value.c_str(), &end);
    if (end == value.c_str()) continue;
    if (key == "count") {
      out.emplace_back();
      out.back().present = true;
      out.back().count = v;
    }
    if (out.empty()) continue;
    if (key == "p50") out.back().p50_ms = v;
    if (key == "p90") out.back().p90_ms = v;
    if (key == "p99") out.back().p99_ms = v;
    if (key == "max") out.back().max_ms = v;
  }
  return out;
}

std::vector<double> read_fused_latency_log(const std::string& path, std::int64_t from_ns, std::int64_t to_ns) {
  std::vector<double> out;
  Result<CsvTable> table = CsvTable::read(path);
  if (!table) return out;
  const CsvTable& t = table.value();
  const auto stamp = t.column("stamp_ns"), fused = t.column("fused_ns");
  if (!stamp || !fused) return out;
  for (std::size_t r = 0; r < t.rows(); ++r) {
    const auto s = t.integer(r, *stamp), f = t.integer(r, *fused);
    if (!s || !f || *s < from_ns || *s > to_ns) continue;
    out.push_back(static_cast<double>(*f - *s) * 1e-6);
  }
  std::sort(out.begin(), out.end());
  return out;
}

double sorted_pct(const std::vector<double>& v, double q) {
  return v.empty() ? 0.0 : v[std::min(v.size() - 1, static_cast<std::size_t>(q * static_cast<double>(v.size())))];
}

StationScore score_station_model(const std::string& fused_all_pcd, const std::vector<LabelledPoint>& points,
                                 const std::vector<std::uint32_t>& point_seq) {
  StationScore ss;
  auto cloud = read_pcd(fused_all_pcd);
  if (!cloud) {
    ss.error = cloud.error().what;
    return ss;
  }
  const PcdCloud& c = cloud.value();
  const int fr = c.field("robot"), fsq = c.field("scan"), fb = c.field("beam"), fk = c.field("keep"), fl = c.field("live_keep");
  if (fr < 0 || fsq < 0 || fb < 0 || fk < 0) {
    ss.error = "fused_all.pcd lacks robot/scan/beam/keep";
    return ss;
  }
  auto key = [](double robot, double seq, double beam) {
    return station::point_key(static_cast<std::uint32_t>(robot), static_cast<std::uint32_t>(seq), static_cast<std::uint32_t>(beam));
  };
  std::unordered_map<std::uint64_t, std::uint8_t> flags;  // bit 0: keep, bit 1: live_keep
  flags.reserve(c.size());
  for (std::size_t i = 0; i < c.size(); ++i) {
    const auto fi = [&](int f) { return c.columns[static_cast<std::size_t>(f)][i]; };
    flags[key(fi(fr), fi(fsq), fi(fb))] =
        static_cast<std::uint8_t>((fi(fk) != 0 ? 1 : 0) | (fl < 0 || fi(fl) != 0 ? 2 : 0));
  }
  ss.model_points = c.size();
  std::vector<LabelledPoint> pts;
  std::vector<std::uint8_t> rm_model, rm_live;
  ss.removed.assign(points.size(), 0);
  for (std::size_t i = 0; i < points.size(); ++i) {
    const LabelledPoint& p = points[i];
    const auto it = flags.find(key(p.robot, point_seq[i], p.beam));
    if (it == flags.end()) {
      ++ss.unmatched;
      continue;
    }
    ++ss.matched;
    pts.push_back(p);
    rm_model.push_back((it->second & 1) ? 0 : 1);
    rm_live.push_back((it->second & 2) ? 0 : 1);
    ss.removed[i] = rm_model.back();
  }
  ss.model = mapping::removal_metrics(pts, rm_model);
  ss.live = mapping::removal_metrics(pts, rm_live);
  ss.present = ss.matched > 0;
  return ss;
}

std::vector<SessionEvalCheck> check_station_models_against_session_eval(const std::string& session,
                                                                       const std::string& station_config,
                                                                       const std::vector<LabelledPoint>& points,
                                                                       const std::vector<std::uint32_t>& point_seq) {
  station::GroundStationConfig gcfg;
  SessionEvalCheck failed;
  if (!read_station_config(station_config, gcfg, failed.error)) return {failed};
  std::vector<SessionEvalCheck> out;
  out.push_back(check_station_against_session_eval(session, station_config, points, point_seq));
  for (const std::string& m : gcfg.fusion.compare_methods)
    out.push_back(check_station_against_session_eval(session, station_config, points, point_seq, m));
  return out;
}

SessionEvalCheck check_station_against_session_eval(const std::string& session, const std::string& station_config,
                                                    const std::vector<LabelledPoint>& points,
                                                    const std::vector<std::uint32_t>& point_seq, const std::string& method) {
  SessionEvalCheck sc;
  station::GroundStationConfig gcfg;
  if (!read_station_config(station_config, gcfg, sc.error)) return sc;
  sc.primary = method.empty() || method == gcfg.fusion.core.method;
  sc.method = sc.primary ? gcfg.fusion.core.method : method;
  // With its [registration] (on and its keys): the eval of the session runs with the registration as the
  // station did (`teamscan eval SESSION --registration`), so the identity holds with it on.
  const station::FusionOptions& station_options = gcfg.fusion;
  auto check = station::check_model_against_eval(
      session, sc.primary ? station_options : station::compared_options(station_options, sc.method));
  if (!check) {
    sc.error = check.error().what;
    return sc;
  }
  const station::ModelCheck& mc = check.value();
  std::unordered_map<std::uint64_t, std::size_t> labelled;  // identity -> points index
  labelled.reserve(points.size());
  for (std::size_t i = 0; i < points.size(); ++i) labelled[station::point_key(points[i].robot, point_seq[i], points[i].beam)] = i;
  std::vector<LabelledPoint> pts;
  std::vector<std::uint8_t> rm_model, rm_eval, rm_live;
  for (const station::PointDecision& d : mc.points) {
    if (!d.in_model) continue;
    auto it = labelled.find(station::point_key(d.robot, d.seq, d.beam));
    if (it == labelled.end()) continue;  // bring-up or after the run window: no label
    pts.push_back(points[it->second]);
    rm_model.push_back(d.model_removed ? 1 : 0);
    rm_eval.push_back(d.eval_removed ? 1 : 0);
    rm_live.push_back(d.live_removed ? 1 : 0);
  }
  sc.compared = mc.compared;
  sc.not_in_model = mc.not_in_model;
  sc.mismatches = mc.mismatches;
  sc.labelled = pts.size();
  sc.station = mapping::removal_metrics(pts, rm_model);
  sc.eval = mapping::removal_metrics(pts, rm_eval);
  sc.live = mapping::removal_metrics(pts, rm_live);
  sc.identical = mc.mismatches == 0 && mc.compared > 0;
  return sc;
}

namespace {

// A model file's rows by point_key, and its keep column.
struct ModelRows {
  std::unordered_map<std::uint64_t, std::size_t> row;
  int keep = -1;
};

Result<ModelRows> index_model(const PcdCloud& c) {
  ModelRows m;
  const int fr = c.field("robot"), fs = c.field("scan"), fb = c.field("beam");
  m.keep = c.field("keep");
  if (fr < 0 || fs < 0 || fb < 0 || m.keep < 0) return Error{"the model lacks robot/scan/beam/keep"};
  m.row.reserve(c.size());
  for (std::size_t i = 0; i < c.size(); ++i) {
    auto col = [&](int f) { return static_cast<std::uint32_t>(c.columns[static_cast<std::size_t>(f)][i]); };
    m.row[station::point_key(col(fr), col(fs), col(fb))] = i;
  }
  return m;
}

}  // namespace

SessionReplay replay_station_session(const std::string& session, const std::string& station_config,
                                     const std::string& scratch_dir) {
  SessionReplay out;
  station::GroundStationConfig gcfg;
  if (!read_station_config(station_config, gcfg, out.error)) return out;
  const station::FusionOptions& options = gcfg.fusion;
  // The station's set of cores (fusion/core_set.hpp), fed as the station's restart replay feeds it.
  auto created = fusion::CoreSet::create(options.pose_graph ? fusion::with_graph_order(options.core) : options.core, options.compare_methods);
  if (!created) {
    out.error = std::string("fusion cores: ") + created.error().what;
    return out;
  }
  fusion::CoreSet& cores = *created.value();
  std::vector<std::string> methods;
  std::vector<station::FusionOptions> per_method;
  for (std::size_t k = 0; k < cores.size(); ++k) {
    methods.push_back(cores.at(k).options().method);
    per_method.push_back(station::compared_options(options, methods.back()));
  }
  // With the registration on, where the primary core put every scan and point (off: where the robots did);
  // with the pose graph, its back end fed every release, as the station's is.
  std::unique_ptr<fusion::GraphBackend> graph;
  out.pose_graph = options.pose_graph.has_value();
  if (options.pose_graph) graph = std::make_unique<fusion::GraphBackend>(fusion::without_estimates(*options.pose_graph));
  if (options.core.registration || graph) {
    cores.primary().set_release_callback([&](const fusion::FusedScan& f) {
      if (graph) graph->add(f);
      if (!options.core.registration) return;
      out.scan_pose[{f.view->robot, f.view->scan}] = f.view->map_from_robot;
      for (std::size_t i = 0; i < f.view->points.size() && i < f.beams.size(); ++i)
        out.placed[station::point_key(f.view->robot, f.view->scan, f.beams[i])] = f.view->points[i];
    });
  }
  // Every sample in arrival order with its receive time, as the station took them (its restart replay).
  station::SessionReadStats stats;
  fusion::ScanInput scan;
  const Status st = station::replay_session_files(
      session, [&](const station::PoseObservation& p) { cores.add_pose(station::pose_input(p)); },
      [&](const ScanPoints& s, const station::Receipt& receipt) {
        (void)cores.add_scan(station::scan_input(s, receipt, scan));
      },
      stats);
  if (!st.ok()) {
    out.error = std::string("session: ") + st.error().what;
    return out;
  }
  // A scan released late (a robot's back-fill), or the graph fed scans out of stamp order: the station
  // caught up, its final model is the time order's (station/fusion.hpp FusionStage::flush), and so is
  // the replay's.
  if (cores.primary().counters().scans_late > 0 || (graph && graph->counters().out_of_stamp_order > 0)) {
    station::SessionReadStats again;
    Result<Dataset> ds = station::read_session_dataset(session, again);
    if (!ds) {
      out.error = std::string("session: ") + ds.error().what;
      return out;
    }
    out.scan_pose.clear();
    out.placed.clear();
    if (graph) graph = std::make_unique<fusion::GraphBackend>(fusion::without_estimates(*options.pose_graph));  // fed the releases again
    if (Result<std::size_t> fed = fusion::refeed_in_time_order(ds.value(), cores); !fed) {
      out.error = std::string("fusion cores: ") + fed.error().what;
      return out;
    }
  }
  // With the pose graph, the station's final model is decided again on the graph's poses
  // (FusionStage::rebuild_on_graph): every held scan released into the graph first, then a set of cores
  // without the registration fed the session on its poses.
  std::unique_ptr<fusion::CoreSet> on_graph;
  if (graph) {
    cores.flush();
    station::SessionReadStats again;
    Result<Dataset> ds = station::read_session_dataset(session, again);
    if (!ds) {
      out.error = std::string("session: ") + ds.error().what;
      return out;
    }
    auto rebuilt = fusion::cores_on_graph(ds.value(), graph->poses(), options.core, options.compare_methods);
    if (!rebuilt) {
      out.error = std::string("fusion cores on the graph's poses: ") + rebuilt.error().what;
      return out;
    }
    on_graph = std::move(rebuilt.value());
  }
  fusion::CoreSet& model_cores = on_graph ? *on_graph : cores;
  std::error_code ec;
  std::filesystem::create_directories(scratch_dir, ec);
  for (std::size_t k = 0; k < cores.size(); ++k) {
    model_cores.at(k).flush();
    ReplayModelCheck mc;
    mc.method = methods[k];
    mc.primary = k == 0;
    const std::string all_name = per_method[k].all_points_pcd.empty() ? station::method_file_name("fused_all.pcd", methods[k])
                                                                      : per_method[k].all_points_pcd;
    const std::string replayed_path = scratch_dir + "/" + all_name;
    auto written = fusion::write_model_files(model_cores.at(k), scratch_dir + "/" + per_method[k].kept_pcd, replayed_path);
    auto station_cloud = read_pcd(session + "/" + all_name);
    auto replay_cloud = read_pcd(replayed_path);
    if (!written || !station_cloud || !replay_cloud) {
      mc.error = !written ? std::string("replayed model: ") + written.error().what
                 : !station_cloud ? std::string("the station's ") + all_name + ": " + station_cloud.error().what
                                  : std::string("replayed model: ") + replay_cloud.error().what;
      out.models.push_back(mc);
      continue;
    }
    auto station_rows = index_model(station_cloud.value());
    auto replay_rows = index_model(replay_cloud.value());
    if (!station_rows || !replay_rows) {
      mc.error = std::string("model columns: ") + (!station_rows ? station_rows.error().what : replay_rows.error().what);
      out.models.push_back(mc);
      continue;
    }
    const PcdCloud& sc = station_cloud.value();
    const PcdCloud& rc = replay_cloud.value();
    mc.model_points = sc.size();
    mc.replay_points = rc.size();
    for (const auto& [key, i] : station_rows->row) {
      auto it = replay_rows->row.find(key);
      if (it == replay_rows->row.end()) continue;
      const std::size_t j = it->second;
      ++mc.compared;
      const auto ks = static_cast<std::size_t>(station_rows->keep), kr = static_cast<std::size_t>(replay_rows->keep);
      if ((sc.columns[ks][i] != 0) != (rc.columns[kr][j] != 0)) ++mc.decisions_differ;
      const double dx = sc.xyz[3 * i] - rc.xyz[3 * j], dy = sc.xyz[3 * i + 1] - rc.xyz[3 * j + 1], dz = sc.xyz[3 * i + 2] - rc.xyz[3 * j + 2];
      const double d = std::sqrt(dx * dx + dy * dy + dz * dz);
      if (d > 1e-3) ++mc.placed_differ;
      mc.placed_differ_max_m = std::max(mc.placed_differ_max_m, d);
    }
    mc.identical = mc.compared > 0 && mc.compared == mc.model_points && mc.compared == mc.replay_points &&
                   mc.decisions_differ == 0 && mc.placed_differ == 0;
    out.models.push_back(mc);
  }
  if (const registration::Registration* reg = cores.primary().registration()) {
    for (std::uint8_t id = 1; id <= kMaxRobots; ++id)
      if (const registration::RobotCorrection* c = reg->correction(id)) out.robots.push_back(*c);
  }
  if (graph) {
    // The graph's last search and optimisation, then its poses as the station writes them.
    std::map<std::uint8_t, std::vector<trajectory::StampedPose>> by_robot;
    for (const fusion::GraphScanPose& p : graph->poses()) {
      out.graph_pose[{p.robot, p.scan}] = p.graph;
      by_robot[p.robot].push_back({(p.stamp_ns + 500) / 1000, p.graph});
    }
    for (const auto& [robot, poses] : by_robot) out.graph_tum[robot] = trajectory::tum_text(poses);
    out.graph_stats = graph->graph_stats();
  }
  return out;
}

LiveRegistrationScore score_live_registration(const std::string& session, const std::string& station_config,
                                              const SessionReplay& replay, const LiveDataset& live) {
  LiveRegistrationScore out;
  station::GroundStationConfig gcfg;
  if (!read_station_config(station_config, gcfg, out.error)) return out;
  out.enabled = gcfg.fusion.core.registration;
  if (!replay.error.empty()) {
    out.error = replay.error;
    return out;
  }
  // The session as the robots' odometry placed it (each scan's pose from the odometry at its stamp).
  station::SessionReadStats stats;
  auto read = station::read_session_dataset(session, stats);
  if (!read) {
    out.error = std::string("session: ") + read.error().what;
    return out;
  }
  const Dataset& sd = read.value();
  // The run window's truth, by (robot, seq) and (robot, seq, beam).
  std::map<std::pair<std::uint8_t, std::uint32_t>, std::size_t> scan_of;
  for (std::size_t i = 0; i < live.ds.scans.size() && i < live.scan_seq.size(); ++i)
    scan_of[{live.ds.scans[i].robot, live.scan_seq[i]}] = i;
  std::unordered_map<std::uint64_t, std::size_t> point_of;
  point_of.reserve(live.ds.points.size());
  for (std::size_t i = 0; i < live.ds.points.size() && i < live.point_seq.size(); ++i)
    point_of[station::point_key(live.ds.points[i].robot, live.point_seq[i], live.ds.points[i].beam)] = i;

  Dataset measured;
  measured.truth = live.ds.truth;
  std::vector<Pose2> corrected_poses;
  std::vector<std::uint8_t> decided;
  for (const ScanRecord& s : sd.scans) {
    auto it = scan_of.find({s.robot, s.scan});
    if (it == scan_of.end()) continue;
    ScanRecord r = s;
    r.true_pose = live.ds.scans[it->second].true_pose;
    measured.scans.push_back(r);
    // Registration off: corrected = odometry; on: the scans the core released (all, after its flush).
    auto p = replay.scan_pose.find({s.robot, s.scan});
    corrected_poses.push_back(p != replay.scan_pose.end() ? p->second : r.pose);
    decided.push_back(!out.enabled || p != replay.scan_pose.end() ? 1 : 0);
  }
  std::vector<mapping::MapPoint> corrected_points;
  for (const LabelledPoint& p : sd.points) {
    const std::uint64_t key = station::point_key(p.robot, p.scan, p.beam);
    auto placed = replay.placed.find(key);
    const mapping::MapPoint at = placed != replay.placed.end() ? placed->second : mapping::MapPoint{p.x, p.y, p.z};
    const double moved = std::sqrt((at.x - p.x) * (at.x - p.x) + (at.y - p.y) * (at.y - p.y) + (at.z - p.z) * (at.z - p.z));
    if (moved > 1e-3) ++out.points_moved;
    out.points_moved_max_m = std::max(out.points_moved_max_m, moved);
    auto it = point_of.find(key);
    if (it == point_of.end()) continue;
    const LabelledPoint& t = live.ds.points[it->second];
    LabelledPoint q = p;
    q.label = t.label;
    q.hit_robot = t.hit_robot;
    q.tx = t.tx;
    q.ty = t.ty;
    q.tz = t.tz;
    measured.points.push_back(q);
    corrected_points.push_back(at);
  }
  mapping::measure_errors(measured, out.pose_m_odometry, out.pose_deg_odometry, out.point_m_odometry);
  mapping::measure_errors(measured, out.pose_m_corrected, out.pose_deg_corrected, out.point_m_corrected, corrected_points,
                          corrected_poses, decided);
  out.scans = out.pose_m_corrected.count;
  out.points = out.point_m_corrected.count;
  out.graph = replay.pose_graph;
  if (out.graph) {
    std::vector<Pose2> graph_poses;
    std::vector<std::uint8_t> in_graph;
    for (const ScanRecord& r : measured.scans) {
      const auto p = replay.graph_pose.find({r.robot, r.scan});
      graph_poses.push_back(p != replay.graph_pose.end() ? p->second : r.pose);
      in_graph.push_back(p != replay.graph_pose.end() ? 1 : 0);
    }
    mapping::ErrorStats unused;
    mapping::measure_errors(measured, out.pose_m_graph, out.pose_deg_graph, unused, {}, graph_poses, in_graph);
    // The station's files against the replay's graph, byte for byte.
    for (const auto& [robot, text] : replay.graph_tum) {
      ++out.graph_files;
      std::ifstream in(session + "/robot" + std::to_string(robot) + ".graph.tum", std::ios::binary);
      if (!in) {
        out.graph_error = "robot" + std::to_string(robot) + ".graph.tum missing in the session";
        ++out.graph_files_differ;
        continue;
      }
      const std::string station_text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
      if (station_text != text) ++out.graph_files_differ;
    }
    if (replay.graph_tum.empty()) out.graph_error = "the replay's graph took no scan";
  }
  return out;
}

RobotCorrections score_robot_corrections(const std::string& session, const LiveDataset& live) {
  RobotCorrections out;
  std::map<std::uint8_t, RobotCorrectionScore> by_robot;
  auto robot = [&](std::uint32_t id) -> RobotCorrectionScore& {
    RobotCorrectionScore& r = by_robot[static_cast<std::uint8_t>(id)];
    r.robot = static_cast<std::uint8_t>(id);
    return r;
  };
  Result<std::vector<StatusRow>> status = read_status_csv(session + "/status.csv");
  if (!status) {
    out.error = std::string("session: ") + status.error().what;
    return out;
  }
  for (const StatusRow& s : status.value()) {  // counters only grow: the highest is the last
    RobotCorrectionScore& r = robot(s.robot_id);
    r.corrections_applied = std::max(r.corrections_applied, s.corrections_applied);
    r.corrections_rejected = std::max(r.corrections_rejected, s.corrections_rejected);
  }
  // Each accepted scan's applied correction, by (robot, seq).
  std::map<std::pair<std::uint8_t, std::uint32_t>, OdomCorrection> applied;
  std::map<std::uint8_t, std::set<std::uint32_t>> carried;
  station::ScanDecodeStats st;
  std::string err;
  if (!station::read_scan_file(session + "/scans.bin", [&](const ScanPoints& sc, const station::Receipt& receipt) {
        if (receipt.rejected != 0 || sc.robot_id == 0 || sc.robot_id > kMaxRobots) return;
        RobotCorrectionScore& r = robot(sc.robot_id);
        ++r.scans;
        r.last = sc.applied;
        if (sc.applied.none()) return;
        ++r.scans_corrected;
        carried[r.robot].insert(sc.applied.seq);
        applied[{r.robot, sc.seq}] = sc.applied;
      }, st, err)) {
    out.error = "session: " + err;
    return out;
  }
  for (const auto& [id, seqs] : carried) by_robot[id].corrections_carried = seqs.size();
  // The run window's scans that carry a correction: odometry pose (the session's, at the scan's stamp)
  // and the robot's, against the truth.
  station::SessionReadStats stats;
  auto read = station::read_session_dataset(session, stats);
  if (!read) {
    out.error = std::string("session: ") + read.error().what;
    return out;
  }
  std::map<std::pair<std::uint8_t, std::uint32_t>, std::size_t> truth_of;
  for (std::size_t i = 0; i < live.ds.scans.size() && i < live.scan_seq.size(); ++i)
    truth_of[{live.ds.scans[i].robot, live.scan_seq[i]}] = i;
  for (auto& [id, r] : by_robot) {
    Dataset measured;
    measured.truth = live.ds.truth;
    std::vector<Pose2> robot_poses;
    for (const ScanRecord& s : read->scans) {
      if (s.robot != id) continue;
      auto a = applied.find({s.robot, s.scan});
      auto t = truth_of.find({s.robot, s.scan});
      if (a == applied.end() || t == truth_of.end()) continue;
      ScanRecord m = s;
      m.true_pose = live.ds.scans[t->second].true_pose;
      measured.scans.push_back(m);
      robot_poses.push_back(a->second.map_from_odom() * s.pose);
    }
    mapping::ErrorStats points;
    mapping::measure_errors(measured, r.pose_m_odometry, r.pose_deg_odometry, points);
    mapping::measure_errors(measured, r.pose_m_robot, r.pose_deg_robot, points, {}, robot_poses);
    out.robots.push_back(r);
  }
  return out;
}

UnplugReport unplug_report(const std::vector<StatusRow>& status, std::uint32_t robot_id) {
  UnplugReport r;
  for (const StatusRow& s : status) {
    if (s.robot_id != robot_id) continue;
    if (r.lms_states.empty() || r.lms_states.back() != s.lms_state) r.lms_states.push_back(s.lms_state);
    r.lms_reopens = std::max(r.lms_reopens, s.lms_reopens);
  }
  return r;
}

KillReport kill_report(const std::string& session, std::uint32_t robot_id, std::int64_t kill_realtime_ns) {
  KillReport k;
  std::ifstream ev(session + "/events.log");
  const std::string needle = "robot " + std::to_string(robot_id) + " LOST";
  for (std::string line; std::getline(ev, line);) {
    if (line.find(needle) == std::string::npos) continue;
    char* end = nullptr;
    const long long t = std::strtoll(line.c_str(), &end, 10);
    if (end == line.c_str()) continue;
    if (t >= kill_realtime_ns) {
      k.lost_after_s = static_cast<double>(t - kill_realtime_ns) * 1e-9;
      break;
    }
  }
  // The other robots' scans from 1 s after the kill: points flagged team-stale, and points filtered.
  station::ScanDecodeStats st;
  std::string err;
  station::read_scan_file(session + "/scans.bin", [&](const ScanPoints& sc, const station::Receipt&) {
    if (sc.robot_id == robot_id) return;
    const bool after = sc.stamp.ns() >= kill_realtime_ns + 1'000'000'000;
    if (after) ++k.others_scans_after;
    for (std::uint16_t i = 0; i < sc.count; ++i) {
      const std::uint16_t fl = sc.points[i].flags;
      if (fl & kPointTeamStale) ++(after ? k.team_stale_after : k.team_stale_before);
      if (after && (fl & kPointDirectionFiltered)) ++k.direction_filtered_after;
    }
  }, st, err);
  return k;
}

}  // namespace teamscan::demo
