// PlanarSlam on the whole Intel Research Lab log (tests/data/real/intel.clf.xz, 13 631 scans): the
// relations metric (intel.relations; all, and split into relations within 100 s and across revisits)
// and the CPU time (all threads) and wall time of the SLAM alone (parsing excluded). TEAMSCAN_BENCH_SLAM_SCANS limits the scans;
// TEAMSCAN_BENCH_SLAM_OPTIONS="name=value,..." overrides SlamOptions fields by name, for tuning.
#include <benchmark/benchmark.h>

#include <time.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include "common/dataset/log_text.hpp"
#include "groundstation/posegraph/slam.hpp"
#include "groundstation/trajectory/relations.hpp"
#include "tests/support/real_data.hpp"
#include "tests/unit/posegraph/carmen_log.hpp"

namespace teamscan::posegraph {
namespace {

// TEAMSCAN_BENCH_SLAM_OPTIONS: a few SlamOptions fields by name.
SlamOptions options_from_env() {
  SlamOptions o;
  const char* env = std::getenv("TEAMSCAN_BENCH_SLAM_OPTIONS");
  if (!env) return o;
  std::map<std::string, double*> d = {
      {"resolution_m", &o.resolution_m},
      {"hit_sigma_m", &o.hit_sigma_m},
      {"max_range_m", &o.max_range_m},
      {"local.occupied_weight", &o.local.occupied_weight},
      {"local.translation_weight", &o.local.translation_weight},
      {"local.rotation_weight", &o.local.rotation_weight},
      {"closure_max_distance_m", &o.closure_max_distance_m},
      {"closure_min_score", &o.closure_min_score},
      {"closure_min_refined_score", &o.closure_min_refined_score},
      {"closure_weak_axis_floor", &o.closure_weak_axis_floor},
      {"closure_rotation_lever_m", &o.closure_rotation_lever_m},
      {"closure_rotation_floor", &o.closure_rotation_floor},
      {"still_translation_m", &o.still_translation_m},
      {"still_rotation_rad", &o.still_rotation_rad},
      {"graph.matcher_translation_weight", &o.graph.matcher_translation_weight},
      {"graph.matcher_rotation_weight", &o.graph.matcher_rotation_weight},
      {"graph.closure_translation_weight", &o.graph.closure_translation_weight},
      {"graph.closure_rotation_weight", &o.graph.closure_rotation_weight},
      {"graph.odometry_translation_weight", &o.graph.odometry_translation_weight},
      {"graph.odometry_rotation_weight", &o.graph.odometry_rotation_weight},
      {"graph.local_translation_weight", &o.graph.local_translation_weight},
      {"graph.local_rotation_weight", &o.graph.local_rotation_weight},
      {"graph.closure_huber_scale", &o.graph.closure_huber_scale},
      {"graph.rest_translation_m", &o.graph.rest_translation_m},
      {"graph.rest_rotation_rad", &o.graph.rest_rotation_rad},
      {"graph.rest_weight_factor", &o.graph.rest_weight_factor},
      {"closure_window.linear_m", &o.closure_window.linear_m},
      {"closure_window.angular_rad", &o.closure_window.angular_rad},
      {"rematch_window.linear_m", &o.rematch_window.linear_m},
      {"rematch_window.angular_rad", &o.rematch_window.angular_rad},
      {"closure_window.plateau_score", &o.closure_window.plateau_score},
      {"rematch_window.plateau_score", &o.rematch_window.plateau_score},
      {"retire_distance_m", &o.retire_distance_m},
      {"rematch_cell_m", &o.rematch_cell_m},
      {"local_search_score", &o.local_search_score},
      {"local_search_window.linear_m", &o.local_search_window.linear_m},
      {"local_search_window.angular_rad", &o.local_search_window.angular_rad},
  };
  std::map<std::string, int*> i = {
      {"scans_per_submap", &o.scans_per_submap},
      {"local.max_iterations", &o.local.max_iterations},
      {"closure_every_n_nodes", &o.closure_every_n_nodes},
      {"closure_track_nodes", &o.closure_track_nodes},
      {"closure_skip_recent_nodes", &o.closure_skip_recent_nodes},
      {"closure_submaps", &o.closure_submaps},
      {"closure_depth", &o.closure_depth},
      {"closure_pool", &o.closure_pool},
      {"optimize_every_n_nodes", &o.optimize_every_n_nodes},
      {"rematch_submaps", &o.rematch_submaps},
      {"rematch_every_n_nodes", &o.rematch_every_n_nodes},
      {"rematch_rounds", &o.rematch_rounds},
      {"threads", &o.threads},
      {"graph.max_iterations", &o.graph.max_iterations},
      {"graph.final_max_iterations", &o.graph.final_max_iterations},
      {"retire_after_submaps", &o.retire_after_submaps},
      {"rematch_nodes_per_cell", &o.rematch_nodes_per_cell},
  };
  std::stringstream ss(env);
  std::string item;
  while (std::getline(ss, item, ',')) {
    const auto eq = item.find('=');
    if (eq == std::string::npos) continue;
    const std::string name = item.substr(0, eq), value = item.substr(eq + 1);
    if (auto it = d.find(name); it != d.end()) *it->second = std::atof(value.c_str());
    else if (auto jt = i.find(name); jt != i.end()) *jt->second = std::atoi(value.c_str());
    else std::fprintf(stderr, "TEAMSCAN_BENCH_SLAM_OPTIONS: unknown %s\n", name.c_str());
  }
  return o;
}

double cpu_s() {
  timespec t{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
  return static_cast<double>(t.tv_sec) + 1e-9 * static_cast<double>(t.tv_nsec);
}

void print(const char* name, const trajectory::RelationErrors& e) {
  std::printf("%-22s %4zu of %4zu  translation %.4f ± %.4f m  rotation %.3f ± %.3f deg\n", name, e.used, e.relations, e.translation_mean_m,
              e.translation_std_m, e.rotation_mean_deg, e.rotation_std_deg);
}

// Each relation's error (t1 t2 translation_m rotation_deg), for finding where a trajectory goes wrong.
void dump_errors(const char* path, const std::vector<trajectory::Relation>& relations, const std::vector<trajectory::StampedPose>& poses) {
  std::map<std::int64_t, Pose2> at;
  for (const trajectory::StampedPose& p : poses) at.emplace(p.stamp_us, p.pose);
  std::FILE* f = std::fopen(path, "w");
  if (!f) return;
  for (const trajectory::Relation& r : relations) {
    const auto a = at.find(r.t1_us), b = at.find(r.t2_us);
    if (a == at.end() || b == at.end()) continue;
    const Pose2 e = r.t1_from_t2.inverse() * (a->second.inverse() * b->second);
    std::fprintf(f, "%lld %lld %.5f %.4f\n", static_cast<long long>(r.t1_us), static_cast<long long>(r.t2_us), std::hypot(e.x_m, e.y_m),
                 std::abs(e.theta_rad) * 180.0 / kPi);
  }
  std::fclose(f);
}

void BM_IntelPoseGraph(benchmark::State& state) {
  const char* n = std::getenv("TEAMSCAN_BENCH_SLAM_SCANS");
  // FLASER beams 180°/n apart from −90° (`import carmen --flaser-step-fov-over-n`), which fits this log best;
  // TEAMSCAN_BENCH_SLAM_BEAMS: 0 end to end, 1 180°/n from −90°, 2 180°/n centred.
  const char* beams = std::getenv("TEAMSCAN_BENCH_SLAM_BEAMS");
  const test::CarmenLogScans log = test::intel_log(n ? static_cast<std::size_t>(std::atol(n)) : SIZE_MAX,
                                             static_cast<test::FlaserBeams>(beams ? std::atoi(beams) : 1));
  const Result<std::string> rel = read_log_text(teamscan::test::real_data_path("intel.relations"));
  if (log.points.empty() || !rel) {
    state.SkipWithError("intel.clf.xz or intel.relations not readable");
    return;
  }
  const std::vector<trajectory::Relation> all = trajectory::parse_relations(rel.value()).relations;
  std::vector<trajectory::Relation> near, revisit;
  for (const trajectory::Relation& r : all) (std::llabs(r.t2_us - r.t1_us) < 100'000'000 ? near : revisit).push_back(r);
  for (auto _ : state) {
    const double cpu0 = cpu_s();
    const auto wall0 = std::chrono::steady_clock::now();
    PlanarSlam slam(options_from_env());
    std::vector<std::size_t> nodes;
    for (std::size_t k = 0; k < log.points.size(); ++k) nodes.push_back(slam.add_scan(1, log.processing_ns[k], log.odometry[k], log.points[k]));
    slam.finish();
    const double cpu = cpu_s() - cpu0;
    const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - wall0).count();
    std::vector<trajectory::StampedPose> corrected, local, odometry;
    for (std::size_t k = 0; k < nodes.size(); ++k) {
      corrected.push_back({log.stamps_us[k], slam.pose(nodes[k])});
      local.push_back({log.stamps_us[k], slam.local_pose(nodes[k])});
      odometry.push_back({log.stamps_us[k], log.odometry[k]});
    }
    const SlamStats st = slam.stats();
    std::printf("%zu nodes (%zu standing still), %zu submaps (%zu retired), %zu searches, %zu followed, %zu closures (%zu from the second search), %zu optimisations; "
                "returns of %zu nodes kept; %.0f MB of grids, search levels and returns at the end; CPU %.1f s (all threads), wall %.1f s\n",
                st.nodes, st.still, st.submaps, st.retired, st.searches, st.tracked, st.closures, st.rematches, st.optimizations, st.kept_returns,
                static_cast<double>(st.memory_bytes) / 1e6, cpu, wall);
    print("odometry", trajectory::relation_errors(all, odometry));
    print("local SLAM, within 100 s", trajectory::relation_errors(near, local));
    print("pose graph", trajectory::relation_errors(all, corrected));
    print("  within 100 s", trajectory::relation_errors(near, corrected));
    print("  revisits", trajectory::relation_errors(revisit, corrected));
    if (const char* dump = std::getenv("TEAMSCAN_BENCH_SLAM_DUMP")) dump_errors(dump, all, corrected);
    const trajectory::RelationErrors e = trajectory::relation_errors(all, corrected);
    state.counters["translation_mm"] = 1e3 * e.translation_mean_m;
    state.counters["rotation_mdeg"] = 1e3 * e.rotation_mean_deg;
    state.counters["cpu_s"] = cpu;
    state.counters["wall_s"] = wall;
    state.counters["memory_mb"] = static_cast<double>(st.memory_bytes) / 1e6;
  }
}
BENCHMARK(BM_IntelPoseGraph)->Iterations(1)->Unit(benchmark::kSecond);

}  // namespace
}  // namespace teamscan::posegraph
