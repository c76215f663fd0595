// The map catches up after a radio shadow (station/fusion.hpp FusionStage::catch_up): one robot of three
// is out of contact for two seconds of a survey (its scans kept on the robot, its poses of the shadow
// lost), then back-fills its scans behind its live ones. Its teammates' scans are released during the
// shadow without waiting for it; the back-filled ones are released out of stamp order; the station
// catches up once the back-fill is over, and its model files at the end are byte for byte those of the
// session fed through a core in `teamscan eval`'s time order (fusion/time_line.hpp). The catch-up in
// slices (FusionOptions::catch_up_slice_scans) ends with the cores the whole one in a single turn makes,
// and meanwhile the live scans are fused turn by turn.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iterator>
#include <map>
#include <memory>
#include <optional>
#include <set>
#include <sstream>
#include <thread>
#include <tuple>

#include "common/dataset/pcd.hpp"
#include "groundstation/fusion/graph_map.hpp"
#include "groundstation/fusion/model_writer.hpp"
#include "groundstation/fusion/time_line.hpp"
#include "groundstation/station/fusion.hpp"
#include "groundstation/station/model_check.hpp"
#include "groundstation/station/station.hpp"
#include "groundstation/station/session_replay.hpp"
#include "groundstation/station/session_store.hpp"
#include "groundstation/trajectory/tum.hpp"
#include "teamscan.h"
#include "tests/bench/mapping/synthetic_survey.hpp"
#include "tests/support/odometry_drift.hpp"

namespace teamscan::station {
namespace {

std::int32_t mm(double m) { return static_cast<std::int32_t>(std::lround(m * 1000.0)); }

std::string temp_dir() {
  char tmpl[] = "/tmp/teamscan-catch-up-XXXXXX";
  return ::mkdtemp(tmpl);
}

std::string file_bytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), {});
}

// One received sample: a pose (wire units) or a scan, at its receive time.
struct Sample {
  std::int64_t recv_ns = 0;
  bool is_pose = false;
  teamscan_msg_RobotPose pose{};
  ScanPoints scan{};
  Receipt receipt{};
};

struct Shadow {
  std::uint8_t robot = 2;
  std::int64_t from_ns = 0, to_ns = 0;           // stamps of the shadow
  std::int64_t backfill_period_ns = 20'000'000;  // one back-filled scan every 20 ms after it (5x live)
};

// The survey as the station receives it: a pose 20 ms after its stamp, a scan 5 ms after; the shadowed
// robot's poses of the shadow never, its scans of the shadow back-filled one by one from the shadow's end.
std::vector<Sample> received(const Dataset& d, const Shadow& sh) {
  std::vector<Sample> out;
  for (const TrajectorySample& s : d.odom) {
    if (s.robot == sh.robot && s.stamp_ns >= sh.from_ns && s.stamp_ns < sh.to_ns) continue;
    Sample x;
    x.is_pose = true;
    x.recv_ns = s.stamp_ns + 20'000'000;
    x.pose.robot_id = s.robot;
    x.pose.stamp_ns = s.stamp_ns;
    x.pose.x_mm = mm(s.pose.x_m);
    x.pose.y_mm = mm(s.pose.y_m);
    x.pose.yaw_urad = static_cast<std::int32_t>(std::lround(s.pose.theta_rad * 1e6));
    x.pose.vx_mmps = mm(s.v_mps * std::cos(s.pose.theta_rad));
    x.pose.vy_mmps = mm(s.v_mps * std::sin(s.pose.theta_rad));
    out.push_back(x);
  }
  std::int64_t backfill_ns = sh.to_ns + 300'000'000;
  for (const ScanRecord& r : d.scans) {
    Sample x;
    ScanPoints& s = x.scan;
    s.robot_id = r.robot;
    s.seq = r.scan + 1;
    s.stamp = Time::from_ns(r.stamp_ns);
    x.receipt.recv_realtime_ns = r.stamp_ns + 5'000'000;
    if (r.robot == sh.robot && r.stamp_ns >= sh.from_ns && r.stamp_ns < sh.to_ns) {
      x.receipt.recv_realtime_ns = backfill_ns;  // in seq order, behind the live ones
      backfill_ns += sh.backfill_period_ns;
    }
    s.origin_x_mm = mm(r.origin.x);
    s.origin_y_mm = mm(r.origin.y);
    s.origin_z_mm = mm(r.origin.z);
    for (const LabelledPoint& p : d.points)
      if (p.robot == r.robot && p.scan == r.scan) s.points[s.count++] = ScanPoint{mm(p.x), mm(p.y), mm(p.z), p.beam, 0};
    x.recv_ns = x.receipt.recv_realtime_ns;
    out.push_back(x);
  }
  std::stable_sort(out.begin(), out.end(), [](const Sample& a, const Sample& b) { return a.recv_ns < b.recv_ns; });
  return out;
}

// The station's loop over the samples: stored, then fused, then the loop's tick. `before` (optional) looks
// at the stage before each sample.
void run_station(const std::vector<Sample>& samples, SessionStore& store, FusionStage& stage,
                 const std::function<void(const Sample&)>& before = {}) {
  for (const Sample& x : samples) {
    if (before) before(x);
    if (x.is_pose) {
      store.append_pose(x.pose, ReceiveTime{Time::from_ns(x.recv_ns), Time::from_ns(x.recv_ns)});
      stage.add_pose(pose_observation(x.pose, Time::from_ns(x.recv_ns)));
    } else {
      store.append_scan(x.scan, x.receipt);
      stage.add_scan(x.scan, x.receipt);
    }
    stage.tick(x.recv_ns);  // the loop's turn
  }
  // A catch-up in slices still under way (its session read is on a thread of its own): the loop turns
  // on with the clock where it is until it is done.
  while (stage.catching_up()) {
    if (!stage.catch_up_has_work()) std::this_thread::sleep_for(std::chrono::milliseconds(1));
    stage.tick(samples.back().recv_ns);
  }
  store.sync();
}

// A station of `o` with its session folder `dir` that took `samples` (run_station); nullptr, with the
// test's failure added, if the folder or the stage could not be made.
std::unique_ptr<FusionStage> station_after(const FusionOptions& o, const std::string& dir, const std::vector<Sample>& samples) {
  auto store = SessionStore::open(dir);
  auto created = FusionStage::create(o, dir);
  if (!store.ok() || !created.ok()) {
    ADD_FAILURE() << "session folder or fusion stage: " << (!store.ok() ? store.error().what : created.error().what);
    return nullptr;
  }
  run_station(samples, *store, **created);
  return std::move(created.value());
}

// A station of `o` in `dir` that took the first half of `samples`, with its session store, so a test can
// look at it there and feed it the rest (run_station).
struct HalfWay {
  SessionStore store;
  std::unique_ptr<FusionStage> stage;
  std::size_t half = 0;  // the samples taken
};
std::optional<HalfWay> station_half_way(const FusionOptions& o, const std::string& dir, const std::vector<Sample>& samples) {
  auto store = SessionStore::open(dir);
  auto created = FusionStage::create(o, dir);
  if (!store.ok() || !created.ok()) {
    ADD_FAILURE() << "session folder or fusion stage: " << (!store.ok() ? store.error().what : created.error().what);
    return std::nullopt;
  }
  HalfWay h{std::move(store.value()), std::move(created.value()), samples.size() / 2};
  run_station({samples.begin(), samples.begin() + static_cast<std::ptrdiff_t>(h.half)}, h.store, *h.stage);
  return h;
}

// Three robots surveying a 6 m room for `duration_s`.
Dataset survey(double duration_s, std::uint64_t seed) {
  bench::SurveyOptions so;
  so.robots = 3;
  so.duration_s = duration_s;
  so.room_m = 6.0;
  so.seed = seed;
  return bench::synthetic_survey(so);
}

FusionOptions options() {
  FusionOptions o;
  o.core.method = "best";
  o.all_points_pcd = "fused_all.pcd";  // the model store at its default cap: its choice follows the order
  o.catch_up_min_scans = 10;
  return o;
}

TEST(CatchUp, AfterABackFillTheModelIsEvalsOfTheSessionByteForByte) {
  const Dataset d = survey(8.0, 7);
  ASSERT_FALSE(d.scans.empty());
  const std::int64_t t0 = d.scans.front().stamp_ns;
  const Shadow sh{2, t0 + 2'000'000'000, t0 + 4'500'000'000};
  const std::vector<Sample> samples = received(d, sh);
  const FusionOptions o = options();

  const std::string dir = temp_dir();
  auto store = SessionStore::open(dir);
  ASSERT_TRUE(store.ok());
  auto created = FusionStage::create(o, dir);
  ASSERT_TRUE(created.ok());
  FusionStage& stage = **created;
  std::uint64_t most_late = 0;
  bool checked_teammates = false;
  run_station(samples, *store, stage, [&](const Sample& x) {
    // The shadow is over and nothing was back-filled yet: the teammates' scans of the shadow were not
    // held for robot 2 (released by their poses, or by hold_s once robot 2 fell silent).
    if (!checked_teammates && x.recv_ns >= sh.to_ns + 300'000'000) {
      checked_teammates = true;
      for (std::uint8_t mate : {1, 3}) {
        std::uint64_t due = 0;
        for (const ScanRecord& r : d.scans)
          if (r.robot == mate && r.stamp_ns < sh.to_ns - 200'000'000) ++due;
        EXPECT_GE(stage.core().robot_counters(mate).scans_released, due) << "robot " << int{mate};
      }
    }
    most_late = std::max(most_late, stage.late_since_catch_up());
  });
  ASSERT_TRUE(checked_teammates);
  // The back-fill was released late, and caught up in the loop once it was over.
  EXPECT_GE(most_late, 10u);
  EXPECT_EQ(stage.counters().catch_ups, 1u);
  EXPECT_EQ(stage.late_since_catch_up(), 0u);
  // Everything is in the map once, whatever was fused twice meanwhile.
  stage.flush();
  EXPECT_EQ(stage.counters().scans, d.scans.size());
  ASSERT_TRUE(stage.write_model().ok());
  std::printf("catch-up: %llu scans replayed in %.3f s\n",
              static_cast<unsigned long long>(stage.counters().caught_up_scans), stage.counters().last_catch_up_s);

  // `teamscan eval` of the session: read back, fed in time order, the station's core options.
  SessionReadStats stats;
  auto session = read_session_dataset(dir, stats);
  ASSERT_TRUE(session.ok()) << session.error().what;
  EXPECT_EQ(session->scans.size(), d.scans.size());
  auto eval_core = fusion::FusionCore::create(o.core);
  ASSERT_TRUE(eval_core.ok());
  fusion::feed_in_time_order(session.value(), **eval_core);
  const std::string eval_dir = temp_dir();
  ASSERT_TRUE(fusion::write_model_files(**eval_core, eval_dir + "/fused.pcd", eval_dir + "/fused_all.pcd").ok());
  for (const char* name : {"fused.pcd", "fused_all.pcd"}) {
    const std::string live = file_bytes(dir + "/" + name), offline = file_bytes(eval_dir + "/" + name);
    EXPECT_GT(live.size(), 1000u) << name;
    EXPECT_TRUE(live == offline) << name << ": the station's " << live.size() << " bytes, eval's " << offline.size();
  }
  EXPECT_GT((*eval_core)->counters().capped_points, 0u);  // the cap chose points: the order mattered
  std::filesystem::remove_all(dir);
  std::filesystem::remove_all(eval_dir);
}

// Without the catch-up (the back-fill released as it came) the model is not eval's of the session: the
// test above is not vacuous.
TEST(CatchUp, ABackFillReleasedAsItCameIsNotEvalsModel) {
  const Dataset d = survey(8.0, 7);
  const std::int64_t t0 = d.scans.front().stamp_ns;
  const std::vector<Sample> samples = received(d, Shadow{2, t0 + 2'000'000'000, t0 + 4'500'000'000});
  FusionOptions o = options();
  o.catch_up_min_scans = 0;  // never in the loop
  const std::string dir = temp_dir();
  const std::unique_ptr<FusionStage> ran = station_after(o, dir, samples);
  ASSERT_NE(ran, nullptr);
  FusionStage& stage = *ran;
  EXPECT_EQ(stage.counters().catch_ups, 0u);
  EXPECT_GT(stage.late_since_catch_up(), 10u);
  stage.core().flush();  // the core as it is, no catch-up
  ASSERT_TRUE(fusion::write_model_files(stage.core(), dir + "/live.pcd", dir + "/live_all.pcd").ok());
  SessionReadStats stats;
  auto session = read_session_dataset(dir, stats);
  ASSERT_TRUE(session.ok());
  auto eval_core = fusion::FusionCore::create(o.core);
  ASSERT_TRUE(eval_core.ok());
  fusion::feed_in_time_order(session.value(), **eval_core);
  ASSERT_TRUE(fusion::write_model_files(**eval_core, dir + "/eval.pcd", dir + "/eval_all.pcd").ok());
  EXPECT_NE(file_bytes(dir + "/live_all.pcd"), file_bytes(dir + "/eval_all.pcd"));
  // The same points, chosen and decided differently.
  std::filesystem::remove_all(dir);
}

// A longer survey for the catch-up in slices: robot 2 of three out of contact for 4 s, its 40 scans of
// the shadow back-filled behind its live ones, the catch-up due 2 s after, 7 s of live scans after that.
Dataset long_survey() { return survey(16.0, 11); }

// The primary core's model files after every held scan was released (no catch-up at the end).
std::string primary_model_bytes(FusionStage& stage, const std::string& dir) {
  stage.core().flush();
  if (!fusion::write_model_files(stage.core(), dir + "/primary.pcd", dir + "/primary_all.pcd").ok()) return {};
  return file_bytes(dir + "/primary.pcd") + file_bytes(dir + "/primary_all.pcd");
}

// However the catch-up is sliced (a few scans per loop turn, or the whole one in one turn), the cores
// it leaves are the same: the rebuilt ones take the live inputs since it began in their order.
TEST(CatchUp, InSlicesTheCoresEndAsTheWholeCatchUpsInOneTurn) {
  const Dataset d = long_survey();
  const std::int64_t t0 = d.scans.front().stamp_ns;
  const std::vector<Sample> samples = received(d, Shadow{2, t0 + 2'000'000'000, t0 + 6'000'000'000});
  std::string models[2];
  std::uint64_t catch_ups[2] = {0, 0};
  for (int k = 0; k < 2; ++k) {
    FusionOptions o = options();
    o.catch_up_slice_scans = k == 0 ? 0 : 3;
    const std::string dir = temp_dir();
    const std::unique_ptr<FusionStage> ran = station_after(o, dir, samples);
    ASSERT_NE(ran, nullptr);
    FusionStage& stage = *ran;
    EXPECT_FALSE(stage.catching_up());
    catch_ups[k] = stage.counters().catch_ups;
    if (k == 1) {
      EXPECT_GT(stage.counters().catch_up_turns, 20u);  // in slices, over many turns
      EXPECT_GT(stage.counters().caught_up_live_scans, 0u);  // live scans came meanwhile
    }
    std::printf("slice %u: %llu catch-ups, the last %llu scans of the session + %llu live ones over %llu turns\n",
                o.catch_up_slice_scans, static_cast<unsigned long long>(stage.counters().catch_ups),
                static_cast<unsigned long long>(stage.counters().caught_up_scans),
                static_cast<unsigned long long>(stage.counters().caught_up_live_scans),
                static_cast<unsigned long long>(stage.counters().catch_up_turns));
    models[k] = primary_model_bytes(stage, dir);
    EXPECT_GT(models[k].size(), 1000u);
    std::filesystem::remove_all(dir);
  }
  EXPECT_EQ(catch_ups[0], 1u);
  EXPECT_EQ(catch_ups[1], catch_ups[0]);
  EXPECT_TRUE(models[0] == models[1]) << "the whole catch-up's model " << models[0].size() << " bytes, the sliced one's "
                                      << models[1].size();
}

// The station's robot<N>.graph.tum in `dir` (three robots) are byte for byte those of `teamscan eval` of
// the session: a core of `core` fed it in time order, its releases into a back end.
void expect_graph_is_evals(const std::string& dir, const fusion::CoreOptions& core, const std::string& what) {
  SessionReadStats stats;
  auto session = read_session_dataset(dir, stats);
  ASSERT_TRUE(session.ok()) << session.error().what;
  auto eval_core = fusion::FusionCore::create(fusion::with_graph_order(core));
  ASSERT_TRUE(eval_core.ok());
  fusion::GraphBackend eval_graph;
  (*eval_core)->set_release_callback([&](const fusion::FusedScan& f) { eval_graph.add(f); });
  fusion::feed_in_time_order(session.value(), **eval_core);
  std::map<std::uint8_t, std::vector<trajectory::StampedPose>> expected;
  for (const fusion::GraphScanPose& p : eval_graph.poses()) expected[p.robot].push_back({(p.stamp_ns + 500) / 1000, p.graph});
  ASSERT_EQ(expected.size(), 3u) << what;
  for (const auto& [robot, poses] : expected) {
    const std::string live = file_bytes(dir + "/robot" + std::to_string(robot) + ".graph.tum");
    EXPECT_GT(live.size(), 1000u) << what << " robot " << int{robot};
    EXPECT_TRUE(live == trajectory::tum_text(poses)) << what << " robot " << int{robot};
  }
}

// A robot's scans arriving out of their order by less than hold_s (its live writer's dropped scans
// back-filled a moment later, after the next one): released after teammates' later scans, not late, so
// no catch-up while the station runs, but the graph took them out of stamp order and is not the one
// eval's time order feeds. At the stop the station catches up in time order: its graph is eval's again.
TEST(CatchUp, ScansTheGraphTookOutOfStampOrderAreCaughtUpAtTheStop) {
  const Dataset d = survey(8.0, 7);
  std::vector<Sample> samples = received(d, Shadow{2, 0, 0});  // no shadow
  for (Sample& x : samples)
    if (!x.is_pose && x.scan.robot_id == 1 && x.scan.seq >= 40 && x.scan.seq <= 43) {
      x.recv_ns += 450'000'000;  // after scans 44–47, before hold_s
      x.receipt.recv_realtime_ns = x.recv_ns;
    }
  std::stable_sort(samples.begin(), samples.end(), [](const Sample& a, const Sample& b) { return a.recv_ns < b.recv_ns; });
  FusionOptions o = options();
  o.pose_graph = fusion::GraphBackendOptions{};  // no estimates: nothing followed
  const std::string dir = temp_dir();
  const std::unique_ptr<FusionStage> stage = station_after(o, dir, samples);
  ASSERT_NE(stage, nullptr);
  EXPECT_GT(stage->graph()->counters().out_of_stamp_order, 0u);
  EXPECT_GT(stage->core().counters().scans_out_of_stamp_order, 0u);
  EXPECT_EQ(stage->core().counters().scans_late, 0u) << "none late by hold_s";
  EXPECT_EQ(stage->counters().catch_ups, 0u);
  stage->flush();
  EXPECT_EQ(stage->counters().catch_ups, 1u) << "caught up at the stop";
  EXPECT_EQ(stage->graph()->counters().out_of_stamp_order, 0u) << "a new graph fed in time order";
  ASSERT_TRUE(stage->write_graph_trajectories().ok());
  expect_graph_is_evals(dir, o.core, "scans out of stamp order");
  std::filesystem::remove_all(dir);
}

// The pose graph follows the catch-up ([pose_graph]): after a back-fill, caught up in one turn or in
// slices, the station's robot<N>.graph.tum at the end are those of the back end fed `teamscan eval`'s
// time order of the session, byte for byte.
TEST(CatchUp, ThePoseGraphsTrajectoriesAreEvalsOfTheSession) {
  const Dataset d = survey(8.0, 7);
  const std::int64_t t0 = d.scans.front().stamp_ns;
  const std::vector<Sample> samples = received(d, Shadow{2, t0 + 2'000'000'000, t0 + 4'500'000'000});
  for (const std::uint32_t slice : {0u, 3u}) {
    FusionOptions o = options();
    o.catch_up_slice_scans = slice;
    o.pose_graph = fusion::GraphBackendOptions{};
    const std::string dir = temp_dir();
    const std::unique_ptr<FusionStage> ran = station_after(o, dir, samples);
    ASSERT_NE(ran, nullptr);
    FusionStage& stage = *ran;
    EXPECT_GE(stage.counters().catch_ups, 1u) << "slice " << slice;
    stage.flush();
    ASSERT_TRUE(stage.write_graph_trajectories().ok());
    ASSERT_NE(stage.graph(), nullptr);
    EXPECT_EQ(stage.graph()->counters().scans, d.scans.size()) << "every scan once, in the graph that took over";
    expect_graph_is_evals(dir, o.core, "slice " + std::to_string(slice));
    std::filesystem::remove_all(dir);
  }
}

// The final model follows the pose graph (FusionStage::rebuild_on_graph, the shutdown's last step with
// [pose_graph]): after a back-fill, every point of every core's fused_all.pcd sits
// where the graph put its scan (the correction from the robot's pose to the graph's applied to the point
// the robot placed), and every decision is `teamscan eval SESSION --pose-graph`'s (model_check). A session
// folder that cannot be read back leaves the cores as they were, with an error.
TEST(CatchUp, TheFinalModelFollowsThePoseGraph) {
  const Dataset d = survey(8.0, 7);
  const std::int64_t t0 = d.scans.front().stamp_ns;
  const std::vector<Sample> samples = received(d, Shadow{2, t0 + 2'000'000'000, t0 + 4'500'000'000});
  FusionOptions o = options();
  o.compare_methods = {"visibility"};
  o.pose_graph = fusion::GraphBackendOptions{};
  const std::string dir = temp_dir();
  const std::unique_ptr<FusionStage> ran = station_after(o, dir, samples);
  ASSERT_NE(ran, nullptr);
  FusionStage& stage = *ran;
  stage.flush();
  ASSERT_TRUE(stage.write_graph_trajectories().ok());
  ASSERT_TRUE(stage.rebuild_on_graph().ok());
  EXPECT_EQ(stage.counters().graph_rebuilds, 1u);
  EXPECT_EQ(stage.counters().scans, d.scans.size()) << "every scan in the rebuilt map once";
  EXPECT_EQ(stage.core().options().registration, false);
  ASSERT_TRUE(stage.write_model().ok());

  SessionReadStats stats;
  const Result<Dataset> session = read_session_dataset(dir, stats);
  ASSERT_TRUE(session.ok()) << session.error().what;
  std::map<std::pair<std::uint8_t, std::uint32_t>, Pose2> correction;  // (robot, seq) -> graph from robot's map
  for (const fusion::GraphScanPose& p : stage.graph()->poses())
    for (const ScanRecord& r : session->scans)
      if (r.robot == p.robot && r.scan == p.scan) correction[{p.robot, p.scan}] = p.graph * r.pose.inverse();
  ASSERT_EQ(correction.size(), d.scans.size());
  for (const std::string& method : {std::string("best"), std::string("visibility")}) {
    const FusionOptions mo = compared_options(o, method);
    const Result<PcdCloud> model = read_pcd(dir + "/" + mo.all_points_pcd);
    ASSERT_TRUE(model.ok()) << model.error().what;
    const PcdCloud& c = model.value();
    const int fr = c.field("robot"), fs = c.field("scan"), fb = c.field("beam");
    ASSERT_TRUE(fr >= 0 && fs >= 0 && fb >= 0);
    std::map<std::uint64_t, std::size_t> row;
    for (std::size_t i = 0; i < c.size(); ++i)
      row[point_key(static_cast<std::uint32_t>(c.columns[static_cast<std::size_t>(fr)][i]),
                    static_cast<std::uint32_t>(c.columns[static_cast<std::size_t>(fs)][i]),
                    static_cast<std::uint32_t>(c.columns[static_cast<std::size_t>(fb)][i]))] = i;
    double worst_m = 0.0, moved_m = 0.0;
    std::size_t found = 0;
    for (const LabelledPoint& p : session->points) {
      const auto it = row.find(point_key(p.robot, p.scan, p.beam));
      if (it == row.end()) continue;
      ++found;
      const Pose2& m = correction.at({p.robot, p.scan});
      const double x = m.x_m + std::cos(m.theta_rad) * p.x - std::sin(m.theta_rad) * p.y;
      const double y = m.y_m + std::sin(m.theta_rad) * p.x + std::cos(m.theta_rad) * p.y;
      const std::size_t i = it->second;
      const double mx = c.xyz[3 * i], my = c.xyz[3 * i + 1], mz = c.xyz[3 * i + 2];
      worst_m = std::max({worst_m, std::abs(mx - x), std::abs(my - y), std::abs(mz - double{p.z})});
      moved_m = std::max(moved_m, std::hypot(mx - double{p.x}, my - double{p.y}));
    }
    EXPECT_EQ(found, c.size()) << method << ": every model point is a session point";
    EXPECT_LT(worst_m, 1e-4) << method << ": a point off the graph's pose of its scan";
    // The graph moves these scans by about a millimetre (the room is small, the survey short): still five
    // times the tolerance above, so a model left on the robots' poses fails it (lap2-drift's metres:
    // e2e_registration_demo_test).
    EXPECT_GT(moved_m, 5e-4) << method << ": the graph moved no point";
    EXPECT_GT(moved_m, 5.0 * worst_m) << method;
    const Result<ModelCheck> check = check_model_against_eval(dir, mo);
    ASSERT_TRUE(check.ok()) << check.error().what;
    EXPECT_EQ(check->compared, check->model_points) << method;
    EXPECT_EQ(check->mismatches, 0u) << method << ": decisions unlike `teamscan eval SESSION --pose-graph`'s";
    std::printf("%s: %zu points on the graph's poses (moved up to %.4f m), %llu decisions as eval's; rebuilt in %.3f s\n",
                method.c_str(), found, moved_m, static_cast<unsigned long long>(check->compared), stage.counters().last_graph_rebuild_s);
  }
  // The folder gone: an error, the cores as they were.
  std::filesystem::remove_all(dir);
  const std::uint64_t scans = stage.counters().scans;
  EXPECT_FALSE(stage.rebuild_on_graph().ok());
  EXPECT_EQ(stage.counters().graph_rebuilds, 1u);
  EXPECT_EQ(stage.counters().scans, scans);
}

// Where the model file puts each (robot, scan, beam): its row in `c`.
std::map<std::uint64_t, std::size_t> model_rows(const PcdCloud& c) {
  const int fr = c.field("robot"), fs = c.field("scan"), fb = c.field("beam");
  std::map<std::uint64_t, std::size_t> row;
  if (fr < 0 || fs < 0 || fb < 0) return row;
  for (std::size_t i = 0; i < c.size(); ++i)
    row[point_key(static_cast<std::uint32_t>(c.columns[static_cast<std::size_t>(fr)][i]),
                  static_cast<std::uint32_t>(c.columns[static_cast<std::size_t>(fs)][i]),
                  static_cast<std::uint32_t>(c.columns[static_cast<std::size_t>(fb)][i]))] = i;
  return row;
}

// The survey as received, robot 2's odometry drifting from its start (tests/support/odometry_drift.hpp).
std::vector<Sample> drifting_survey() {
  Dataset d = survey(8.0, 7);
  test::add_odometry_drift(d, 2, d.scans.front().stamp_ns);
  return received(d, Shadow{2, 0, 0});  // no shadow
}

// options() with the graph publishing an estimate whenever it took a node, each one followed rigidly.
FusionOptions following_options() {
  FusionOptions o = options();
  fusion::GraphBackendOptions graph_options;
  graph_options.estimate_every_s = 1e-3;
  o.pose_graph = graph_options;
  o.exact_follow_share = 0.0;
  return o;
}

// Until the graph took every node closed so far and published an estimate (at most until `deadline`).
void wait_for_estimate(FusionStage& stage, std::chrono::steady_clock::time_point deadline) {
  while ((stage.graph()->queued() > 0 || !stage.graph()->latest()) && std::chrono::steady_clock::now() < deadline)
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
}

// The live map follows the pose graph ([pose_graph] follow_s: GraphBackendOptions::estimate_every_s):
// once the graph published an estimate, the station's cores are rebuilt on its poses in slices and take
// over, without the registration: every point of the model of a scan the estimate holds sits where the
// estimate put that scan. The graph is fed on, and at the end its trajectories are those of a graph fed
// `teamscan eval`'s time order of the session, byte for byte: following it fed it nothing of its own.
TEST(CatchUp, TheLiveMapFollowsThePoseGraph) {
  const Dataset d = survey(8.0, 7);
  const std::vector<Sample> samples = received(d, Shadow{2, 0, 0});  // no shadow
  FusionOptions o = following_options();
  o.core.registration = true;
  o.follow_rigidly = false;  // each estimate: the session decided again on its poses
  o.catch_up_slice_scans = 8;
  const std::string dir = temp_dir();
  std::optional<HalfWay> run = station_half_way(o, dir, samples);
  ASSERT_TRUE(run);
  FusionStage& stage = *run->stage;
  EXPECT_EQ(stage.counters().catch_ups, 0u);
  // The graph's thread publishes its estimates as it takes the nodes: wait until it took those closed so
  // far; the loop's turns then rebuild the cores on the newest estimate.
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(60);
  while ((stage.graph()->queued() > 0 || !stage.graph()->latest()) && std::chrono::steady_clock::now() < deadline)
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  while (stage.counters().graph_follows == 0 && std::chrono::steady_clock::now() < deadline) {
    if (!stage.catch_up_has_work()) std::this_thread::sleep_for(std::chrono::milliseconds(1));
    stage.tick(samples[run->half - 1].recv_ns);
  }
  ASSERT_GE(stage.counters().graph_follows, 1u) << "no estimate followed within 60 s";
  const std::shared_ptr<const fusion::GraphEstimate> estimate = stage.followed_estimate();
  ASSERT_NE(estimate, nullptr);
  EXPECT_FALSE(stage.core().options().registration) << "the graph places the scans now";
  EXPECT_EQ(stage.counters().catch_ups, 0u) << "a follow is not a catch-up";
  run->store.sync();
  ASSERT_TRUE(stage.write_model().ok());
  {
    SessionReadStats stats;
    const Result<Dataset> session = read_session_dataset(dir, stats);
    ASSERT_TRUE(session.ok()) << session.error().what;
    std::map<std::pair<std::uint8_t, std::uint32_t>, Pose2> correction;  // (robot, seq) -> graph from robot's map
    const std::vector<fusion::GraphScanPose> poses = estimate->poses();
    for (const fusion::GraphScanPose& p : poses)
      for (const ScanRecord& r : session->scans)
        if (r.robot == p.robot && r.scan == p.scan) correction[{p.robot, p.scan}] = p.graph * r.pose.inverse();
    EXPECT_EQ(correction.size(), poses.size());
    EXPECT_GE(correction.size(), 10u) << "the estimate holds the scans of its nodes";
    const Result<PcdCloud> model = read_pcd(dir + "/" + o.all_points_pcd);
    ASSERT_TRUE(model.ok()) << model.error().what;
    const PcdCloud& c = model.value();
    const std::map<std::uint64_t, std::size_t> row = model_rows(c);
    double worst_m = 0.0, moved_m = 0.0;
    std::size_t on_estimate = 0;
    for (const LabelledPoint& p : session->points) {
      const auto it = row.find(point_key(p.robot, p.scan, p.beam));
      const auto m = correction.find({p.robot, p.scan});
      if (it == row.end() || m == correction.end()) continue;
      ++on_estimate;
      const Pose2& k = m->second;
      const double x = k.x_m + std::cos(k.theta_rad) * p.x - std::sin(k.theta_rad) * p.y;
      const double y = k.y_m + std::sin(k.theta_rad) * p.x + std::cos(k.theta_rad) * p.y;
      const std::size_t i = it->second;
      worst_m = std::max({worst_m, std::abs(c.xyz[3 * i] - x), std::abs(c.xyz[3 * i + 1] - y), std::abs(c.xyz[3 * i + 2] - double{p.z})});
      moved_m = std::max(moved_m, std::hypot(c.xyz[3 * i] - double{p.x}, c.xyz[3 * i + 1] - double{p.y}));
    }
    EXPECT_GT(on_estimate, 1000u);
    EXPECT_LT(worst_m, 1e-4) << "a live point off the estimate's pose of its scan";
    EXPECT_GT(moved_m, 5.0 * worst_m) << "the estimate moved no point";
    std::printf("followed estimate %llu (%zu nodes, %zu closures): %zu live points on its poses (moved up to %.4f m)\n",
                static_cast<unsigned long long>(estimate->version), estimate->nodes, estimate->closures, on_estimate, moved_m);
  }
  // The rest of the survey: the live map follows on; the graph is the one eval's time order feeds.
  run_station({samples.begin() + static_cast<std::ptrdiff_t>(run->half), samples.end()}, run->store, stage);
  stage.flush();
  ASSERT_TRUE(stage.write_graph_trajectories().ok());
  EXPECT_EQ(stage.counters().catch_ups, 0u);
  EXPECT_EQ(stage.graph()->counters().scans, d.scans.size()) << "every scan once";
  // Teammates' returns were left out of the graph (where their odometry places them, whatever the map
  // followed), and the graph is still eval's.
  EXPECT_GT(stage.graph()->counters().returns.teammates, 0u);
  expect_graph_is_evals(dir, o.core, "following");
  std::printf("%llu follows; the graph took %llu scans (%llu again from a rebuilt core, ignored), %llu returns on teammates left out\n",
              static_cast<unsigned long long>(stage.counters().graph_follows),
              static_cast<unsigned long long>(stage.graph()->counters().scans),
              static_cast<unsigned long long>(stage.graph()->counters().repeated_scans),
              static_cast<unsigned long long>(stage.graph()->counters().returns.teammates));
  std::filesystem::remove_all(dir);
}

// Rigidly (FusionOptions::follow_rigidly, the default once the registration does not place the scans):
// robot 2's odometry drifts; once the graph published an estimate, the loop's turns move every core's
// model onto it a slice at a time, with no session read. After the follow every model point of a scan in
// the estimate lies where the estimate puts its scan (graph · odom⁻¹ of the point as the robot placed
// it), every other where its robot's newest scan in the estimate puts it (the tail correction, which the
// scans released since were placed with and the robots are handed), the live map is that model binned,
// and at the end the graph is still eval's.
TEST(CatchUp, TheLiveMapFollowsThePoseGraphRigidly) {
  const std::vector<Sample> samples = drifting_survey();
  FusionOptions o = following_options();
  o.compare_methods = {"visibility"};  // every core's model moves
  o.catch_up_slice_scans = 8;
  o.write_slice_ms = 0.0;  // the move in its smallest steps, over many turns
  o.follow_min_shift_m = 0.0;  // this survey's graph moves scans by a millimetre: every estimate is followed
  ASSERT_TRUE(o.follow_rigidly);
  const std::string dir = temp_dir();
  std::optional<HalfWay> run = station_half_way(o, dir, samples);
  ASSERT_TRUE(run);
  FusionStage& stage = *run->stage;
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(60);
  wait_for_estimate(stage, deadline);
  // The loop's turns until the graph's newest estimate is followed (the graph takes no more nodes, so
  // it publishes no newer one): the follows on the way moved the model from one estimate to the next.
  std::uint64_t turns_following = 0;
  auto behind = [&] { return stage.following() || !stage.followed_estimate() || stage.followed_estimate()->version != stage.graph()->latest()->version; };
  while (behind() && std::chrono::steady_clock::now() < deadline) {
    if (stage.following()) ++turns_following;
    else std::this_thread::sleep_for(std::chrono::milliseconds(1));
    stage.tick(samples[run->half - 1].recv_ns);
  }
  ASSERT_FALSE(behind()) << "the newest estimate not followed within 60 s";
  EXPECT_GE(stage.counters().rigid_follows, 2u) << "follows one after the other while the robots mapped";
  EXPECT_EQ(stage.counters().graph_follows, stage.counters().rigid_follows) << "rigid follows, no rebuild";
  EXPECT_EQ(stage.counters().catch_ups, 0u);
  EXPECT_EQ(stage.counters().follow_failures, 0u);
  EXPECT_GT(stage.counters().follow_turns, 2u) << "the move is spread over the loop's turns";
  EXPECT_GT(stage.counters().follow_moved_points, 1000u);
  const std::shared_ptr<const fusion::GraphEstimate> estimate = stage.followed_estimate();
  ASSERT_NE(estimate, nullptr);

  std::map<std::pair<std::uint8_t, std::uint32_t>, Pose2> correction;  // (robot, seq) -> graph · odom⁻¹
  std::map<std::uint8_t, std::pair<std::int64_t, Pose2>> tail;          // robot -> its newest scan's
  for (const fusion::GraphScanPose& p : estimate->poses()) {
    correction[{p.robot, p.scan}] = p.graph * p.odom.inverse();
    auto [it, added] = tail.try_emplace(p.robot, p.stamp_ns, p.graph * p.odom.inverse());
    if (!added && p.stamp_ns > it->second.first) it->second = {p.stamp_ns, p.graph * p.odom.inverse()};
  }
  ASSERT_EQ(tail.size(), 3u);
  std::map<std::uint64_t, const LabelledPoint*> placed;  // as the robot placed it: the session's point
  SessionReadStats stats;
  const Result<Dataset> session = read_session_dataset(dir, stats);
  ASSERT_TRUE(session.ok()) << session.error().what;
  for (const LabelledPoint& p : session->points) placed[point_key(p.robot, p.scan, p.beam)] = &p;
  for (std::size_t c = 0; c < 2; ++c) {
    const fusion::FusionCore& core = c == 0 ? stage.core() : *stage.compared_core("visibility");
    double worst_m = 0.0, moved_m = 0.0;
    std::size_t on_estimate = 0, on_tail = 0, unknown = 0;
    core.for_each_model_point([&](const fusion::ModelPoint& m, bool) {
      const auto p = placed.find(point_key(m.robot, m.seq, m.beam));
      if (p == placed.end()) {
        ++unknown;
        return;
      }
      const auto k = correction.find({static_cast<std::uint8_t>(m.robot), m.seq});
      const Pose2 at = k != correction.end() ? k->second : tail.at(static_cast<std::uint8_t>(m.robot)).second;
      (k != correction.end() ? on_estimate : on_tail) += 1;
      const Vec2 want = at.apply(Vec2{p->second->x, p->second->y});
      worst_m = std::max({worst_m, std::abs(m.p.x - want.x), std::abs(m.p.y - want.y), std::abs(double{m.p.z} - p->second->z)});
      moved_m = std::max(moved_m, std::hypot(m.p.x - double{p->second->x}, m.p.y - double{p->second->y}));
    });
    EXPECT_EQ(unknown, 0u);
    EXPECT_GT(on_estimate, 1000u) << c;
    EXPECT_GT(on_tail, 0u) << c << ": scans released after the estimate's";
    EXPECT_LT(worst_m, 1e-4) << c << ": a model point off where the estimate puts its scan";
    EXPECT_GT(moved_m, 1e-4) << c << ": the estimate moved no point";
    EXPECT_GT(moved_m, 100.0 * worst_m) << c;
    std::printf("core %zu: %zu model points on the estimate's poses, %zu on the tail corrections (moved up to %.3f m, off by at most %.1e m)\n",
                c, on_estimate, on_tail, moved_m, worst_m);
  }
  // The live map is the primary's moved model, binned.
  LiveMap binned(o.map_resolution_m);
  stage.core().for_each_model_point([&](const fusion::ModelPoint& m, bool) { binned.add(m.p, m.removed_at_release != 0, m.robot); });
  auto sorted = [](std::vector<teamscan_msg_MapVoxel> v) {
    std::sort(v.begin(), v.end(), [](const teamscan_msg_MapVoxel& a, const teamscan_msg_MapVoxel& b) {
      return std::tie(a.x_mm, a.y_mm, a.z_mm) < std::tie(b.x_mm, b.y_mm, b.z_mm);
    });
    return v;
  };
  std::vector<teamscan_msg_MapVoxel> live, want;
  stage.map_voxels(live);
  binned.voxels(want);
  live = sorted(live);
  want = sorted(want);
  ASSERT_EQ(live.size(), want.size());
  for (std::size_t i = 0; i < live.size(); ++i) {
    EXPECT_TRUE(live[i].x_mm == want[i].x_mm && live[i].y_mm == want[i].y_mm && live[i].z_mm == want[i].z_mm &&
                live[i].hits == want[i].hits && live[i].flags == want[i].flags) << "voxel " << i;
    if (::testing::Test::HasFailure()) break;
  }
  EXPECT_TRUE(stage.take_map_replaced()) << "the next publication is the whole map";
  // The robots are handed their tail corrections: the scans to come are placed with them.
  for (const auto& [robot, t] : tail) {
    const fusion::PoseHistory::Correction* now = stage.core().poses().correction_at(robot, samples.back().recv_ns);
    ASSERT_NE(now, nullptr) << unsigned(robot);
    EXPECT_EQ(now->map_from_odom, t.second) << unsigned(robot);
  }

  // The rest of the survey: the live map follows on; the graph is the one eval's time order feeds, and
  // the final model on its poses is made as ever.
  run_station({samples.begin() + static_cast<std::ptrdiff_t>(run->half), samples.end()}, run->store, stage);
  stage.flush();
  EXPECT_FALSE(stage.following());
  ASSERT_TRUE(stage.write_graph_trajectories().ok());
  EXPECT_EQ(stage.counters().catch_ups, 0u);
  const auto scans = static_cast<std::size_t>(std::count_if(samples.begin(), samples.end(), [](const Sample& x) { return !x.is_pose; }));
  EXPECT_EQ(stage.graph()->counters().scans, scans) << "every scan once";
  EXPECT_EQ(stage.graph()->counters().repeated_scans, 0u) << "a rigid follow releases nothing again";
  expect_graph_is_evals(dir, o.core, "following rigidly");
  EXPECT_TRUE(stage.rebuild_on_graph().ok());
  std::printf("%llu rigid follows (%llu turns watched for the newest estimate's), the last moved %llu points in %.3f s\n",
              static_cast<unsigned long long>(stage.counters().rigid_follows), static_cast<unsigned long long>(turns_following),
              static_cast<unsigned long long>(stage.counters().follow_moved_points), stage.counters().last_follow_s);
  std::filesystem::remove_all(dir);
}

// Until the graph's newest estimate is followed, exactly or rigidly (at most until `deadline`): false if not.
bool follow_newest(FusionStage& stage, std::int64_t now_ns, std::chrono::steady_clock::time_point deadline) {
  wait_for_estimate(stage, deadline);
  auto behind = [&] {
    return stage.following() || stage.catching_up() || !stage.followed_estimate() ||
           stage.followed_estimate()->version != stage.graph()->latest()->version;
  };
  while (behind() && std::chrono::steady_clock::now() < deadline) {
    if (!stage.following() && !stage.catch_up_has_work()) std::this_thread::sleep_for(std::chrono::milliseconds(1));
    stage.tick(now_ns);
  }
  return !behind();
}

// A rigid follow leaves the filters' evidence and the decisions where the scans were released. An estimate
// worth following is followed exactly instead (FusionOptions::exact_follow_share) when the last exact
// follow took at most that share of the time since it began: the session decided again on its poses, the
// rebuilt cores taking over. With a share of 1 every one is: once the newest estimate is followed, the
// live primary is a core fed the scans it released on the estimate's poses, every model point where that
// core puts it, with its decision.
TEST(CatchUp, AnEstimateFollowedExactlyMovesTheEvidenceAndTheDecisions) {
  const std::vector<Sample> samples = drifting_survey();
  FusionOptions o = following_options();
  o.exact_follow_share = 1.0;
  o.follow_min_shift_m = 0.0;
  o.catch_up_slice_scans = 8;
  const std::string dir = temp_dir();
  std::optional<HalfWay> run = station_half_way(o, dir, samples);
  ASSERT_TRUE(run);
  FusionStage& stage = *run->stage;
  ASSERT_TRUE(follow_newest(stage, samples[run->half - 1].recv_ns, std::chrono::steady_clock::now() + std::chrono::seconds(60)))
      << "the newest estimate not followed within 60 s";
  EXPECT_GE(stage.counters().graph_follows, 1u);
  EXPECT_EQ(stage.counters().rigid_follows, 0u) << "every follow exact";
  EXPECT_EQ(stage.counters().catch_ups, 0u) << "a follow is not a catch-up";
  const auto taken = static_cast<std::uint64_t>(
      std::count_if(samples.begin(), samples.begin() + static_cast<std::ptrdiff_t>(run->half), [](const Sample& x) { return !x.is_pose; }));
  EXPECT_EQ(stage.counters().caught_up_scans, taken) << "the whole session decided again";
  const std::shared_ptr<const fusion::GraphEstimate> estimate = stage.followed_estimate();
  ASSERT_NE(estimate, nullptr);

  // The reference: a core fed the session's scans the live primary released, on the estimate's poses.
  run->store.sync();
  SessionReadStats stats;
  Result<Dataset> session = read_session_dataset(dir, stats);
  ASSERT_TRUE(session.ok()) << session.error().what;
  Dataset released = std::move(session.value());
  const auto held = [&](std::uint8_t robot, std::uint32_t scan) { return stage.core().holds(robot, scan); };
  std::erase_if(released.scans, [&](const ScanRecord& r) { return held(r.robot, r.scan); });
  std::erase_if(released.points, [&](const LabelledPoint& p) { return held(p.robot, p.scan); });
  ASSERT_EQ(released.scans.size(), stage.core().counters().scans_released);
  const Result<std::unique_ptr<fusion::CoreSet>> reference = fusion::cores_on_graph(released, estimate->poses(), o.core, {});
  ASSERT_TRUE(reference.ok()) << reference.error().what;
  struct Decided {
    Vec3 p;
    bool removed;
  };
  const auto model = [](const fusion::FusionCore& core) {
    std::map<std::uint64_t, Decided> m;
    core.for_each_model_point([&](const fusion::ModelPoint& p, bool removed) {
      m[point_key(p.robot, p.seq, p.beam)] = {Vec3{p.p.x, p.p.y, p.p.z}, removed};
    });
    return m;
  };
  const std::map<std::uint64_t, Decided> live = model(stage.core()), want = model(reference.value()->primary());
  ASSERT_EQ(live.size(), want.size());
  double worst_m = 0.0, moved_m = 0.0;
  std::size_t decisions_differ = 0, removed = 0;
  for (const auto& [key, l] : live) {
    const auto w = want.find(key);
    ASSERT_NE(w, want.end()) << "a live model point the reference does not have";
    worst_m = std::max({worst_m, std::abs(l.p.x - w->second.p.x), std::abs(l.p.y - w->second.p.y), std::abs(l.p.z - w->second.p.z)});
    decisions_differ += l.removed != w->second.removed ? 1 : 0;
    removed += l.removed ? 1 : 0;
  }
  for (const LabelledPoint& p : released.points)
    if (const auto l = live.find(point_key(p.robot, p.scan, p.beam)); l != live.end())
      moved_m = std::max(moved_m, std::hypot(l->second.p.x - double{p.x}, l->second.p.y - double{p.y}));
  EXPECT_GT(live.size(), 1000u);
  EXPECT_LT(worst_m, 1e-6) << "a model point off the estimate's pose of its scan";
  EXPECT_GT(moved_m, 100.0 * worst_m) << "the estimate moved no point";
  EXPECT_EQ(decisions_differ, 0u) << "the evidence did not follow the estimate";
  EXPECT_GT(removed, 0u) << "nothing removed: the decisions compared nothing";
  std::printf("%llu exact follows, the last decided %llu scans again: %zu model points (moved up to %.4f m), %zu removed, as the reference's\n",
              static_cast<unsigned long long>(stage.counters().graph_follows), static_cast<unsigned long long>(stage.counters().caught_up_scans),
              live.size(), moved_m, removed);
  std::filesystem::remove_all(dir);
}

// Exact follows keep to their share of the time and to the time they may be expected to take: with either
// bound this small, only the first estimate worth following is followed exactly, every later one rigidly.
TEST(CatchUp, ExactFollowsKeepToTheirShareAndTheirLength) {
  const std::vector<Sample> samples = drifting_survey();
  struct Bound {
    const char* what;
    double share, max_s;
  };
  // An exact follow of this survey takes milliseconds: the next one would be due in weeks, or expected to
  // take a million times too long.
  for (const Bound& b : {Bound{"share", 1e-9, 1e6}, Bound{"length", 1.0, 1e-9}}) {
    FusionOptions o = following_options();
    o.exact_follow_share = b.share;
    o.exact_follow_max_s = b.max_s;
    o.follow_min_shift_m = 0.0;
    const std::string dir = temp_dir();
    std::unique_ptr<FusionStage> stage = station_after(o, dir, samples);
    ASSERT_TRUE(stage);
    ASSERT_TRUE(follow_newest(*stage, samples.back().recv_ns, std::chrono::steady_clock::now() + std::chrono::seconds(60)))
        << b.what << ": the newest estimate not followed within 60 s";
    EXPECT_GE(stage->counters().rigid_follows, 1u) << b.what;
    EXPECT_EQ(stage->counters().graph_follows, stage->counters().rigid_follows + 1) << b.what << ": one exact follow, the first";
    stage->flush();
    std::filesystem::remove_all(dir);
  }
}

// An exact follow that cannot start (no session folder to decide again) gives way to a rigid one, its new
// models made in the loop since the thread made none for an estimate it was to decide again.
TEST(CatchUp, AnExactFollowThatCannotStartIsARigidOne) {
  const std::vector<Sample> samples = drifting_survey();
  FusionOptions o = following_options();
  o.exact_follow_share = 1.0;
  o.follow_min_shift_m = 0.0;
  const std::string dir = temp_dir();
  auto store = SessionStore::open(dir);
  ASSERT_TRUE(store.ok()) << store.error().what;
  auto created = FusionStage::create(o, "");  // no session folder
  ASSERT_TRUE(created.ok()) << created.error().what;
  FusionStage& stage = **created;
  run_station(samples, *store, stage);
  ASSERT_TRUE(follow_newest(stage, samples.back().recv_ns, std::chrono::steady_clock::now() + std::chrono::seconds(60)))
      << "the newest estimate not followed within 60 s";
  EXPECT_GE(stage.counters().rigid_follows, 1u);
  EXPECT_EQ(stage.counters().graph_follows, stage.counters().rigid_follows) << "no exact follow without a folder";
  EXPECT_GE(stage.counters().catch_up_failures, 1u);
  EXPECT_GT(stage.counters().follow_moved_points, 1000u);
  std::filesystem::remove_all(dir);
}

// A station restarted on its session folder replays it into its cores: the same work an exact follow
// does, so it counts as one made. With exact follows allowed less time than the replay took, a long
// session's first estimate worth following is followed rigidly, not decided again whole.
TEST(CatchUp, ARestartedStationsReplayCountsAsAnExactFollow) {
  const std::vector<Sample> samples = drifting_survey();
  FusionOptions o = following_options();
  o.exact_follow_share = 1.0;
  o.exact_follow_max_s = 1e-6;  // shorter than any replay of the survey's first half
  o.follow_min_shift_m = 0.0;
  const std::string dir = temp_dir();
  auto store = SessionStore::open(dir);
  ASSERT_TRUE(store.ok()) << store.error().what;
  const std::size_t half = samples.size() / 2;
  {
    auto first = FusionStage::create(o, dir);
    ASSERT_TRUE(first.ok()) << first.error().what;
    run_station({samples.begin(), samples.begin() + static_cast<std::ptrdiff_t>(half)}, *store, **first);
  }
  auto restarted = FusionStage::create(o, dir);
  ASSERT_TRUE(restarted.ok()) << restarted.error().what;
  FusionStage& stage = **restarted;
  ASSERT_TRUE(stage.replay_session(dir).ok());
  run_station({samples.begin() + static_cast<std::ptrdiff_t>(half), samples.end()}, *store, stage);
  ASSERT_TRUE(follow_newest(stage, samples.back().recv_ns, std::chrono::steady_clock::now() + std::chrono::seconds(60)))
      << "the newest estimate not followed within 60 s";
  EXPECT_GE(stage.counters().rigid_follows, 1u);
  EXPECT_EQ(stage.counters().graph_follows, stage.counters().rigid_follows) << "no exact follow after the replay";
  stage.flush();
  std::filesystem::remove_all(dir);
}

// An estimate that would shift no scan's returns by FusionOptions::follow_min_shift_m (2 cm by default)
// is not worth a pass over the model: the model stays where the odometry put it, and nothing is moved.
TEST(CatchUp, AnEstimateThatMovesNothingFarIsNotFollowed) {
  const std::vector<Sample> samples = drifting_survey();
  const FusionOptions o = following_options();
  ASSERT_DOUBLE_EQ(o.follow_min_shift_m, 0.02);
  const std::string dir = temp_dir();
  std::unique_ptr<FusionStage> stage = station_after(o, dir, samples);
  ASSERT_TRUE(stage);
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(60);
  wait_for_estimate(*stage, deadline);
  while ((stage->following() || stage->counters().follows_skipped == 0) && std::chrono::steady_clock::now() < deadline) {
    if (!stage->following()) std::this_thread::sleep_for(std::chrono::milliseconds(1));
    stage->tick(samples.back().recv_ns);
  }
  EXPECT_GE(stage->counters().follows_skipped, 1u);
  EXPECT_EQ(stage->counters().rigid_follows, 0u);
  EXPECT_EQ(stage->counters().graph_follows, 0u);
  EXPECT_GT(stage->counters().last_follow_shift_m, 0.0);
  EXPECT_LT(stage->counters().last_follow_shift_m, 0.02);
  EXPECT_EQ(stage->followed_estimate(), nullptr);
  // Every model point where the robot placed it.
  std::map<std::uint64_t, const LabelledPoint*> placed;
  SessionReadStats stats;
  const Result<Dataset> session = read_session_dataset(dir, stats);
  ASSERT_TRUE(session.ok()) << session.error().what;
  for (const LabelledPoint& p : session->points) placed[point_key(p.robot, p.scan, p.beam)] = &p;
  std::size_t off = 0, points = 0;
  stage->core().for_each_model_point([&](const fusion::ModelPoint& m, bool) {
    ++points;
    const auto p = placed.find(point_key(m.robot, m.seq, m.beam));
    if (p == placed.end() || m.p.x != p->second->x || m.p.y != p->second->y) ++off;
  });
  EXPECT_GT(points, 1000u);
  EXPECT_EQ(off, 0u);
  std::filesystem::remove_all(dir);
}

// With the registration on, its corrections place the scans live: the graph's estimates are not followed
// rigidly (they would take the registration's place), only the final model follows the graph.
TEST(CatchUp, WithTheRegistrationOnTheLiveMapStaysTheRegistrations) {
  const std::vector<Sample> samples = drifting_survey();
  FusionOptions o = following_options();
  o.core.registration = true;
  o.follow_min_shift_m = 0.0;
  ASSERT_TRUE(o.follow_rigidly);
  const std::string dir = temp_dir();
  std::unique_ptr<FusionStage> stage = station_after(o, dir, samples);
  ASSERT_TRUE(stage);
  wait_for_estimate(*stage, std::chrono::steady_clock::now() + std::chrono::seconds(60));
  for (int turn = 0; turn < 100; ++turn) stage->tick(samples.back().recv_ns);
  ASSERT_NE(stage->graph()->latest(), nullptr);
  EXPECT_EQ(stage->counters().graph_follows, 0u);
  EXPECT_FALSE(stage->following());
  EXPECT_TRUE(stage->core().options().registration);
  EXPECT_GT(stage->core().counters().registration_corrections, 0u);
  std::filesystem::remove_all(dir);
}

// Without a model store (max_points_per_voxel 0) the live map is the released points themselves, which a
// move cannot reach: the estimates are not followed, and the live map keeps every voxel it had.
TEST(CatchUp, WithoutAModelStoreTheLiveMapIsNotMoved) {
  const std::vector<Sample> samples = drifting_survey();
  FusionOptions o = following_options();
  o.core.max_points_per_voxel = 0;
  o.follow_min_shift_m = 0.0;
  const std::string dir = temp_dir();
  std::unique_ptr<FusionStage> stage = station_after(o, dir, samples);
  ASSERT_TRUE(stage);
  const std::uint32_t voxels = stage->map_total_voxels();
  ASSERT_GT(voxels, 100u);
  wait_for_estimate(*stage, std::chrono::steady_clock::now() + std::chrono::seconds(60));
  for (int turn = 0; turn < 100; ++turn) stage->tick(samples.back().recv_ns);
  EXPECT_EQ(stage->counters().graph_follows, 0u);
  EXPECT_FALSE(stage->following());
  EXPECT_EQ(stage->map_total_voxels(), voxels);
  std::filesystem::remove_all(dir);
}

// The loop is not held by a catch-up: the back-fill's whole session is decided again on the loader
// thread, each turn feeds the rebuilt cores at most catch_up_slice_scans of the live scans queued behind
// it, and every live scan that comes meanwhile is
// released by the live cores within as many turns as with no catch-up at all (until the rebuilt cores take
// over, the live ones are the very cores of a run without a catch-up).
TEST(CatchUp, LiveScansAreFusedTurnByTurnWhileTheCatchUpRuns) {
  const Dataset d = long_survey();
  const std::int64_t t0 = d.scans.front().stamp_ns;
  const std::vector<Sample> samples = received(d, Shadow{2, t0 + 2'000'000'000, t0 + 6'000'000'000});
  constexpr std::uint32_t kSlice = 2;
  // Per live scan received at or after the catch-up began: the turns until the live core released it.
  std::vector<int> turns_to_release[2];
  std::uint64_t catch_up_turns = 0;
  std::int64_t started_ns = 0;
  std::size_t started_at = 0;  // the sample the catch-up began at
  constexpr std::size_t kAhead = 200;  // samples received (and queued) before the loader is waited for
  std::set<std::pair<std::uint8_t, std::uint32_t>> during;
  for (int k = 0; k < 2; ++k) {
    FusionOptions o = options();
    o.catch_up_slice_scans = kSlice;
    if (k == 1) o.catch_up_min_scans = 0;  // the same run without a catch-up in the loop
    const std::string dir = temp_dir();
    auto store = SessionStore::open(dir);
    ASSERT_TRUE(store.ok());
    auto created = FusionStage::create(o, dir);
    ASSERT_TRUE(created.ok());
    FusionStage& stage = **created;
    struct Pending {
      std::uint8_t robot;
      std::uint32_t seq;
      int turns;
    };
    std::vector<Pending> pending;
    std::size_t fed_before = 0;
    bool saw_loaded = false, session_fed_on_loader = false;
    std::size_t most_fed_in_a_turn = 0;
    for (std::size_t i = 0; i < samples.size(); ++i) {
      const Sample& x = samples[i];
      if (x.is_pose) {
        store->append_pose(x.pose, ReceiveTime{Time::from_ns(x.recv_ns), Time::from_ns(x.recv_ns)});
        stage.add_pose(pose_observation(x.pose, Time::from_ns(x.recv_ns)));
      } else {
        store->append_scan(x.scan, x.receipt);
        stage.add_scan(x.scan, x.receipt);
        // The teammates' live scans that come while the catch-up runs (the same ones in the run without).
        const std::pair<std::uint8_t, std::uint32_t> key{static_cast<std::uint8_t>(x.scan.robot_id), x.scan.seq};
        if (k == 0 && stage.catching_up() && key.first != 2) during.insert(key);
        if (during.count(key)) pending.push_back({key.first, key.second, 0});
      }
      const bool was_catching_up = stage.catching_up();
      stage.tick(x.recv_ns);  // the loop's turn
      if (k == 0 && started_ns == 0 && stage.catching_up()) {
        started_ns = x.recv_ns;
        started_at = i;
      }
      if (k == 0 && started_ns != 0 && i == started_at + kAhead) {
        // The session is read and decided again on a thread of its own while the live inputs queue
        // behind it: wait for it here, so that the queue holds kAhead samples' inputs (however fast
        // the thread was) and the turns below feed them.
        while (!stage.catch_up_has_work() && stage.catching_up()) {
          std::this_thread::sleep_for(std::chrono::milliseconds(1));
          stage.tick(x.recv_ns);  // the clock where it is: it releases nothing more
        }
      }
      if (was_catching_up && stage.catching_up()) {
        // What the loop fed the rebuilt cores in this turn: live scans from the queue (the session's
        // are the loader's).
        const fusion::RebuildProgress p = stage.catch_up_progress();
        if (!saw_loaded && stage.catch_up_has_work()) {  // the loop's first sight of the rebuilt cores
          saw_loaded = true;
          session_fed_on_loader = p.time_line_scans > 0 && p.fed_scans == p.time_line_scans;
        }
        const std::size_t fed = p.queued_fed_scans;
        most_fed_in_a_turn = std::max(most_fed_in_a_turn, fed - fed_before);
        fed_before = fed;
        ++catch_up_turns;
      }
      for (Pending& p : pending) {
        if (p.turns < 0) continue;
        if (stage.core().holds(p.robot, p.seq)) {
          ++p.turns;
        } else {
          turns_to_release[k].push_back(p.turns);
          p.turns = -1;
        }
      }
    }
    if (k == 0) {
      ASSERT_NE(started_ns, 0) << "no catch-up began";
      EXPECT_FALSE(stage.catching_up()) << "the catch-up did not end before the survey";
      EXPECT_EQ(stage.counters().catch_ups, 1u);
      EXPECT_LE(most_fed_in_a_turn, kSlice) << "a turn fed the rebuilt cores more than the slice";
      EXPECT_TRUE(saw_loaded);
      EXPECT_TRUE(session_fed_on_loader) << "the loop was handed the session's scans to feed";
      EXPECT_GT(stage.counters().caught_up_live_scans, 50u);  // live scans queued behind the session
      EXPECT_GE(catch_up_turns, stage.counters().caught_up_live_scans / kSlice);  // fed over many turns
    }
    std::filesystem::remove_all(dir);
  }
  ASSERT_GT(turns_to_release[0].size(), 30u);
  ASSERT_EQ(turns_to_release[0].size(), turns_to_release[1].size());
  const int most[2] = {*std::max_element(turns_to_release[0].begin(), turns_to_release[0].end()),
                       *std::max_element(turns_to_release[1].begin(), turns_to_release[1].end())};
  std::printf("catch-up over %llu turns; a live scan released within %d turns (without a catch-up: %d)\n",
              static_cast<unsigned long long>(catch_up_turns), most[0], most[1]);
  EXPECT_LE(most[0], most[1]);
  EXPECT_LE(most[0], 10);
}

}  // namespace
}  // namespace teamscan::station
