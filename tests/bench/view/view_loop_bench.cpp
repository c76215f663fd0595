// The view's cost to the fusion ("with 32 robots x 75 Hz live and three browsers connected, scan
// -> map p99 within 10 % of a run without the view, the station's memory bounded"), without DDS, robot
// daemons or emulated devices, so the figure is the view's and not the machine's: the station's loop
// (Kalman team source, the live fusion stage `best`, the map tick every 1 s) fed a synthetic 32-robot
// survey at 75 Hz per robot in real time, once without the view and once with the view server and
// three WebSocket clients reading everything (ViewFeeder + ViewServer, as the daemon wires them),
// alternating. Per scan: scan -> map = from its arrival time (the survey's schedule, stretched by 1/SPEED)
// to the end of its fusion and view hooks, so a loop that falls behind shows (beyond 1 s the histogram
// gives the maximum); and the loop's own work per scan (fusion + the view's hooks), which does not depend
// on the machine's other load. Prints p50/p99/max, the loop's CPU, the process's memory, the view's
// counters and what the clients got.
// usage: view_loop_bench [SECONDS_PER_RUN=8] [ROUNDS=2] [SPEED=1] [METHOD=best]
#include <sys/resource.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <sstream>
#include <map>
#include <string>
#include <thread>
#include <vector>

#include "common/clock.hpp"
#include "groundstation/station/fusion.hpp"
#include "groundstation/station/pose_history_team_source.hpp"
#include "groundstation/station/latency_histogram.hpp"
#include "groundstation/station/view_feeder.hpp"
#include "groundstation/view/server.hpp"
#include "teamscan.h"
#include "tests/bench/mapping/synthetic_survey.hpp"
#include "tests/bench/view/ws_clients.hpp"

namespace {

using namespace teamscan;
using namespace teamscan::station;

constexpr int kRobots = 32;
constexpr double kScanHz = 75.0;

std::int32_t mm(double m) { return static_cast<std::int32_t>(std::lround(m * 1000.0)); }

struct Feed {
  std::vector<PoseObservation> poses;  // stamp order
  std::vector<ScanPoints> scans;       // stamp order
};

Feed make_feed(double seconds) {
  bench::SurveyOptions o;
  o.robots = kRobots;
  o.scan_hz = kScanHz;
  o.duration_s = seconds;
  const Dataset d = bench::synthetic_survey(o);
  Feed out;
  std::map<std::pair<int, std::uint32_t>, std::vector<const LabelledPoint*>> points;
  for (const LabelledPoint& p : d.points) points[{p.robot, p.scan}].push_back(&p);
  for (const TrajectorySample& s : d.odom) {
    PoseObservation p;
    p.robot_id = s.robot;
    p.stamp = Time::from_ns(s.stamp_ns);
    p.x_m = s.pose.x_m;
    p.y_m = s.pose.y_m;
    p.yaw_rad = s.pose.theta_rad;
    p.vx_mps = s.v_mps * std::cos(s.pose.theta_rad);
    p.vy_mps = s.v_mps * std::sin(s.pose.theta_rad);
    out.poses.push_back(p);
  }
  std::sort(out.poses.begin(), out.poses.end(), [](const auto& a, const auto& b) { return a.stamp < b.stamp; });
  out.scans.resize(d.scans.size());
  for (std::size_t i = 0; i < d.scans.size(); ++i) {
    const ScanRecord& r = d.scans[i];
    ScanPoints& s = out.scans[i];
    s.robot_id = r.robot;
    s.seq = r.scan;
    s.stamp = Time::from_ns(r.stamp_ns);
    s.origin_x_mm = mm(r.origin.x);
    s.origin_y_mm = mm(r.origin.y);
    s.origin_z_mm = mm(r.origin.z);
    for (const LabelledPoint* p : points[{r.robot, r.scan}]) {
      if (s.count < kMaxBeams) s.points[s.count++] = ScanPoint{mm(p->x), mm(p->y), mm(p->z), p->beam, 0};
    }
  }
  std::sort(out.scans.begin(), out.scans.end(), [](const auto& a, const auto& b) { return a.stamp < b.stamp; });
  return out;
}

long peak_rss_kb() {
  std::ifstream in("/proc/self/status");
  std::string line;
  while (std::getline(in, line)) {
    if (line.rfind("VmHWM:", 0) == 0) return std::atol(line.c_str() + 6);
  }
  return 0;
}
long rss_kb() {
  std::ifstream in("/proc/self/status");
  std::string line;
  while (std::getline(in, line)) {
    if (line.rfind("VmRSS:", 0) == 0) return std::atol(line.c_str() + 6);
  }
  return 0;
}
// CPU seconds of this process's thread named `name` (/proc/self/task/*/comm), 0 if none.
double named_thread_cpu_s(const std::string& name) {
  namespace fs = std::filesystem;
  std::error_code ec;
  for (const fs::directory_entry& t : fs::directory_iterator("/proc/self/task", ec)) {
    std::ifstream comm(t.path() / "comm");
    std::string c;
    std::getline(comm, c);
    if (c != name) continue;
    std::ifstream stat(t.path() / "stat");
    std::string text((std::istreambuf_iterator<char>(stat)), std::istreambuf_iterator<char>());
    std::istringstream rest(text.substr(text.rfind(')') + 2));
    std::string field;
    unsigned long long utime = 0, stime = 0;
    for (int i = 3; i <= 15 && rest >> field; ++i) {
      if (i == 14) utime = std::stoull(field);
      if (i == 15) stime = std::stoull(field);
    }
    return static_cast<double>(utime + stime) / static_cast<double>(sysconf(_SC_CLK_TCK));
  }
  return 0.0;
}

double thread_cpu_s() {
  rusage u{};
  getrusage(RUSAGE_THREAD, &u);
  return static_cast<double>(u.ru_utime.tv_sec + u.ru_stime.tv_sec) +
         static_cast<double>(u.ru_utime.tv_usec + u.ru_stime.tv_usec) * 1e-6;
}

// One run of the station's loop over the feed in real time; with_view: the view and three clients.
void run(const Feed& f, bool with_view, double speed, const char* method) {
  FusionOptions fo;
  fo.core.method = method;
  fo.latency_csv.clear();
  auto stage = FusionStage::create(fo, "/tmp");
  FusionStage& fusion = **stage;
  PoseHistoryTeamSource team(fusion.core().poses());  // the station's one tracker: the core's history
  std::array<RobotRecord, kMaxRobots + 1> records{};
  for (std::uint32_t i = 0; i <= kMaxRobots; ++i) records[i].robot_id = i;

  std::unique_ptr<view::ViewFeed> feed;
  std::unique_ptr<view::ViewServer> server;
  std::unique_ptr<ViewFeeder> feeder;
  std::atomic<bool> stop_clients{false};
  std::vector<bench::ViewClientFigures> figures(3);
  std::vector<std::thread> clients;
  if (with_view) {
    feed = std::make_unique<view::ViewFeed>();
    view::ServerOptions vo;
    vo.listen = {"127.0.0.1", 0};
    vo.hub.map_resolution_mm = 100;
    auto s = view::ViewServer::start(vo, *feed);
    if (!s) {
      std::fprintf(stderr, "view: %s\n", s.error().what);
      std::exit(1);
    }
    server = std::move(s.value());
    feeder = std::make_unique<ViewFeeder>(
        *feed, [&](std::uint32_t id) -> const RobotRecord& { return records[id]; }, team,
        std::chrono::milliseconds(100), 100,
        [&](std::uint32_t id) { return fusion.core().robot_counters(id).removed_at_release; });
    for (std::size_t c = 0; c < figures.size(); ++c) {
      clients.emplace_back(bench::run_view_client, server->port(), std::cref(stop_clients), 0, std::ref(figures[c]));
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(500));  // the clients connect
  }

  LatencyHistogram scan_to_map;
  std::vector<std::int64_t> work;  // the loop's own work per scan, exact (well below the histogram's 0.1 ms)
  work.reserve(f.scans.size());
  std::vector<teamscan_msg_MapVoxel> voxels;
  std::vector<std::uint8_t> robots;
  const long rss_before = rss_kb();
  const double cpu_before = thread_cpu_s();
  const Time t0 = now_monotonic();
  const std::int64_t stamp0 = f.scans.front().stamp.ns();
  Time next_map = t0 + std::chrono::seconds(1);
  std::uint64_t map_ticks = 0;
  std::size_t next_pose = 0;
  // The station loop's ticks after each poll: the view's snapshot, the map changes (teamscan/map).
  auto ticks = [&](Time now) {
    if (feeder) feeder->tick(now);
    if (now >= next_map) {
      fusion.map_voxels_changed(voxels, &robots);
      if (feeder) feeder->offer_map(voxels, robots, false, fusion.map_total_voxels(), fusion.map_release());
      ++map_ticks;
      next_map = now + std::chrono::seconds(1);
    }
  };
  for (const ScanPoints& s : f.scans) {
    const Time arrival = t0 + Duration{static_cast<std::int64_t>(static_cast<double>(s.stamp.ns() - stamp0) / speed)};
    Time now = now_monotonic();
    while (now < arrival) {  // the loop waits for data
      std::this_thread::sleep_for(std::min<Duration>(arrival - now, std::chrono::microseconds(500)));
      now = now_monotonic();
      ticks(now);
    }
    while (next_pose < f.poses.size() && f.poses[next_pose].stamp.ns() <= s.stamp.ns()) {
      const PoseObservation& p = f.poses[next_pose++];
      team.add_pose(p);
      fusion.add_pose(p);
      if (feeder) feeder->on_pose(p);
    }
    const Time start = now_monotonic();
    RobotRecord& r = records[s.robot_id];
    r.seen = true;
    ++r.scans;
    fusion.add_scan(s, Receipt{});
    if (feeder) feeder->on_scan(s, Receipt{});
    const Time done = now_monotonic();
    scan_to_map.add((done - arrival).count());
    work.push_back((done - start).count());
    ticks(done);
  }
  const double run_s = to_seconds(now_monotonic() - t0);
  const double cpu_s = thread_cpu_s() - cpu_before;
  const long rss_after = rss_kb();
  auto ms = [](std::int64_t ns) { return static_cast<double>(ns) * 1e-6; };
  std::sort(work.begin(), work.end());
  auto work_q = [&](double q) {
    return work[std::min(work.size() - 1, static_cast<std::size_t>(q * static_cast<double>(work.size())))];
  };
  std::printf(
      "%-26s %6llu scans in %5.1f s  scan->map p50 %7.2f p99 %7.2f max %7.1f ms  loop work/scan p50 %6.3f "
      "p99 %6.3f ms  loop CPU %5.1f %%  RSS %ld MB (%+ld, peak %ld)  map %u voxels, %llu map ticks\n",
      with_view ? "view + 3 WebSocket clients" : "no view", static_cast<unsigned long long>(scan_to_map.count()), run_s,
      ms(scan_to_map.quantile_ns(0.5)), ms(scan_to_map.quantile_ns(0.99)), ms(scan_to_map.max_ns()), ms(work_q(0.5)),
      ms(work_q(0.99)), 100.0 * cpu_s / run_s, rss_after / 1024, (rss_after - rss_before) / 1024, peak_rss_kb() / 1024,
      fusion.map_total_voxels(), static_cast<unsigned long long>(map_ticks));
  if (with_view) {
    std::this_thread::sleep_for(std::chrono::milliseconds(300));
    const view::FeedCounters fc = feed->counters();
    std::printf("  feed: %llu scans offered (%llu dropped), %llu voxels offered (%llu overflows), %llu snapshots\n",
                static_cast<unsigned long long>(fc.scans_offered), static_cast<unsigned long long>(fc.scans_dropped),
                static_cast<unsigned long long>(fc.voxels_offered), static_cast<unsigned long long>(fc.voxel_overflows),
                static_cast<unsigned long long>(fc.snapshots_offered));
    std::printf("  view: server thread CPU %.1f %% of a core; hub %.1f MB, client queues %.2f MB now; %s\n",
                100.0 * named_thread_cpu_s("teamscan-view") / run_s,
                static_cast<double>(server->counters().hub_bytes.load()) * 1e-6,
                static_cast<double>(server->counters().queued_bytes.load()) * 1e-6, server->counters().line().c_str());
    stop_clients = true;
    server.reset();  // the clients see the server go away
    for (std::thread& t : clients) t.join();
    for (std::size_t c = 0; c < figures.size(); ++c) bench::print_view_client(c + 1, figures[c]);
  }
}

}  // namespace

int main(int argc, char** argv) {
  const double seconds = argc > 1 ? std::atof(argv[1]) : 8.0;
  const int rounds = argc > 2 ? std::atoi(argv[2]) : 2;
  const double speed = argc > 3 ? std::atof(argv[3]) : 1.0;
  const char* method = argc > 4 ? argv[4] : "best";
  std::printf(
      "view_loop_bench: %d robots x %.0f Hz, %.0f s of survey per run at %.2fx real time, synthetic survey, "
      "fusion method %s\n",
      kRobots, kScanHz, seconds, speed, method);
  const Feed f = make_feed(seconds);
  std::printf("feed: %zu scans, %zu poses\n", f.scans.size(), f.poses.size());
  for (int r = 0; r < rounds; ++r) {
    run(f, false, speed, method);
    run(f, true, speed, method);
  }
  return 0;
}
