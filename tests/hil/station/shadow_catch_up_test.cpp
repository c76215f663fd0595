// A radio shadow over loopback DDS: teamscan-groundstation fed in real time by three robots (DdsBridge in
// this process); robot 2 loses its link for 4 s (nothing it sends arrives: its poses of the shadow are
// lost, its scans kept as its ring keeps them) and back-fills its scans of the shadow on teamscan/backfill
// behind its live ones when it returns. Then: no scan lost (every seq of every robot in the session once);
// its teammates' scans of the shadow were decided without waiting for it (in the fused map before the
// back-fill began); and the station's model files after SIGTERM are byte for byte those of `teamscan
// eval`'s time order on the session (fusion/time_line.hpp: the session read back and fed in time order to
// a core with the station's options), and every decision is eval's (model_check, the demo's check).
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <deque>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <map>
#include <sstream>
#include <thread>
#include <tuple>

#include "common/clock.hpp"
#include "common/scan_points.hpp"
#include "groundstation/fusion/graph_backend.hpp"
#include "groundstation/fusion/graph_map.hpp"
#include "groundstation/fusion/model_writer.hpp"
#include "groundstation/fusion/time_line.hpp"
#include "groundstation/station/config.hpp"
#include "groundstation/station/fusion.hpp"
#include "groundstation/station/model_check.hpp"
#include "groundstation/station/session_replay.hpp"
#include "onboard/bridge/bridge.hpp"
#include "tests/bench/mapping/synthetic_survey.hpp"
#include "tests/hil/station/process.hpp"
#include "tests/support/test_domain.hpp"

namespace teamscan {
namespace {

using namespace std::chrono_literals;

std::int32_t mm(double m) { return static_cast<std::int32_t>(std::lround(m * 1000.0)); }

std::string file_bytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), {});
}

void sleep_until_realtime(std::int64_t t_ns) {
  const std::int64_t now = now_realtime().ns();
  if (t_ns > now) std::this_thread::sleep_for(std::chrono::nanoseconds(t_ns - now));
}

// One sample of the survey as its robot publishes it at its stamp.
struct Event {
  std::int64_t stamp_ns;
  bool is_pose;
  std::size_t index;  // in odom or scans
};

constexpr std::uint8_t kShadowed = 2;
constexpr std::int64_t kSecond = 1'000'000'000;

TEST(ShadowCatchUp, NoScanLostTeammatesNotHeldAndTheModelIsEvalsOfTheSession) {
  char tmpl[] = "/tmp/teamscan-shadow-catch-up-XXXXXX";
  const std::string root = ::mkdtemp(tmpl);
  const std::string session = root + "/session", config = root + "/gs.toml";
  std::ofstream(config)
      << "[fusion]\nmethod = \"best\"\nwrite_interval_s = 0.0\nwrite_all_points = true\nlatency_log = true\n"
      << "[view]\nlisten = \"\"\n[ros2]\nenabled = false\n";
  station::GroundStationConfig cfg;
  station::ConfigError cerr;
  ASSERT_TRUE(station::load_groundstation_config(config, cfg, cerr)) << cerr.message;
  const station::FusionOptions options = cfg.fusion;

  std::vector<onboard::DdsBridge> robots;
  for (std::uint32_t id : {1u, 2u, 3u}) {
    onboard::DdsBridgeOptions o;
    o.robot_id = id;
    o.domain_id = test::test_domain_id();
    o.store_and_forward = id == kShadowed;
    auto b = onboard::DdsBridge::create(o);
    ASSERT_TRUE(b.ok()) << b.error().what;
    robots.push_back(std::move(b.value()));
  }
  test::ChildProcess gs(
      {TEAMSCAN_GROUNDSTATION, "--config", config, "--session-dir", session, "--domain", test::test_domain_arg()});
  for (auto& b : robots) {
    const auto deadline = std::chrono::steady_clock::now() + 15s;
    while (b.scan_subscribers() < 1 && std::chrono::steady_clock::now() < deadline) std::this_thread::sleep_for(10ms);
    ASSERT_EQ(b.scan_subscribers(), 1u);
  }
  std::this_thread::sleep_for(300ms);  // the pose and back-fill readers matched too

  // A 12 s survey of three robots at 10 scans a second, stamped from now on: published in real time.
  bench::SurveyOptions so;
  so.robots = 3;
  so.duration_s = 12.0;
  so.room_m = 6.0;
  so.seed = 3;
  Dataset d = bench::synthetic_survey(so);
  const std::int64_t shift = now_realtime().ns() + kSecond / 2 - d.scans.front().stamp_ns;
  for (ScanRecord& r : d.scans) r.stamp_ns += shift;
  for (TrajectorySample& s : d.odom) s.stamp_ns += shift;
  const std::int64_t t0 = d.scans.front().stamp_ns;
  const std::int64_t shadow_from = t0 + 4 * kSecond, shadow_to = t0 + 8 * kSecond;
  auto in_shadow = [&](std::uint8_t robot, std::int64_t stamp) {
    return robot == kShadowed && stamp >= shadow_from && stamp < shadow_to;
  };
  std::map<std::pair<std::uint8_t, std::uint32_t>, std::vector<const LabelledPoint*>> points;
  for (const LabelledPoint& p : d.points) points[{p.robot, p.scan}].push_back(&p);
  std::vector<Event> events;
  for (std::size_t i = 0; i < d.odom.size(); ++i) events.push_back({d.odom[i].stamp_ns, true, i});
  for (std::size_t i = 0; i < d.scans.size(); ++i) events.push_back({d.scans[i].stamp_ns, false, i});
  std::stable_sort(events.begin(), events.end(),
                   [](const Event& a, const Event& b) { return a.stamp_ns < b.stamp_ns; });

  static ScanPoints scan;
  auto fill_scan = [&](const ScanRecord& r) {
    scan.robot_id = r.robot;
    scan.seq = r.scan + 1;
    scan.stamp = Time::from_ns(r.stamp_ns);
    scan.origin_x_mm = mm(r.origin.x);
    scan.origin_y_mm = mm(r.origin.y);
    scan.origin_z_mm = mm(r.origin.z);
    scan.count = 0;
    for (const LabelledPoint* p : points[{r.robot, r.scan}])
      scan.points[scan.count++] = ScanPoint{mm(p->x), mm(p->y), mm(p->z), p->beam, 0};
  };
  std::deque<std::size_t> kept;  // robot 2's scans of the shadow, as its ring keeps them
  std::uint32_t pose_seq[4] = {0, 0, 0, 0};
  std::int64_t backfill_began_ns = 0, next_backfill_ns = 0;
  std::size_t backfilled = 0;
  // Back-fill after the shadow: one kept scan every 25 ms (4x the live rate), behind the live ones.
  auto backfill_due = [&](std::int64_t now_ns) {
    while (!kept.empty() && now_ns >= shadow_to && now_ns >= next_backfill_ns) {
      if (backfill_began_ns == 0) backfill_began_ns = now_realtime().ns();
      fill_scan(d.scans[kept.front()]);
      kept.pop_front();
      ASSERT_TRUE(robots[kShadowed - 1].publish_backfill(scan).ok());
      ++backfilled;
      next_backfill_ns = std::max(next_backfill_ns, now_ns) + 25'000'000;
    }
  };
  for (const Event& e : events) {
    sleep_until_realtime(e.stamp_ns + 2'000'000);  // published 2 ms after its stamp
    backfill_due(now_realtime().ns());
    if (e.is_pose) {
      const TrajectorySample& s = d.odom[e.index];
      ++pose_seq[s.robot];
      if (in_shadow(s.robot, s.stamp_ns)) continue;  // sent into the shadow: lost
      onboard::OnboardPose pose;
      pose.robot_id = s.robot;
      pose.seq = pose_seq[s.robot];
      pose.stamp_ns = s.stamp_ns;
      pose.x_mm = mm(s.pose.x_m);
      pose.y_mm = mm(s.pose.y_m);
      pose.yaw_urad = static_cast<std::int32_t>(std::lround(s.pose.theta_rad * 1e6));
      pose.vx_mmps = mm(s.v_mps * std::cos(s.pose.theta_rad));
      pose.vy_mmps = mm(s.v_mps * std::sin(s.pose.theta_rad));
      pose.yaw_rate_mradps = mm(s.w_radps);
      ASSERT_TRUE(robots[s.robot - 1u].publish_pose(pose).ok());
      continue;
    }
    const ScanRecord& r = d.scans[e.index];
    if (in_shadow(r.robot, r.stamp_ns)) {
      kept.push_back(e.index);
      continue;
    }
    fill_scan(r);
    ASSERT_TRUE(robots[r.robot - 1u].publish_scan(scan).ok());
  }
  while (!kept.empty()) {
    std::this_thread::sleep_for(5ms);
    backfill_due(now_realtime().ns());
  }
  ASSERT_GT(backfilled, 30u);
  for (auto& b : robots) ASSERT_TRUE(b.wait_for_scan_acks(from_seconds(20.0)).ok());
  std::this_thread::sleep_for(3s);  // the back-fill's last scans stored; a catch-up in the loop may follow
  gs.signal(SIGTERM);
  const auto st = gs.wait(60s);
  ASSERT_TRUE(st.has_value());
  EXPECT_TRUE(WIFEXITED(*st) && WEXITSTATUS(*st) == 0);

  // No scan lost: every seq of every robot in the session, once.
  std::map<std::uint32_t, std::vector<std::uint32_t>> seqs;
  station::SessionReadStats stats;
  ASSERT_TRUE(station::replay_session_files(
                  session, [](const station::PoseObservation&) {},
                  [&](const ScanPoints& s, const station::Receipt& receipt) {
                    if (receipt.rejected == 0) seqs[s.robot_id].push_back(s.seq);
                  },
                  stats)
                  .ok());
  for (std::uint32_t id : {1u, 2u, 3u}) {
    std::vector<std::uint32_t>& v = seqs[id];
    std::sort(v.begin(), v.end());
    const std::size_t sent = static_cast<std::size_t>(
        std::count_if(d.scans.begin(), d.scans.end(), [&](const ScanRecord& r) { return r.robot == id; }));
    EXPECT_EQ(v.size(), sent) << "robot " << id;
    EXPECT_TRUE(std::adjacent_find(v.begin(), v.end()) == v.end()) << "robot " << id << ": a scan stored twice";
  }

  // Teammates not held: their scans of the shadow's first half were in the fused map before the back-fill
  // began (fused_latency.csv: robot,seq,stamp_ns,received_ns,fused_ns); their scan -> map latency during
  // the shadow and outside it, for the record.
  std::ifstream lat(session + "/fused_latency.csv");
  std::string line;
  std::vector<double> during_ms, outside_ms;
  std::size_t mates_early = 0, mates_early_before_backfill = 0;
  while (std::getline(lat, line)) {
    unsigned robot = 0, seq = 0;
    long long stamp = 0, received = 0, fused = 0;
    if (std::sscanf(line.c_str(), "%u,%u,%lld,%lld,%lld", &robot, &seq, &stamp, &received, &fused) != 5 ||
        robot == kShadowed)
      continue;
    (stamp >= shadow_from && stamp < shadow_to ? during_ms : outside_ms)
        .push_back(static_cast<double>(fused - stamp) * 1e-6);
    if (stamp >= shadow_from && stamp < shadow_from + 2 * kSecond) {
      ++mates_early;
      if (fused < backfill_began_ns) ++mates_early_before_backfill;
    }
  }
  EXPECT_GT(mates_early, 30u);
  EXPECT_EQ(mates_early_before_backfill, mates_early);
  auto quantile = [](std::vector<double> v, double q) {
    if (v.empty()) return 0.0;
    std::sort(v.begin(), v.end());
    return v[static_cast<std::size_t>(q * static_cast<double>(v.size() - 1))];
  };
  std::printf(
      "teammates' scan -> map: during the shadow p50 %.1f ms p99 %.1f ms (%zu scans), outside it p50 %.1f ms p99 %.1f "
      "ms (%zu)\n",
      quantile(during_ms, 0.5), quantile(during_ms, 0.99), during_ms.size(), quantile(outside_ms, 0.5),
      quantile(outside_ms, 0.99), outside_ms.size());

  // The station caught up (events.log) and its model files are those of eval's time order on the session.
  const std::string events_log = file_bytes(session + "/events.log");
  EXPECT_NE(events_log.find("fusion: caught up in time order"), std::string::npos) << events_log;
  for (std::size_t at = events_log.find("fusion: caught up"); at != std::string::npos;
       at = events_log.find("fusion: caught up", at + 1))
    std::printf("%s\n", events_log.substr(at, events_log.find('\n', at) - at).c_str());
  station::SessionReadStats read_stats;
  auto ds = station::read_session_dataset(session, read_stats);
  ASSERT_TRUE(ds.ok()) << ds.error().what;
  // Eval's model of the session at the station's defaults: the core fed in time order feeds the pose
  // graph, and the model is decided again on the graph's poses (`teamscan eval SESSION`).
  ASSERT_TRUE(options.pose_graph.has_value());
  fusion::GraphBackend graph(*options.pose_graph);
  auto core = fusion::FusionCore::create(fusion::with_graph_order(options.core));
  ASSERT_TRUE(core.ok());
  (*core)->set_release_callback([&](const fusion::FusedScan& f) { graph.add(f); });
  fusion::feed_in_time_order(ds.value(), **core);
  graph.finish();
  auto on_graph = fusion::cores_on_graph(ds.value(), graph.poses(), options.core, {});
  ASSERT_TRUE(on_graph.ok()) << on_graph.error().what;
  ASSERT_TRUE(fusion::write_model_files((*on_graph)->primary(), root + "/eval.pcd", root + "/eval_all.pcd").ok());
  const std::string live_all = file_bytes(session + "/fused_all.pcd"), eval_all = file_bytes(root + "/eval_all.pcd");
  EXPECT_GT(live_all.size(), 10'000u);
  EXPECT_TRUE(live_all == eval_all) << "fused_all.pcd: the station's " << live_all.size() << " bytes, eval's "
                                    << eval_all.size();
  EXPECT_TRUE(file_bytes(session + "/fused.pcd") == file_bytes(root + "/eval.pcd"));
  auto check = station::check_model_against_eval(session, options);
  ASSERT_TRUE(check.ok()) << check.error().what;
  EXPECT_EQ(check->mismatches, 0u);
  EXPECT_EQ(check->model_unknown, 0u);
  std::printf(
      "%zu scans back-filled; the model: %llu points, %llu decisions compared with `teamscan eval SESSION`, %llu "
      "differ\n",
      backfilled, static_cast<unsigned long long>(check->model_points),
      static_cast<unsigned long long>(check->compared), static_cast<unsigned long long>(check->mismatches));
  if (std::getenv("GSLIVE_KEEP_SESSION") == nullptr) std::filesystem::remove_all(root);
}

}  // namespace
}  // namespace teamscan
