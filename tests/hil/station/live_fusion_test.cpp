// Live fusion: a teamscan-groundstation process fed by two test robots (DdsBridge in this
// process, loopback DDS) with a small labelled survey writes, on SIGTERM, a fused PCD whose per-point
// keep/remove decisions equal the offline evaluation (`teamscan eval`: the fusion core fed the data set
// in time order) run on the same survey as it goes over the wire (millimetres, microradians), and
// `teamscan eval SESSION` (the session folder read back). The teamscan/team topic carries the Kalman
// tracker's estimates of the poses it was sent.
#include <gtest/gtest.h>

#include <dds/dds.h>

#include <chrono>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <thread>
#include <tuple>

#include "common/clock.hpp"
#include "common/dataset/pcd.hpp"
#include "groundstation/fusion/evaluation.hpp"
#include "groundstation/mapping/filter.hpp"
#include "groundstation/station/config.hpp"
#include "groundstation/station/fusion.hpp"
#include "groundstation/station/model_check.hpp"
#include "groundstation/station/session_replay.hpp"
#include "onboard/bridge/bridge.hpp"
#include "dds/qos.hpp"
#include "teamscan.h"
#include "tests/bench/mapping/synthetic_survey.hpp"
#include "tests/hil/station/process.hpp"
#include "tests/hil/station/robot_bridges.hpp"
#include "tests/support/test_domain.hpp"

namespace teamscan {
namespace {

using namespace std::chrono_literals;

std::int32_t mm(double m) { return static_cast<std::int32_t>(std::lround(m * 1000.0)); }

// The survey shifted to recent CLOCK_REALTIME stamps (so the team publication's prediction is short).
Dataset make_survey(std::int64_t base_ns) {
  bench::SurveyOptions o;
  o.duration_s = 4.0;
  o.room_m = 6.0;
  o.seed = 11;
  Dataset d = bench::synthetic_survey(o);
  for (auto& s : d.scans) s.stamp_ns += base_ns;
  for (auto& s : d.odom) s.stamp_ns += base_ns;
  return d;
}

// What the station can know: every value as it crosses the wire, in the station's own unit conversion.
Dataset as_received(const Dataset& d) {
  Dataset q = d;
  for (TrajectorySample& s : q.odom) {
    const std::int32_t vx = mm(s.v_mps * std::cos(s.pose.theta_rad)), vy = mm(s.v_mps * std::sin(s.pose.theta_rad));
    s.pose = Pose2{mm(s.pose.x_m) * 1e-3, mm(s.pose.y_m) * 1e-3,
                   static_cast<std::int32_t>(std::lround(s.pose.theta_rad * 1e6)) * 1e-6};
    s.v_mps = forward_speed_mps(vx * 1e-3, vy * 1e-3, s.pose.theta_rad);
  }
  for (ScanRecord& r : q.scans) {
    r.origin = {mm(r.origin.x) * 1e-3, mm(r.origin.y) * 1e-3, mm(r.origin.z) * 1e-3};
    r.pose = Pose2{mm(r.pose.x_m) * 1e-3, mm(r.pose.y_m) * 1e-3,
                   static_cast<std::int32_t>(std::lround(r.pose.theta_rad * 1e6)) * 1e-6};
  }
  for (LabelledPoint& p : q.points) {
    p.x = static_cast<float>(mm(p.x) * 1e-3);
    p.y = static_cast<float>(mm(p.y) * 1e-3);
    p.z = static_cast<float>(mm(p.z) * 1e-3);
  }
  return q;
}

std::size_t csv_rows(const std::string& path) {
  std::ifstream in(path);
  std::string line;
  std::size_t n = 0;
  while (std::getline(in, line))
    if (!line.empty() && line[0] != '#' && line.rfind("recv", 0) != 0 && line.rfind("robot", 0) != 0) ++n;
  return n;
}

struct Robots {
  std::vector<onboard::DdsBridge> bridges;
};

// Publishes the survey in time order: each robot's odometry pose at the stamp, then its scan. Pose seqs
// and the rows awaited in poses.csv count on from `poses_before` (a survey published in parts).
void publish_survey(Robots& robots, const Dataset& d, const std::string& poses_csv, std::size_t poses_before = 0) {
  static ScanPoints scan;
  std::map<std::pair<std::uint8_t, std::uint32_t>, std::vector<const LabelledPoint*>> points;
  for (const LabelledPoint& p : d.points) points[{p.robot, p.scan}].push_back(&p);
  std::size_t next_odom = 0;
  std::vector<ScanRecord> scans = d.scans;
  std::stable_sort(scans.begin(), scans.end(),
                   [](const ScanRecord& a, const ScanRecord& b) { return std::tie(a.stamp_ns, a.robot) < std::tie(b.stamp_ns, b.robot); });
  for (const ScanRecord& r : scans) {
    while (next_odom < d.odom.size() && d.odom[next_odom].stamp_ns <= r.stamp_ns) {
      const TrajectorySample& s = d.odom[next_odom++];
      onboard::OnboardPose pose;
      pose.robot_id = s.robot;
      pose.seq = static_cast<std::uint32_t>(poses_before + next_odom);
      pose.stamp_ns = s.stamp_ns;
      pose.x_mm = mm(s.pose.x_m);
      pose.y_mm = mm(s.pose.y_m);
      pose.yaw_urad = static_cast<std::int32_t>(std::lround(s.pose.theta_rad * 1e6));
      pose.vx_mmps = mm(s.v_mps * std::cos(s.pose.theta_rad));
      pose.vy_mmps = mm(s.v_mps * std::sin(s.pose.theta_rad));
      pose.yaw_rate_mradps = mm(s.w_radps);
      ASSERT_TRUE(robots.bridges[s.robot - 1u].publish_pose(pose).ok());
      // teamscan/pose is keep-last 1: wait until the station has stored this pose before sending the
      // next, so a loaded machine cannot make the station miss one (bounded: 10 s per pose).
      const auto deadline = std::chrono::steady_clock::now() + 10s;
      while (csv_rows(poses_csv) < poses_before + next_odom && std::chrono::steady_clock::now() < deadline)
        std::this_thread::sleep_for(1ms);
    }
    scan.robot_id = r.robot;
    scan.seq = r.scan + 1;  // onboard seq counts from 1
    scan.stamp = Time::from_ns(r.stamp_ns);
    scan.origin_x_mm = mm(r.origin.x);
    scan.origin_y_mm = mm(r.origin.y);
    scan.origin_z_mm = mm(r.origin.z);
    scan.count = 0;
    for (const LabelledPoint* p : points[{r.robot, r.scan}]) {
      scan.points[scan.count++] = ScanPoint{mm(p->x), mm(p->y), mm(p->z), p->beam, 0};
    }
    ASSERT_TRUE(robots.bridges[r.robot - 1u].publish_scan(scan).ok());
  }
  for (auto& b : robots.bridges) ASSERT_TRUE(b.wait_for_scan_acks(from_seconds(20.0)).ok());
}

// A teamscan/map viewer: merges every update into its own map (an update carries the changed voxels
// with their whole counts, or the whole map: total_voxels == its length), as a live viewer does.
class MapViewer {
 public:
  MapViewer() {
    participant_ = dds_create_participant(test::test_domain_id(), nullptr, nullptr);
    const dds_entity_t topic = dds_create_topic(participant_, &teamscan_msg_MapUpdate_desc, dds::kTopicMap, nullptr, nullptr);
    dds_qos_t* q = dds::make_map_qos();
    reader_ = dds_create_reader(participant_, topic, q, nullptr);
    dds_delete_qos(q);
  }
  ~MapViewer() { (void)dds_delete(participant_); }
  MapViewer(const MapViewer&) = delete;
  MapViewer& operator=(const MapViewer&) = delete;
  // Takes everything available; returns true if an update arrived.
  bool take() {
    void* samples[8] = {};
    dds_sample_info_t infos[8];
    const int n = dds_take(reader_, samples, infos, 8, 8);
    bool got = false;
    for (int i = 0; i < n; ++i) {
      if (!infos[i].valid_data) continue;
      const auto* m = static_cast<const teamscan_msg_MapUpdate*>(samples[i]);
      got = true;
      resolution_mm = m->resolution_mm;
      total_voxels = m->total_voxels;
      if (m->total_voxels == m->voxels._length) {
        map.clear();
        ++full_updates;
      }
      for (std::uint32_t k = 0; k < m->voxels._length; ++k) {
        const teamscan_msg_MapVoxel& v = m->voxels._buffer[k];
        map[{v.x_mm, v.y_mm, v.z_mm}] = {v.hits, v.flags};
      }
    }
    if (n > 0) (void)dds_return_loan(reader_, samples, n);
    voxels = static_cast<std::uint32_t>(map.size());
    hits = flagged = 0;
    for (const auto& [key, value] : map) {
      hits += value.first;
      flagged += value.second;
    }
    return got;
  }
  std::map<std::tuple<std::int32_t, std::int32_t, std::int32_t>, std::pair<std::uint32_t, std::uint32_t>> map;
  std::uint64_t full_updates = 0;
  std::uint32_t resolution_mm = 0, total_voxels = 0, voxels = 0;
  std::uint64_t hits = 0, flagged = 0;

 private:
  dds_entity_t participant_ = -1;
  dds_entity_t reader_ = -1;
};

class LiveFusion : public ::testing::TestWithParam<const char*> {};

TEST_P(LiveFusion, FinalPcdEqualsOfflineEvalAndTeamTopicCarriesTheTracker) {
  const std::string method = GetParam();
  char tmpl[] = "/tmp/teamscan-station-live-XXXXXX";
  const std::string root = ::mkdtemp(tmpl);
  const std::string session = root + "/session";
  const std::string config = root + "/gs.toml";
  {
    std::ofstream c(config);
    c << "[team.kalman]\nlost_after_s = 60.0\n"
      << "[fusion]\nmethod = \"" << method << "\"\nwrite_interval_s = 0.0\nwrite_all_points = true\n"
      << "map_interval_s = 0.5\nmax_points_per_voxel = 100000\n"  // every point in the model, compared below
      // Compared with the core's decisions on the robots' own poses; a station on the pose graph (its
      // default) against eval: LiveFusionCompared below.
      << "[pose_graph]\nenabled = false\n";
  }
  const std::int64_t base_ns = now_realtime().ns() - 4'000'000'000;
  const Dataset survey = make_survey(base_ns);
  const Dataset wire = as_received(survey);

  MapViewer viewer;
  Robots robots;
  test::start_robot_bridges(robots.bridges);
  ASSERT_FALSE(::testing::Test::HasFatalFailure());
  ASSERT_FALSE(::testing::Test::HasFatalFailure());
  test::ChildProcess gs({TEAMSCAN_GROUNDSTATION, "--config", config, "--session-dir", session, "--domain",
                         test::test_domain_arg()});
  for (auto& b : robots.bridges) {
    const auto deadline = std::chrono::steady_clock::now() + 15s;
    while (b.scan_subscribers() < 1 && std::chrono::steady_clock::now() < deadline) std::this_thread::sleep_for(10ms);
    ASSERT_EQ(b.scan_subscribers(), 1u);
  }
  std::this_thread::sleep_for(200ms);  // pose reader matched too
  publish_survey(robots, survey, session + "/poses.csv");

  // teamscan/team: every robot's estimate equals the tracker fed with the same poses, predicted to valid_ns.
  mapping::TrackerOptions tracker;
  tracker.lost_after_s = 60.0;
  mapping::TeamTracker reference_tracker(tracker);
  for (const TrajectorySample& s : wire.odom) reference_tracker.add_pose(s.robot, s.stamp_ns, s.pose, s.v_mps);
  const std::int64_t last_stamp = wire.odom.back().stamp_ns;
  onboard::TeamSnapshot team;
  bool got_team = false;
  const auto team_deadline = std::chrono::steady_clock::now() + 10s;
  while (!got_team && std::chrono::steady_clock::now() < team_deadline) {
    if (robots.bridges[0].take_team(team) && team.count == 2 && team.members[0].valid_ns > last_stamp + 100'000'000) {
      got_team = true;
    } else {
      std::this_thread::sleep_for(20ms);
    }
  }
  ASSERT_TRUE(got_team);
  for (std::uint32_t i = 0; i < team.count; ++i) {
    const onboard::TeamMemberState& m = team.members[i];
    const mapping::TeamState predicted = reference_tracker.predict(m.valid_ns);
    const mapping::RobotEstimate* e = predicted.find(static_cast<std::uint8_t>(m.robot_id));
    ASSERT_NE(e, nullptr);
    EXPECT_FALSE(m.lost);
    EXPECT_NEAR(m.x_mm, e->position_m.x * 1000.0, 1.0) << "robot " << m.robot_id;
    EXPECT_NEAR(m.y_mm, e->position_m.y * 1000.0, 1.0) << "robot " << m.robot_id;
    EXPECT_NEAR(m.cov_xx, e->position_cov_m2(0, 0) * 1e6, 1e-3 * e->position_cov_m2(0, 0) * 1e6 + 1e-3);
    EXPECT_NEAR(m.cov_yy, e->position_cov_m2(1, 1) * 1e6, 1e-3 * e->position_cov_m2(1, 1) * 1e6 + 1e-3);
    EXPECT_GT(m.length_mm, 0);
  }

  // teamscan/map: the merged updates (changes, and a full map every 10th) account for every point
  // (map_interval_s = 0.5).
  bool map_complete = false;
  const auto map_deadline = std::chrono::steady_clock::now() + 10s;
  while (!map_complete && std::chrono::steady_clock::now() < map_deadline) {
    if (viewer.take() && viewer.hits == wire.points.size()) map_complete = true;
    std::this_thread::sleep_for(20ms);
  }
  EXPECT_TRUE(map_complete) << "last map update: " << viewer.hits << " hits of " << wire.points.size();
  EXPECT_EQ(viewer.resolution_mm, 100u);
  EXPECT_EQ(viewer.total_voxels, viewer.voxels);
  EXPECT_GT(viewer.voxels, 0u);
  gs.signal(SIGTERM);
  const auto st = gs.wait(30s);
  ASSERT_TRUE(st.has_value());
  EXPECT_TRUE(WIFEXITED(*st) && WEXITSTATUS(*st) == 0);

  // Storage first: every pose and scan is in the session.
  EXPECT_EQ(csv_rows(session + "/poses.csv"), wire.odom.size());

  // The offline evaluation on the same data.
  mapping::MethodOptions options;  // the config's defaults: resolution 0.1 m, half-angle 7°
  options.frequency.resolution_m = options.visibility.resolution_m = 0.1;
  const std::vector<std::uint8_t> removed = fusion::decide_through_core(wire, method, options, tracker).value();

  auto all = read_pcd(session + "/fused_all.pcd");
  ASSERT_TRUE(all.ok()) << all.error().what;
  const int fr = all->field("robot"), fs = all->field("scan"), fb = all->field("beam"), fk = all->field("keep");
  ASSERT_TRUE(fr >= 0 && fs >= 0 && fb >= 0 && fk >= 0);
  std::map<std::tuple<int, int, int>, int> keep;
  for (std::size_t i = 0; i < all->size(); ++i) {
    keep[{static_cast<int>(all->columns[static_cast<std::size_t>(fr)][i]),
          static_cast<int>(all->columns[static_cast<std::size_t>(fs)][i]),
          static_cast<int>(all->columns[static_cast<std::size_t>(fb)][i])}] =
        static_cast<int>(all->columns[static_cast<std::size_t>(fk)][i]);
  }
  ASSERT_EQ(all->size(), wire.points.size());
  std::size_t kept = 0, ghosts_removed = 0, mismatches = 0;
  for (std::size_t i = 0; i < wire.points.size(); ++i) {
    const LabelledPoint& p = wire.points[i];
    auto it = keep.find({p.robot, static_cast<int>(p.scan + 1), p.beam});
    ASSERT_NE(it, keep.end()) << "point " << i << " missing from fused_all.pcd";
    const int expect_keep = removed[i] ? 0 : 1;
    if (it->second != expect_keep) ++mismatches;
    kept += static_cast<std::size_t>(expect_keep);
    if (p.is_ghost() && removed[i]) ++ghosts_removed;
  }
  EXPECT_EQ(mismatches, 0u);
  EXPECT_GT(ghosts_removed, 0u) << "the method removes nothing here: the comparison would be vacuous";
  auto fused = read_pcd(session + "/fused.pcd");
  ASSERT_TRUE(fused.ok());
  EXPECT_EQ(fused->size(), kept);
  EXPECT_FALSE(std::filesystem::exists(session + "/fused.pcd.tmp"));

  // The session folder read back (what `teamscan eval SESSION` reads) gives the same decisions.
  station::SessionReadStats read_stats;
  auto received = station::read_session_dataset(session, read_stats);
  ASSERT_TRUE(received.ok()) << received.error().what;
  ASSERT_EQ(received->points.size(), wire.points.size());
  const std::vector<std::uint8_t> removed_received = fusion::decide_through_core(received.value(), method, options, tracker).value();
  std::size_t received_mismatches = 0;
  for (std::size_t i = 0; i < received->points.size(); ++i) {
    const LabelledPoint& p = received->points[i];
    const int expect_keep = removed_received[i] ? 0 : 1;
    if (keep.at({p.robot, static_cast<int>(p.scan), p.beam}) != expect_keep) ++received_mismatches;
  }
  EXPECT_EQ(received_mismatches, 0u);
  if (std::getenv("GSLIVE_KEEP_SESSION") == nullptr) std::filesystem::remove_all(root);  // set: inspect by hand
}

INSTANTIATE_TEST_SUITE_P(Methods, LiveFusion, ::testing::Values("combined", "direction", "visibility"));

// The station deciding every method side by side (`best` primary, the seven others in
// [fusion] compare_methods), with periodic model writes off its loop, killed halfway and restarted on
// its session folder: each method's model file gives every point the decision `teamscan eval` of the
// session gives it with that method (model_check, the demo's identity check).
TEST(LiveFusionCompared, EveryMethodsModelEqualsEvalOfTheSessionAcrossARestart) {
  char tmpl[] = "/tmp/teamscan-station-compared-XXXXXX";
  const std::string root = ::mkdtemp(tmpl);
  const std::string session = root + "/session";
  const std::string config = root + "/gs.toml";
  {
    std::ofstream c(config);
    c << "[team.kalman]\nlost_after_s = 60.0\n"
      << "[fusion]\nmethod = \"best\"\ncompare_methods = [\"frequency\", \"visibility\", \"position\", \"direction\", "
         "\"combined\", \"freespace\", \"tracked\"]\nwrite_interval_s = 0.2\nwrite_all_points = true\n"
         "max_points_per_voxel = 100000\n"  // every point in the model: all of them are compared
      << "[view]\nlisten = \"\"\n";
  }
  station::GroundStationConfig cfg;
  station::ConfigError cerr;
  ASSERT_TRUE(station::load_groundstation_config(config, cfg, cerr)) << cerr.message;
  const station::FusionOptions& options = cfg.fusion;

  const std::int64_t base_ns = now_realtime().ns() - 4'000'000'000;
  const Dataset survey = make_survey(base_ns);
  // The survey in two parts at its middle stamp: before the kill, after the restart.
  const std::int64_t split_ns = survey.scans[survey.scans.size() / 2].stamp_ns;
  Dataset first = survey, second = survey;
  auto before = [&](std::int64_t t) { return t < split_ns; };
  std::erase_if(first.scans, [&](const ScanRecord& r) { return !before(r.stamp_ns); });
  std::erase_if(first.odom, [&](const TrajectorySample& s) { return !before(s.stamp_ns); });
  std::erase_if(second.scans, [&](const ScanRecord& r) { return before(r.stamp_ns); });
  std::erase_if(second.odom, [&](const TrajectorySample& s) { return before(s.stamp_ns); });
  ASSERT_FALSE(first.scans.empty());
  ASSERT_FALSE(second.scans.empty());

  Robots robots;
  test::start_robot_bridges(robots.bridges);
  ASSERT_FALSE(::testing::Test::HasFatalFailure());
  ASSERT_FALSE(::testing::Test::HasFatalFailure());
  auto start_station = [&] {
    return std::make_unique<test::ChildProcess>(std::vector<std::string>{
        TEAMSCAN_GROUNDSTATION, "--config", config, "--session-dir", session, "--domain", test::test_domain_arg()});
  };
  auto wait_subscribed = [&] {
    for (auto& b : robots.bridges) {
      const auto deadline = std::chrono::steady_clock::now() + 15s;
      while (b.scan_subscribers() < 1 && std::chrono::steady_clock::now() < deadline) std::this_thread::sleep_for(10ms);
      ASSERT_EQ(b.scan_subscribers(), 1u);
    }
    std::this_thread::sleep_for(200ms);  // pose reader matched too
  };
  {
    auto gs = start_station();
    wait_subscribed();
    publish_survey(robots, first, session + "/poses.csv");
    std::this_thread::sleep_for(1s);  // held scans released, periodic writes
    gs->signal(SIGKILL);              // a crash: no orderly shutdown, held scans lost
    ASSERT_TRUE(gs->wait(10s).has_value());
  }
  {
    auto gs = start_station();
    wait_subscribed();
    publish_survey(robots, second, session + "/poses.csv", first.odom.size());
    std::this_thread::sleep_for(500ms);
    gs->signal(SIGTERM);
    const auto st = gs->wait(60s);
    ASSERT_TRUE(st.has_value());
    EXPECT_TRUE(WIFEXITED(*st) && WEXITSTATUS(*st) == 0);
  }
  std::ifstream events(session + "/events.log");
  std::string line;
  std::size_t periodic = 0, rebuilt = 0;
  while (std::getline(events, line)) {
    if (line.find("fused model written (periodic)") != std::string::npos && line.find("8 models") != std::string::npos) ++periodic;
    if (line.find("fusion: rebuilt from the session folder") != std::string::npos) ++rebuilt;
  }
  EXPECT_GT(periodic, 0u) << "no periodic write off the loop was logged";
  EXPECT_EQ(rebuilt, 1u);

  std::vector<std::string> methods{options.core.method};
  methods.insert(methods.end(), options.compare_methods.begin(), options.compare_methods.end());
  ASSERT_EQ(methods.size(), 8u);
  for (const std::string& m : methods) {
    const station::FusionOptions om = station::compared_options(options, m);
    auto check = station::check_model_against_eval(session, om);
    ASSERT_TRUE(check.ok()) << m << ": " << check.error().what;
    EXPECT_EQ(check->compared, survey.points.size()) << m;
    EXPECT_EQ(check->not_in_model, 0u) << m;
    EXPECT_EQ(check->model_unknown, 0u) << m;
    EXPECT_EQ(check->mismatches, 0u) << m << ": " << check->mismatches << " of " << check->compared << " decisions differ";
    std::printf("[compared] %-10s %llu points, %llu decisions differ from `teamscan eval SESSION`\n", m.c_str(),
                static_cast<unsigned long long>(check->compared), static_cast<unsigned long long>(check->mismatches));
  }
  if (std::getenv("GSLIVE_KEEP_SESSION") == nullptr) std::filesystem::remove_all(root);
}

}  // namespace
}  // namespace teamscan
