// A station restart: the session folder (scans.bin + poses.csv written by SessionStore) replayed through
// the fusion core, then the rest of the survey live, decides every point as an uninterrupted run and as
// `teamscan eval` of the session (read_session_dataset + the core in time order); a robot that goes silent
// keeps its teammates' hits on it removed; every compared method's model equals eval with that method.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <map>
#include <memory>
#include <set>
#include <tuple>

#include "common/dataset/pcd.hpp"
#include "groundstation/fusion/evaluation.hpp"
#include "groundstation/fusion/time_line.hpp"
#include "groundstation/station/fusion.hpp"
#include "groundstation/station/station.hpp"
#include "groundstation/station/model_check.hpp"
#include "groundstation/station/session_replay.hpp"
#include "groundstation/station/session_store.hpp"
#include "teamscan.h"
#include "tests/bench/mapping/synthetic_survey.hpp"

namespace teamscan::station {
namespace {

std::int32_t mm(double m) { return static_cast<std::int32_t>(std::lround(m * 1000.0)); }

std::string temp_dir() {
  char tmpl[] = "/tmp/teamscan-replay-unit-XXXXXX";
  return ::mkdtemp(tmpl);
}

// The survey as the robots publish it: poses (wire units) and scans, with receive times (a pose arrives
// 20 ms after its stamp, a scan 5 ms after).
struct Sample {
  std::int64_t recv_ns = 0;
  bool is_pose = false;
  teamscan_msg_RobotPose pose{};
  std::size_t scan = 0;  // index in scans
  Receipt receipt{};     // the scan's
};
struct Feed {
  std::vector<Sample> samples;
  std::vector<ScanPoints> scans;
};

Feed make_feed(const Dataset& d) {
  Feed f;
  for (const TrajectorySample& s : d.odom) {
    Sample x;
    x.is_pose = true;
    x.recv_ns = s.stamp_ns + 20'000'000;
    x.pose.robot_id = s.robot;
    x.pose.stamp_ns = s.stamp_ns;
    x.pose.x_mm = mm(s.pose.x_m);
    x.pose.y_mm = mm(s.pose.y_m);
    x.pose.yaw_urad = static_cast<std::int32_t>(std::lround(s.pose.theta_rad * 1e6));
    x.pose.vx_mmps = static_cast<std::int32_t>(std::lround(s.v_mps * std::cos(s.pose.theta_rad) * 1e3));
    x.pose.vy_mmps = static_cast<std::int32_t>(std::lround(s.v_mps * std::sin(s.pose.theta_rad) * 1e3));
    f.samples.push_back(x);
  }
  f.scans.reserve(d.scans.size());
  for (const ScanRecord& r : d.scans) {
    ScanPoints s{};
    s.robot_id = r.robot;
    s.seq = r.scan;
    s.stamp = Time::from_ns(r.stamp_ns);
    s.origin_x_mm = mm(r.origin.x);
    s.origin_y_mm = mm(r.origin.y);
    s.origin_z_mm = mm(r.origin.z);
    for (const LabelledPoint& p : d.points)
      if (p.robot == r.robot && p.scan == r.scan) s.points[s.count++] = ScanPoint{mm(p.x), mm(p.y), mm(p.z), p.beam, 0};
    Sample x;
    x.receipt.recv_realtime_ns = r.stamp_ns + 5'000'000;
    x.recv_ns = x.receipt.recv_realtime_ns;
    x.scan = f.scans.size();
    f.scans.push_back(s);
    f.samples.push_back(x);
  }
  std::stable_sort(f.samples.begin(), f.samples.end(), [](const Sample& a, const Sample& b) { return a.recv_ns < b.recv_ns; });
  return f;
}

// Stores then fuses samples [from, to) as the station's loop does (storage first).
void run(const Feed& f, std::size_t from, std::size_t to, SessionStore* store, FusionStage& stage) {
  for (std::size_t i = from; i < to; ++i) {
    const Sample& x = f.samples[i];
    if (x.is_pose) {
      if (store) store->append_pose(x.pose, ReceiveTime{Time::from_ns(x.recv_ns), Time::from_ns(x.recv_ns)});
      stage.add_pose(pose_observation(x.pose, Time::from_ns(x.recv_ns)));
    } else {
      if (store) store->append_scan(f.scans[x.scan], x.receipt);
      stage.add_scan(f.scans[x.scan], x.receipt);
    }
  }
}

// A station of `o` that stored and fused every sample of `f` into `dir`, its folder synced; nullptr, with
// the test's failure added, if the folder or the stage could not be made.
std::unique_ptr<FusionStage> station_over_all(const Feed& f, const FusionOptions& o, const std::string& dir) {
  auto store = SessionStore::open(dir);
  auto stage = FusionStage::create(o, dir);
  if (!store.ok() || !stage.ok()) {
    ADD_FAILURE() << "session folder or fusion stage: " << (!store.ok() ? store.error().what : stage.error().what);
    return nullptr;
  }
  run(f, 0, f.samples.size(), &*store, **stage);
  store->sync();
  return std::move(stage.value());
}

using Decisions = std::map<std::tuple<int, std::uint32_t, int>, std::uint8_t>;
Decisions model_decisions(const std::string& path) {
  Decisions out;
  auto all = read_pcd(path);
  EXPECT_TRUE(all.ok());
  if (!all.ok()) return out;
  const int fr = all->field("robot"), fs = all->field("scan"), fb = all->field("beam"), fk = all->field("keep");
  for (std::size_t i = 0; i < all->size(); ++i) {
    auto col = [&](int c) { return all->columns[static_cast<std::size_t>(c)][i]; };
    out[{static_cast<int>(col(fr)), static_cast<std::uint32_t>(col(fs)), static_cast<int>(col(fb))}] = col(fk) == 0.0 ? 1 : 0;
  }
  return out;
}

// The restart's replay in arrival order, the model on the robots' poses (the pose graph's final model
// after a restart and a catch-up: catch_up_test).
FusionOptions options() {
  FusionOptions o;
  o.core.method = "best";
  o.core.max_points_per_voxel = 100000;
  o.all_points_pcd = "fused_all.pcd";
  o.pose_graph.reset();
  return o;
}

Dataset survey() {
  bench::SurveyOptions o;
  o.duration_s = 3.0;
  o.room_m = 6.0;
  o.seed = 5;
  return bench::synthetic_survey(o);
}

// Reading a long session back says it is progressing every 256 samples: the daemon asks systemd for
// more start-up time on each (at most once a second), so a restart is not killed for taking long.
TEST(SessionReplay, ReadingASessionBackSaysItIsProgressing) {
  bench::SurveyOptions so;
  so.duration_s = 20.0;
  so.room_m = 6.0;
  so.seed = 5;
  const Feed f = make_feed(bench::synthetic_survey(so));
  const std::string dir = temp_dir();
  ASSERT_NE(station_over_all(f, options(), dir), nullptr);
  auto restarted = FusionStage::create(options(), dir);
  ASSERT_TRUE(restarted.ok());
  std::uint64_t progressing = 0;
  const auto replayed = (*restarted)->replay_session(dir, [&] { ++progressing; });
  ASSERT_TRUE(replayed.ok()) << replayed.error().what;
  EXPECT_EQ(replayed.value(), f.samples.size());
  EXPECT_GE(progressing, 2u);
  EXPECT_EQ(progressing, replayed.value() / 256);
  std::filesystem::remove_all(dir);
}

TEST(SessionReplay, ARestartedStationDecidesAsTheUninterruptedRunAndAsEvalOfTheSession) {
  const Dataset d = survey();
  const Feed f = make_feed(d);
  const std::size_t half = f.samples.size() / 2;

  // Uninterrupted.
  const std::string whole = temp_dir();
  {
    const std::unique_ptr<FusionStage> stage = station_over_all(f, options(), whole);
    ASSERT_NE(stage, nullptr);
    stage->flush();
    ASSERT_TRUE(stage->write_model().ok());
  }
  // Killed halfway (its held scans and in-memory state lost), restarted on the same folder.
  const std::string restarted = temp_dir();
  {
    auto s = SessionStore::open(restarted);
    ASSERT_TRUE(s.ok());
    {
      auto first = FusionStage::create(options(), restarted);
      ASSERT_TRUE(first.ok());
      run(f, 0, half, &*s, **first);
    }
    s->sync();
    auto second = FusionStage::create(options(), restarted);
    ASSERT_TRUE(second.ok());
    auto replayed = (*second)->replay_session(restarted);
    ASSERT_TRUE(replayed.ok());
    EXPECT_EQ(replayed.value(), half);
    EXPECT_GT((*second)->counters().replayed_scans, 0u);
    // The robots' DDS history delivers the last samples before the kill again: not fused twice.
    run(f, half > 200 ? half - 200 : 0, f.samples.size(), &*s, **second);
    (*second)->flush();
    EXPECT_GT((*second)->counters().duplicates, 0u);
    ASSERT_TRUE((*second)->write_model().ok());
  }
  const Decisions a = model_decisions(whole + "/fused_all.pcd"), b = model_decisions(restarted + "/fused_all.pcd");
  ASSERT_EQ(a.size(), d.points.size());
  EXPECT_EQ(a, b);

  // `teamscan eval` of the session: the session as a data set, the core in time order.
  SessionReadStats stats;
  auto ds = read_session_dataset(whole, stats);
  ASSERT_TRUE(ds.ok());
  EXPECT_EQ(ds->points.size(), d.points.size());
  EXPECT_EQ(stats.bad_pose_lines + stats.bad_scan_records, 0u);
  const FusionOptions o = options();
  const std::vector<std::uint8_t> eval = fusion::decide_through_core(*ds, o.core.method, o.core.methods, o.core.tracker).value();
  std::size_t removed = 0;
  for (std::size_t i = 0; i < ds->points.size(); ++i) {
    const LabelledPoint& p = ds->points[i];
    ASSERT_EQ((a.at({p.robot, p.scan, p.beam})), eval[i]) << i;
    removed += eval[i];
  }
  EXPECT_GT(removed, 0u);
  std::filesystem::remove_all(whole);
  std::filesystem::remove_all(restarted);
}

// Every method side by side in one station (best primary, the others compared), killed halfway and
// restarted on its session folder: each method's model file gives every point the decision `teamscan
// eval` of the session gives it with that method (model_check, as the demo checks it), and the
// decisions of the uninterrupted run.
TEST(SessionReplay, EveryComparedMethodsModelEqualsEvalOfTheSessionAfterARestart) {
  const Dataset d = survey();
  const Feed f = make_feed(d);
  const std::size_t half = f.samples.size() / 2;
  FusionOptions o = options();
  for (const char* m : {"frequency", "visibility", "position", "direction", "combined", "freespace", "tracked"})
    o.compare_methods.push_back(m);
  const std::string whole = temp_dir(), restarted = temp_dir();
  {
    const std::unique_ptr<FusionStage> stage = station_over_all(f, o, whole);
    ASSERT_NE(stage, nullptr);
    stage->flush();
    ASSERT_TRUE(stage->write_model().ok());
  }
  {
    auto s = SessionStore::open(restarted);
    ASSERT_TRUE(s.ok());
    {
      auto first = FusionStage::create(o, restarted);
      ASSERT_TRUE(first.ok());
      run(f, 0, half, &*s, **first);
      (*first)->request_write();  // a periodic write in flight when it dies: replaced by the final one
    }
    s->sync();
    auto second = FusionStage::create(o, restarted);
    ASSERT_TRUE(second.ok());
    ASSERT_TRUE((*second)->replay_session(restarted).ok());
    run(f, half > 200 ? half - 200 : 0, f.samples.size(), &*s, **second);
    (*second)->flush();
    ASSERT_TRUE((*second)->write_model().ok());
    for (const std::string& m : o.compare_methods) {
      const fusion::FusionCore* c = (*second)->compared_core(m);
      ASSERT_NE(c, nullptr) << m;
      EXPECT_EQ(c->counters().points, (*second)->core().counters().points) << m;  // the same input
    }
  }
  std::vector<std::string> methods{o.core.method};
  methods.insert(methods.end(), o.compare_methods.begin(), o.compare_methods.end());
  std::set<std::vector<bool>> distinct;
  for (const std::string& m : methods) {
    const FusionOptions om = compared_options(o, m);
    auto check = check_model_against_eval(restarted, om);
    ASSERT_TRUE(check.ok()) << m << ": " << check.error().what;
    EXPECT_EQ(check->compared, d.points.size()) << m;
    EXPECT_EQ(check->not_in_model, 0u) << m;
    EXPECT_EQ(check->model_unknown, 0u) << m;
    EXPECT_EQ(check->mismatches, 0u) << m;
    std::vector<bool> removed;
    for (const PointDecision& p : check->points) removed.push_back(p.eval_removed);
    distinct.insert(removed);
    EXPECT_EQ(model_decisions(whole + "/" + om.all_points_pcd), model_decisions(restarted + "/" + om.all_points_pcd)) << m;
  }
  EXPECT_GE(distinct.size(), 4u);  // the methods really differ: each file is its own method's
  std::filesystem::remove_all(whole);
  std::filesystem::remove_all(restarted);
}

TEST(SessionReplay, ASilentRobotStaysWhereItWasLastSeenAndItsHitsAreStillRemoved) {
  // Robot 2 stands at (2, 0) and goes silent after its poses of the first second; robot 1 keeps
  // scanning it for 10 s (a point on its body, one on a box 2 m beyond its centre, one on the wall).
  // The box is out of a silent standing Pioneer's reach: 1.7 m beyond its front in its 2 s coast would
  // need 0.85 m/s, above a P3-AT's top speed of 0.7 m/s (TrackerOptions::coast_s).
  FusionOptions o;
  o.core.method = "tracked";
  o.core.max_points_per_voxel = 1000;
  o.all_points_pcd = "fused_all.pcd";
  const std::string dir = temp_dir();
  auto stage = FusionStage::create(o, dir);
  ASSERT_TRUE(stage.ok());
  const std::int64_t t0 = 1'700'000'000'000'000'000;
  std::uint32_t seq = 0;
  for (std::int64_t ms = 0; ms <= 10'000; ms += 100) {
    const std::int64_t t = t0 + ms * 1'000'000;
    PoseObservation p1;
    p1.robot_id = 1;
    p1.stamp = p1.received = Time::from_ns(t);
    (*stage)->add_pose(p1);
    if (ms <= 1000) {
      PoseObservation p2;
      p2.robot_id = 2;
      p2.stamp = p2.received = Time::from_ns(t);
      p2.x_m = 2.0;
      (*stage)->add_pose(p2);
    }
    ScanPoints s{};
    s.robot_id = 1;
    s.seq = ++seq;
    s.stamp = Time::from_ns(t);
    Receipt receipt;
    receipt.recv_realtime_ns = t;
    s.origin_z_mm = 300;
    s.points[s.count++] = ScanPoint{1750, 0, 150, 0, 0};  // robot 2's front face
    s.points[s.count++] = ScanPoint{5000, 0, 300, 1, 0};  // the wall
    s.points[s.count++] = ScanPoint{4000, 0, 300, 2, 0};  // the box
    (*stage)->add_scan(s, receipt);
  }
  (*stage)->flush();
  ASSERT_TRUE((*stage)->write_model().ok());
  const Decisions m = model_decisions(dir + "/fused_all.pcd");
  for (std::uint32_t q = 1; q <= seq; ++q) {
    EXPECT_EQ((m.at({1, q, 0})), 1) << "body hit of scan " << q << " kept";
    EXPECT_EQ((m.at({1, q, 1})), 0) << "wall of scan " << q << " removed";
    EXPECT_EQ((m.at({1, q, 2})), 0) << "box of scan " << q << " removed";
  }
  std::filesystem::remove_all(dir);
}

// The session files are an edge: an accepted sample whose robot id is out of 1..kMaxRobots (a file
// from elsewhere) is skipped and counted by the reader, so that no consumer sees it.
TEST(SessionReplay, ARobotIdOutOfRangeIsSkippedAndCountedByTheReader) {
  const std::string dir = temp_dir();
  {
    auto store = SessionStore::open(dir);
    ASSERT_TRUE(store.ok());
    const ReceiveTime at{Time::from_ns(1'000), Time::from_ns(1'000)};
    for (std::uint32_t robot : {1u, 0u, static_cast<std::uint32_t>(kMaxRobots) + 1}) {
      teamscan_msg_RobotPose p{};
      p.robot_id = robot;
      store->append_pose(p, at);
      ScanPoints s{};
      s.robot_id = robot;
      s.points[s.count++] = ScanPoint{1000, 0, 0, 0, 0};
      Receipt receipt;
      receipt.recv_realtime_ns = 2'000;
      store->append_scan(s, receipt);
    }
  }
  SessionReadStats stats;
  std::vector<std::uint32_t> poses, scans;
  const Status st = replay_session_files(
      dir, [&](const PoseObservation& p) { poses.push_back(p.robot_id); },
      [&](const ScanPoints& s, const Receipt&) { scans.push_back(s.robot_id); }, stats);
  ASSERT_TRUE(st.ok()) << st.error().what;
  EXPECT_EQ(poses, (std::vector<std::uint32_t>{1}));
  EXPECT_EQ(scans, (std::vector<std::uint32_t>{1}));
  EXPECT_EQ(stats.poses, 1u);
  EXPECT_EQ(stats.scans, 1u);
  EXPECT_EQ(stats.bad_robot_ids, 4u);
  std::filesystem::remove_all(dir);
}

// The station's final model reads its session as rows, each scan's points read back from scans.bin as it
// is fed (read_session_index): the same rows, and in time order the same points, flags and beams as the
// whole read, past a stretch of bad bytes and a scan stored twice; a record that no longer reads (the
// file cut short since) is counted and fed without points.
TEST(SessionReplay, TheIndexFeedsEachScansPointsAsTheWholeRead) {
  const Dataset d = survey();
  const Feed f = make_feed(d);
  const std::string dir = temp_dir();
  const auto store_part = [&](std::size_t from, std::size_t to) {
    auto store = SessionStore::open(dir);
    ASSERT_TRUE(store.ok());
    for (std::size_t i = from; i < to; ++i) {
      const Sample& x = f.samples[i];
      if (x.is_pose) store->append_pose(x.pose, ReceiveTime{Time::from_ns(x.recv_ns), Time::from_ns(x.recv_ns)});
      else store->append_scan(f.scans[x.scan], x.receipt);
    }
    if (to == f.samples.size()) {  // a DDS history replay: the last scan stored again
      const auto last = std::find_if(f.samples.rbegin(), f.samples.rend(), [](const Sample& x) { return !x.is_pose; });
      store->append_scan(f.scans[last->scan], last->receipt);
    }
  };
  const std::size_t half = f.samples.size() / 2;
  ASSERT_NO_FATAL_FAILURE(store_part(0, half));
  {
    // A record whose bytes went bad (its CRC fails), then bytes that are no record.
    std::vector<std::uint8_t> record(kScanRecordMaxBytes);
    record.resize(encode_scan_record(f.scans.front(), Receipt{}, record));
    record[record.size() / 2] ^= 0xff;
    std::FILE* bin = std::fopen((dir + "/scans.bin").c_str(), "ab");
    ASSERT_NE(bin, nullptr);
    std::fwrite(record.data(), 1, record.size(), bin);
    for (int i = 0; i < 37; ++i) std::fputc(0x5a, bin);
    std::fclose(bin);
  }
  ASSERT_NO_FATAL_FAILURE(store_part(half, f.samples.size()));

  SessionReadStats whole_stats, index_stats;
  const Result<Dataset> whole = read_session_dataset(dir, whole_stats);
  Result<SessionIndex> index = read_session_index(dir, index_stats);
  ASSERT_TRUE(whole.ok()) << whole.error().what;
  ASSERT_TRUE(index.ok()) << index.error().what;
  EXPECT_GT(index_stats.bad_scan_records, 0u);
  EXPECT_EQ(index_stats.scans, whole_stats.scans);
  EXPECT_TRUE(index->dataset.points.empty());
  EXPECT_FALSE(whole->points.empty());
  ASSERT_EQ(index->dataset.scans.size(), d.scans.size());
  ASSERT_EQ(index->dataset.scans.size(), whole->scans.size());
  EXPECT_EQ(index->dataset.odom.size(), whole->odom.size());
  for (std::size_t i = 0; i < whole->scans.size(); ++i) {
    const ScanRecord &a = whole->scans[i], &b = index->dataset.scans[i];
    EXPECT_EQ(std::tie(a.robot, a.scan, a.stamp_ns, a.points, a.beams), std::tie(b.robot, b.scan, b.stamp_ns, b.points, b.beams));
    EXPECT_EQ(a.pose.x_m, b.pose.x_m);
    EXPECT_EQ(a.origin.z, b.origin.z);
  }
  using Fed = std::vector<std::tuple<int, std::uint32_t, std::vector<float>, std::vector<std::uint16_t>, std::vector<std::uint16_t>>>;
  const auto feed = [](const fusion::TimeLine& t) {
    Fed out;
    t.feed([](fusion::PoseInput&) {},
           [&](fusion::ScanInput& in) {
             std::vector<float> xyz;
             for (const mapping::MapPoint& p : in.points) xyz.insert(xyz.end(), {p.x, p.y, p.z});
             out.emplace_back(in.robot, in.scan, xyz, std::vector<std::uint16_t>(in.flags.begin(), in.flags.end()),
                              std::vector<std::uint16_t>(in.beams.begin(), in.beams.end()));
           });
    return out;
  };
  const Fed from_whole = feed(fusion::TimeLine(whole.value()));
  const Fed from_index = feed(fusion::TimeLine(index->dataset, index->points.get()));
  ASSERT_EQ(from_index.size(), d.scans.size());
  EXPECT_TRUE(from_index == from_whole);
  EXPECT_EQ(index->points->failures(), 0u);

  // The file cut short after the index was read: the scans past the cut no longer read.
  std::filesystem::resize_file(dir + "/scans.bin", std::filesystem::file_size(dir + "/scans.bin") / 2);
  const Fed cut = feed(fusion::TimeLine(index->dataset, index->points.get()));
  ASSERT_EQ(cut.size(), from_whole.size());
  EXPECT_GT(index->points->failures(), 0u);
  EXPECT_LT(index->points->failures(), d.scans.size());
  std::size_t emptied = 0;  // scans with points in the whole read, none after the cut
  for (std::size_t i = 0; i < cut.size(); ++i) emptied += std::get<2>(cut[i]).empty() && !std::get<2>(from_whole[i]).empty() ? 1 : 0;
  EXPECT_EQ(emptied, index->points->failures());
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace teamscan::station
