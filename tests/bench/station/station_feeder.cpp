// station_feeder: a light multi-robot feeder for station benchmarks (docs/validation.md "Benchmarks"):
// one process, no emulators or daemons, publishes scans (75 Hz), poses (10 Hz) and status (1 Hz) of N
// robots over DDS as the onboard daemons do, from a looped template survey (the synthetic lap2-like
// survey of tests/bench/mapping, or a recorded data set with --dataset). Each robot copy drives its own
// cell of the site. Stamps are the feeder's CLOCK_REALTIME at publication, so they stay consistent with
// the station's clock at any --warp (robot seconds per wall second; velocities are scaled to match) and
// pass the station's stamp-window validation without a bench mode.
//
// With --station PATH it also starts teamscan-groundstation (its own session folder and config, pinned
// to --station-cpu), samples its RSS and CPU, stops it after the feed, and prints: scans published /
// stored / fused, lost, scan -> fused-map latency p50/p99 (fused_latency.csv), the station's CPU share
// and RSS curve (start, each quarter, end), and the periodic model writes with the p99 of the scans fused
// during a write and outside. Figures only: never pass/fail.
#include <sched.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cinttypes>
#include <climits>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <optional>
#include <set>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include <CLI/CLI.hpp>
#include <dds/dds.h>

#include "common/clock.hpp"
#include "common/dataset/dataset.hpp"
#include "groundstation/station/scan_record.hpp"
#include "dds/qos.hpp"
#include "tests/support/robot_writers.hpp"
#include "dds/topics.hpp"
#include "teamscan.h"
#include "tests/bench/mapping/synthetic_survey.hpp"

namespace {

using namespace teamscan;

struct Options {
  int robots = 8;
  double scan_hz = 75.0;
  double pose_hz = 10.0;
  double status_hz = 1.0;
  double duration_s = 20.0;     // robot time
  double warp = 1.0;            // robot seconds per wall second
  int domain = -1;              // -1: from the pid
  std::string dds_config;       // CYCLONEDDS_URI file for the feeder and the station (e.g. a secured one)
  std::string dataset;          // recorded data set folder; empty: the synthetic survey
  double cell_m = 12.0;         // spacing of the robots' cells
  // Station under test (optional).
  std::string station;
  std::string station_config;   // extra TOML appended to the generated config
  double warmup_s = 2.0;        // the steady-state figures skip scans stamped in the feed's first seconds
  std::string session_dir;      // default: a fresh /tmp folder
  std::string method = "best";
  double write_interval_s = 0;  // periodic fused-model writes (0: none)
  std::string compare_methods;  // the station's fusion.compare_methods, comma-separated (empty: none)
  int station_cpu = -1;         // pin the station to this CPU (-1: no pinning)
  double rss_guard_mib = 4096;  // stop feeding if the station's RSS exceeds this (protects a shared host)
  double max_wall_s = 0;        // stop feeding after this much wall time (0: no limit)
  double stop_timeout_s = 120;  // SIGTERM -> exit; then SIGKILL (the final model pass is not measured)
  bool keep_session = false;
};

std::int32_t mm(double m) { return static_cast<std::int32_t>(std::lround(m * 1000.0)); }

// One template robot: its scans in order with their points, and its odometry.
struct TemplateRobot {
  std::vector<ScanRecord> scans;
  std::vector<std::vector<teamscan_msg_ScanPoint>> points;
  std::vector<TrajectorySample> odom;
  std::int64_t t0_ns = 0;
  double lap_s = 0;
};

std::vector<TemplateRobot> make_templates(const Dataset& d) {
  std::map<std::uint8_t, std::size_t> index;
  std::vector<TemplateRobot> out;
  for (const DatasetRobot& r : d.robots) {
    index[r.id] = out.size();
    out.emplace_back();
  }
  std::map<std::pair<std::uint8_t, std::uint32_t>, std::size_t> scan_at;
  for (const ScanRecord& s : d.scans) {
    if (!index.count(s.robot)) continue;
    TemplateRobot& t = out[index[s.robot]];
    scan_at[{s.robot, s.scan}] = t.scans.size();
    t.scans.push_back(s);
    t.points.emplace_back();
  }
  for (const LabelledPoint& p : d.points) {
    auto it = scan_at.find({p.robot, p.scan});
    if (it == scan_at.end() || !index.count(p.robot)) continue;
    auto& list = out[index[p.robot]].points[it->second];
    if (list.size() < kMaxBeams) list.push_back(teamscan_msg_ScanPoint{mm(p.x), mm(p.y), mm(p.z), p.beam, 0});
  }
  for (const TrajectorySample& s : d.odom) {
    if (index.count(s.robot)) out[index[s.robot]].odom.push_back(s);
  }
  std::vector<TemplateRobot> kept;
  for (TemplateRobot& t : out) {
    if (t.scans.empty() || t.odom.empty()) continue;
    t.t0_ns = t.odom.front().stamp_ns;
    t.lap_s = std::max(1.0, static_cast<double>(t.odom.back().stamp_ns - t.t0_ns) * 1e-9);
    kept.push_back(std::move(t));
  }
  return kept;
}

std::optional<long> read_rss_kib(pid_t pid) {
  std::ifstream in("/proc/" + std::to_string(pid) + "/status");
  std::string line;
  while (std::getline(in, line)) {
    if (line.rfind("VmRSS:", 0) == 0) return std::atol(line.c_str() + 6);
  }
  return std::nullopt;
}

double read_cpu_s(pid_t pid) {  // utime + stime of the process (all threads)
  std::ifstream in("/proc/" + std::to_string(pid) + "/stat");
  std::string s((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const auto close = s.rfind(')');
  if (close == std::string::npos) return 0;
  std::istringstream rest(s.substr(close + 2));
  std::string field;
  double ticks = 0;
  for (int i = 3; i <= 15 && rest >> field; ++i) {
    if (i == 14 || i == 15) ticks += std::atof(field.c_str());
  }
  return ticks / static_cast<double>(::sysconf(_SC_CLK_TCK));
}

double quantile(std::vector<double> v, double q) {
  if (v.empty()) return 0;
  const auto k = static_cast<std::size_t>(std::clamp(std::ceil(q * static_cast<double>(v.size())) - 1.0, 0.0,
                                                     static_cast<double>(v.size() - 1)));
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(k), v.end());
  return v[k];
}

// The feeder's participant: one writer per robot and topic in the robot's partition (the station checks
// that a sample's robot id is its sender's), with the robots' QoS.
struct Publisher {
  dds_entity_t participant = 0;
  std::unique_ptr<test::RobotWriters> robots;
  ~Publisher() {
    if (participant > 0) (void)dds_delete(participant);
  }
  bool create(std::uint32_t domain) {
    participant = dds_create_participant(domain, nullptr, nullptr);
    if (participant < 0) return false;
    robots = std::make_unique<test::RobotWriters>(participant, /*keep_all=*/false);
    return robots->ok();
  }
  [[nodiscard]] std::uint32_t scan_readers() const { return robots->matched(test::RobotWriters::kScan, 1); }
};

std::string slurp(const std::string& path) {
  std::ifstream in(path);
  return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

}  // namespace

int main(int argc, char** argv) {
  Options o;
  CLI::App app{"station_feeder: N robots' scans and poses at real rates over DDS to teamscan-groundstation"};
  app.add_option("--robots,-n", o.robots, "robots (1..32)")->check(CLI::Range(1, 32));
  app.add_option("--scan-hz", o.scan_hz, "scans per robot per robot-second")->check(CLI::Range(0.1, 1000.0));
  app.add_option("--pose-hz", o.pose_hz, "poses per robot per robot-second")->check(CLI::Range(0.1, 1000.0));
  app.add_option("--duration", o.duration_s, "robot seconds to feed")->check(CLI::Range(0.1, 1e6));
  app.add_option("--warp", o.warp, "robot seconds per wall second (1 = real time)")->check(CLI::Range(0.01, 1000.0));
  app.add_option("--domain", o.domain, "DDS domain id (default: from the pid)")->check(CLI::Range(0, 232));
  app.add_option("--dds-config", o.dds_config, "Cyclone config file for feeder and station (CYCLONEDDS_URI), e.g. a secured one");
  app.add_option("--dataset", o.dataset, "recorded data set folder (teamscan sim output) instead of the synthetic survey");
  app.add_option("--cell", o.cell_m, "distance between the robots' cells, metres");
  app.add_option("--station", o.station, "start this teamscan-groundstation and measure it");
  app.add_option("--warmup", o.warmup_s, "seconds of feed (wall) left out of the steady-state latency")->check(CLI::Range(0.0, 1e6));
  app.add_option("--station-config", o.station_config, "TOML file appended to the generated station config (after its [fusion] keys; without a [view] table the view is off)");
  app.add_option("--session-dir", o.session_dir, "the station's session folder (default: a new /tmp folder)");
  app.add_option("--method", o.method, "the station's fusion.method");
  app.add_option("--write-interval", o.write_interval_s, "the station's fusion.write_interval_s (0: no periodic writes)");
  app.add_option("--compare-methods", o.compare_methods, "the station's fusion.compare_methods, comma-separated (one more core each)");
  app.add_option("--station-cpu", o.station_cpu, "pin the station to this CPU");
  app.add_option("--rss-guard-mib", o.rss_guard_mib, "stop feeding when the station's RSS exceeds this");
  app.add_option("--max-wall", o.max_wall_s, "stop feeding after this many wall seconds (0: no limit)");
  app.add_option("--stop-timeout", o.stop_timeout_s, "seconds the station may take to exit after SIGTERM");
  app.add_flag("--keep-session", o.keep_session, "keep the station's session folder");
  CLI11_PARSE(app, argc, argv);

  if (!o.dds_config.empty()) {
    const std::string uri = o.dds_config.rfind("file://", 0) == 0 || o.dds_config.front() == '<' ? o.dds_config : "file://" + o.dds_config;
    ::setenv("CYCLONEDDS_URI", uri.c_str(), 1);
  }
  if (std::getenv("CYCLONEDDS_URI") == nullptr) {
    std::fprintf(stderr, "station_feeder: set CYCLONEDDS_URI or --dds-config (e.g. deploy/cyclonedds-lo.xml)\n");
    return 2;
  }
  const auto domain = static_cast<std::uint32_t>(o.domain >= 0 ? o.domain : 1 + ::getpid() % 230);

  // The template: the lap2-like survey (2 robots on one oval of a 10 m room, 181 beams) over one lap,
  // at the feed's scan rate, or a recorded data set.
  Dataset d;
  if (!o.dataset.empty()) {
    auto r = read_dataset(o.dataset);
    if (!r) {
      std::fprintf(stderr, "station_feeder: %s: %s\n", o.dataset.c_str(), r.error().what);
      return 2;
    }
    d = std::move(r.value());
  } else {
    bench::SurveyOptions so;
    so.scan_hz = o.scan_hz;
    const double a = 0.3 * so.room_m, b = 0.2 * so.room_m;
    const double perimeter = kPi * (3 * (a + b) - std::sqrt((3 * a + b) * (a + 3 * b)));
    so.duration_s = perimeter / so.speed_mps;  // one lap: the loop is seamless
    d = bench::synthetic_survey(so);
  }
  const std::vector<TemplateRobot> templates = make_templates(d);
  if (templates.empty()) {
    std::fprintf(stderr, "station_feeder: the template has no robot with scans and odometry\n");
    return 2;
  }
  const auto n_templates = templates.size();
  const double room_m = std::max(1.0, d.room_m[0]);
  const double cell_m = std::max(o.cell_m, room_m + 2.0);

  // The station under test.
  pid_t station_pid = -1;
  std::string session = o.session_dir;
  char tmpl[] = "/tmp/teamscan-feeder-XXXXXX";
  std::string work;
  if (!o.station.empty()) {
    work = ::mkdtemp(tmpl);
    if (session.empty()) session = work + "/session";
    const std::string cfg_path = work + "/groundstation.toml";
    {
      std::ofstream cfg(cfg_path);
      cfg << "[station]\nstatus_interval_s = 1.0\n[dds]\ndomain_id = " << domain << "\n[fusion]\nmethod = \"" << o.method
          << "\"\nwrite_interval_s = " << o.write_interval_s << "\nlatency_log = true\ncompare_methods = [";
      std::stringstream list(o.compare_methods);
      bool first = true;
      for (std::string m; std::getline(list, m, ',');) {
        if (m.empty()) continue;
        cfg << (first ? "\"" : ", \"") << m << "\"";
        first = false;
      }
      cfg << "]\n";
      const std::string extra = o.station_config.empty() ? std::string{} : slurp(o.station_config);
      cfg << extra;
      // The browser view off unless the extra config sets it (its default port would collide with any
      // other station on the host).
      if (extra.find("[view]") == std::string::npos) cfg << "[view]\nlisten = \"\"\n";
    }
    station_pid = ::fork();
    if (station_pid == 0) {
      if (o.station_cpu >= 0) {
        cpu_set_t set;
        CPU_ZERO(&set);
        CPU_SET(o.station_cpu, &set);
        (void)::sched_setaffinity(0, sizeof set, &set);
      }
      const std::string log = work + "/station.log";
      std::FILE* f = std::freopen(log.c_str(), "w", stderr);
      (void)f;
      ::execl(o.station.c_str(), o.station.c_str(), "--config", cfg_path.c_str(), "--session-dir", session.c_str(),
              static_cast<char*>(nullptr));
      ::_exit(127);
    }
  }

  Publisher pub;
  if (!pub.create(domain)) {
    std::fprintf(stderr, "station_feeder: cannot create the DDS writers (domain %u)\n", domain);
    if (station_pid > 0) ::kill(station_pid, SIGKILL);
    return 1;
  }
  if (station_pid > 0) {
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(30);
    while (pub.scan_readers() == 0 && std::chrono::steady_clock::now() < deadline)
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    if (pub.scan_readers() == 0) {
      std::fprintf(stderr, "station_feeder: the station did not subscribe within 30 s (see %s/station.log)\n", work.c_str());
      ::kill(station_pid, SIGKILL);
      return 1;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(500));  // its other readers match too
  }

  std::printf("# station_feeder: %d robots, %.0f Hz scans, %.0f Hz poses, %.1f s robot time at %.2fx, domain %u, "
              "template %s (%zu robots, lap %.1f s), station %s, method %s, write interval %.0f s, load %s",
              o.robots, o.scan_hz, o.pose_hz, o.duration_s, o.warp, domain,
              o.dataset.empty() ? "synthetic survey" : o.dataset.c_str(), n_templates, templates[0].lap_s,
              o.station.empty() ? "(external)" : o.station.c_str(), o.method.c_str(), o.write_interval_s,
              slurp("/proc/loadavg").c_str());

  static teamscan_msg_ScanPoints scan_msg;
  teamscan_msg_RobotPose pose_msg{};
  teamscan_msg_RobotStatus status_msg{};
  struct Robot {
    std::uint32_t id = 0;
    const TemplateRobot* t = nullptr;
    double ox_m = 0, oy_m = 0;
    std::size_t phase = 0;  // template scan index offset
    std::uint64_t scans = 0, poses = 0, statuses = 0;
  };
  std::vector<Robot> robots(static_cast<std::size_t>(o.robots));
  for (int i = 0; i < o.robots; ++i) {
    Robot& r = robots[static_cast<std::size_t>(i)];
    r.id = static_cast<std::uint32_t>(i + 1);
    r.t = &templates[static_cast<std::size_t>(i) % n_templates];
    const int cell = i / static_cast<int>(n_templates);
    r.ox_m = (cell % 8) * cell_m;
    r.oy_m = (cell / 8) * cell_m;
    r.phase = (static_cast<std::size_t>(cell) * 37) % r.t->scans.size();  // cells not in lock-step
  }

  // Wall schedule: robot i's k-th scan at start + (k + i/N) / (scan_hz · warp); poses and status alike.
  const double scan_dt = 1.0 / (o.scan_hz * o.warp), pose_dt = 1.0 / (o.pose_hz * o.warp), status_dt = 1.0 / (o.status_hz * o.warp);
  const auto total_scans = static_cast<std::uint64_t>(o.duration_s * o.scan_hz);
  const Time wall0 = now_monotonic();
  const double cpu0 = station_pid > 0 ? read_cpu_s(station_pid) : 0;
  struct RssSample {
    double robot_s;
    long kib;
  };
  std::vector<RssSample> rss;
  if (station_pid > 0) {
    if (auto k = read_rss_kib(station_pid)) rss.push_back({0.0, *k});
  }
  Time next_rss = wall0 + std::chrono::seconds(1);
  std::uint64_t published = 0, write_errors = 0, late = 0;
  double max_late_ms = 0;
  std::string stopped_because;
  std::uint64_t k_scan = 0, k_pose = 0, k_status = 0;
  const auto nr = static_cast<double>(o.robots);
  for (;;) {
    // The next event: scan round k_scan, pose round k_pose, status round k_status (each spread over robots).
    const double t_scan = static_cast<double>(k_scan) * scan_dt;
    const double t_pose = static_cast<double>(k_pose) * pose_dt;
    const double t_status = static_cast<double>(k_status) * status_dt;
    if (k_scan >= total_scans) break;
    const double t_next = std::min({t_scan, t_pose, t_status});
    const Time due = wall0 + from_seconds(t_next);
    Time now = now_monotonic();
    if (due > now) {
      std::this_thread::sleep_for(std::chrono::nanoseconds((due - now).count()));
      now = now_monotonic();
    } else if (to_seconds(now - due) > scan_dt) {
      ++late;
      max_late_ms = std::max(max_late_ms, to_seconds(now - due) * 1e3);
    }
    const double robot_s = t_next * o.warp;
    if (station_pid > 0 && now >= next_rss) {
      next_rss = now + std::chrono::seconds(1);
      if (auto kib = read_rss_kib(station_pid)) {
        rss.push_back({robot_s, *kib});
        if (static_cast<double>(*kib) / 1024.0 > o.rss_guard_mib) {
          stopped_because = "station RSS above --rss-guard-mib " + std::to_string(static_cast<int>(o.rss_guard_mib));
          break;
        }
      } else {
        stopped_because = "the station exited";
        break;
      }
    }
    if (o.max_wall_s > 0 && to_seconds(now - wall0) > o.max_wall_s) {
      stopped_because = "--max-wall reached";
      break;
    }
    if (t_next == t_scan) {
      // One scan of every robot (robot i is offset by i/N of a period: spread, not a burst).
      for (std::size_t i = 0; i < robots.size(); ++i) {
        Robot& r = robots[i];
        const Time robot_due = wall0 + from_seconds(t_scan + scan_dt * static_cast<double>(i) / nr);
        const Time n2 = now_monotonic();
        if (robot_due > n2) std::this_thread::sleep_for(std::chrono::nanoseconds((robot_due - n2).count()));
        const std::size_t idx = (k_scan + r.phase) % r.t->scans.size();
        const ScanRecord& rec = r.t->scans[idx];
        const auto& pts = r.t->points[idx];
        scan_msg.robot_id = r.id;
        scan_msg.seq = static_cast<std::uint32_t>(k_scan + 1);
        scan_msg.stamp_ns = now_realtime().ns();
        scan_msg.origin_x_mm = mm(rec.origin.x + r.ox_m);
        scan_msg.origin_y_mm = mm(rec.origin.y + r.oy_m);
        scan_msg.origin_z_mm = mm(rec.origin.z);
        scan_msg.count = static_cast<std::uint16_t>(pts.size());
        const std::int32_t dx = mm(r.ox_m), dy = mm(r.oy_m);
        for (std::size_t p = 0; p < pts.size(); ++p) {
          scan_msg.points[p] = pts[p];
          scan_msg.points[p].x_mm += dx;
          scan_msg.points[p].y_mm += dy;
        }
        if (dds_write(pub.robots->writer(test::RobotWriters::kScan, scan_msg.robot_id), &scan_msg) < 0) ++write_errors;
        ++r.scans;
        ++published;
      }
      ++k_scan;
    } else if (t_next == t_pose) {
      for (Robot& r : robots) {
        // The template's odometry at the same lap time as the scan stream (nearest sample at or before).
        const TemplateRobot& t = *r.t;
        const double lap_t = std::fmod(robot_s + static_cast<double>(r.phase) / o.scan_hz, t.lap_s);
        const std::int64_t at_ns = t.t0_ns + static_cast<std::int64_t>(lap_t * 1e9);
        auto it = std::upper_bound(t.odom.begin(), t.odom.end(), at_ns,
                                   [](std::int64_t v, const TrajectorySample& s) { return v < s.stamp_ns; });
        const TrajectorySample& s = it == t.odom.begin() ? *it : *(it - 1);
        pose_msg.robot_id = r.id;
        pose_msg.seq = static_cast<std::uint32_t>(k_pose + 1);
        pose_msg.stamp_ns = now_realtime().ns();
        pose_msg.x_mm = mm(s.pose.x_m + r.ox_m);
        pose_msg.y_mm = mm(s.pose.y_m + r.oy_m);
        pose_msg.yaw_urad = static_cast<std::int32_t>(std::lround(std::remainder(s.pose.theta_rad, 2 * kPi) * 1e6));
        // Velocities in wall-clock units: the robot covers its path `warp` times faster than recorded.
        pose_msg.vx_mmps = mm(s.v_mps * o.warp * std::cos(s.pose.theta_rad));
        pose_msg.vy_mmps = mm(s.v_mps * o.warp * std::sin(s.pose.theta_rad));
        pose_msg.yaw_rate_mradps = mm(s.w_radps * o.warp);
        if (dds_write(pub.robots->writer(test::RobotWriters::kPose, pose_msg.robot_id), &pose_msg) < 0) ++write_errors;
        ++r.poses;
      }
      ++k_pose;
    } else {
      for (Robot& r : robots) {
        status_msg = teamscan_msg_RobotStatus{};
        status_msg.robot_id = r.id;
        status_msg.seq = static_cast<std::uint32_t>(k_status + 1);
        status_msg.stamp_ns = now_realtime().ns();
        status_msg.arcos_state = 1;
        status_msg.lms_state = 1;
        status_msg.scan_rate_mhz = static_cast<std::uint32_t>(o.scan_hz * 1000);
        status_msg.scans_published = static_cast<std::uint32_t>(r.scans);
        status_msg.uptime_s = static_cast<std::uint32_t>(robot_s);
        if (dds_write(pub.robots->writer(test::RobotWriters::kStatus, status_msg.robot_id), &status_msg) < 0) ++write_errors;
        ++r.statuses;
      }
      ++k_status;
    }
  }
  const double feed_wall_s = to_seconds(now_monotonic() - wall0);
  const double robot_s_done = static_cast<double>(k_scan) / o.scan_hz;
  (void)pub.robots->wait_for_acks(DDS_SECS(30));
  std::printf("fed: %" PRIu64 " scans in %.1f s wall (%.1f s robot time, %.0f scans/s), write errors %" PRIu64
              ", feeder late %" PRIu64 " times (max %.1f ms)%s%s\n",
              published, feed_wall_s, robot_s_done, static_cast<double>(published) / feed_wall_s, write_errors, late,
              max_late_ms, stopped_because.empty() ? "" : "; STOPPED EARLY: ", stopped_because.c_str());
  if (station_pid <= 0) return 0;

  // Let the station take its backlog (scans.bin stops growing for 1.5 s; at most 60 s), then measure
  // and stop it: what it has not stored by then counts as lost.
  {
    std::error_code ec;
    std::uintmax_t last = 0;
    auto still_since = std::chrono::steady_clock::now();
    const auto drain_deadline = still_since + std::chrono::seconds(60);
    while (std::chrono::steady_clock::now() < drain_deadline) {
      const std::uintmax_t size = std::filesystem::file_size(session + "/scans.bin", ec);
      if (size != last) {
        last = size;
        still_since = std::chrono::steady_clock::now();
      } else if (std::chrono::steady_clock::now() - still_since > std::chrono::milliseconds(1500)) {
        break;
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(250));
    }
  }
  const double cpu1 = read_cpu_s(station_pid);
  const double measured_wall_s = to_seconds(now_monotonic() - wall0);
  if (auto kib = read_rss_kib(station_pid)) rss.push_back({robot_s_done, *kib});
  ::kill(station_pid, SIGTERM);
  // The stop: the station's last work (the final model on the graph's poses, its writes) and its RSS
  // meanwhile, sampled as it runs.
  bool exited = false;
  int exit_status = 0;
  long stop_max_kib = 0;
  const auto stop_started = std::chrono::steady_clock::now();
  const auto deadline = stop_started + std::chrono::milliseconds(static_cast<long>(o.stop_timeout_s * 1000));
  while (std::chrono::steady_clock::now() < deadline) {
    if (auto kib = read_rss_kib(station_pid)) stop_max_kib = std::max(stop_max_kib, *kib);
    if (::waitpid(station_pid, &exit_status, WNOHANG) == station_pid) {
      exited = true;
      break;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  const double stop_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - stop_started).count();
  if (!exited) {
    ::kill(station_pid, SIGKILL);
    int st = 0;
    (void)::waitpid(station_pid, &st, 0);
  }

  // Stored: unique (robot, seq) accepted records in scans.bin; fused: fused_latency.csv.
  std::set<std::pair<std::uint32_t, std::uint32_t>> stored;
  std::uint64_t refused = 0;
  station::ScanDecodeStats stats;
  std::string err;
  (void)station::read_scan_file(session + "/scans.bin", [&](const ScanPoints& s, const station::Receipt& receipt) {
    if (receipt.rejected != 0) {
      ++refused;
      return;
    }
    stored.insert({s.robot_id, s.seq});
  }, stats, err);
  std::vector<double> lat_ms;
  std::vector<std::pair<std::int64_t, double>> fused_at;  // (fused_ns, latency ms)
  // Steady state (scans stamped after the first --warmup seconds of the feed; the fusion core releases
  // nothing in its first hold_s): scan -> fused map, split into scan -> taken from DDS (transport and the
  // station's queue) and taken -> fused (held for the team state, then fused).
  std::vector<double> steady_ms, steady_taken_ms, steady_held_ms;
  {
    std::ifstream in(session + "/fused_latency.csv");
    std::string line;
    struct Row {
      long long stamp, recv, fused;
    };
    std::vector<Row> rows;
    long long first_stamp = LLONG_MAX;
    while (std::getline(in, line)) {
      unsigned robot = 0, seq = 0;
      long long stamp = 0, recv = 0, fused = 0;
      if (std::sscanf(line.c_str(), "%u,%u,%lld,%lld,%lld", &robot, &seq, &stamp, &recv, &fused) != 5) continue;
      lat_ms.push_back(static_cast<double>(fused - stamp) * 1e-6);
      fused_at.emplace_back(fused, lat_ms.back());
      rows.push_back({stamp, recv, fused});
      first_stamp = std::min(first_stamp, stamp);
    }
    const long long steady_from = first_stamp + static_cast<long long>(o.warmup_s * 1e9);
    for (const Row& r : rows) {
      if (r.stamp < steady_from) continue;
      steady_ms.push_back(static_cast<double>(r.fused - r.stamp) * 1e-6);
      steady_taken_ms.push_back(static_cast<double>(r.recv - r.stamp) * 1e-6);
      steady_held_ms.push_back(static_cast<double>(r.fused - r.recv) * 1e-6);
    }
  }
  const std::uint64_t lost = published > stored.size() ? published - stored.size() : 0;
  std::printf("station: stored %zu (refused %" PRIu64 "), fused %zu, lost %" PRIu64
              "; scan -> fused map p50 %.1f ms, p99 %.1f ms, max %.1f ms; CPU %.1f s over %.1f s = %.0f %% of one core\n",
              stored.size(), refused, lat_ms.size(), lost, quantile(lat_ms, 0.5), quantile(lat_ms, 0.99),
              lat_ms.empty() ? 0.0 : *std::max_element(lat_ms.begin(), lat_ms.end()), cpu1 - cpu0, measured_wall_s,
              100.0 * (cpu1 - cpu0) / measured_wall_s);
  std::printf("steady (stamped after the first %.1f s): %zu scans; scan -> fused map p50 %.1f ms, p99 %.1f ms, max %.1f ms; "
              "of which scan -> taken p50 %.1f / p99 %.1f ms, taken -> fused p50 %.1f / p99 %.1f ms\n",
              o.warmup_s, steady_ms.size(), quantile(steady_ms, 0.5), quantile(steady_ms, 0.99),
              steady_ms.empty() ? 0.0 : *std::max_element(steady_ms.begin(), steady_ms.end()), quantile(steady_taken_ms, 0.5),
              quantile(steady_taken_ms, 0.99), quantile(steady_held_ms, 0.5), quantile(steady_held_ms, 0.99));
  if (!rss.empty()) {
    std::printf("station RSS (MiB) at robot time:");
    const std::size_t n = rss.size();
    for (int q = 0; q <= 4; ++q) {
      const RssSample& s = rss[std::min(n - 1, static_cast<std::size_t>(q) * (n - 1) / 4)];
      std::printf(" %s %.0f s: %.1f", q == 0 ? "start" : q == 4 ? "end" : ("q" + std::to_string(q)).c_str(), s.robot_s,
                  static_cast<double>(s.kib) / 1024.0);
    }
    long max_kib = 0;
    for (const RssSample& s : rss) max_kib = std::max(max_kib, s.kib);
    std::printf("; max %.1f\n", static_cast<double>(max_kib) / 1024.0);
  }
  // Periodic model writes (events.log, logged by the loop when a write finished: "fused model written
  // (periodic): ...; snapshot S s in the loop (K slices, longest L ms, over T s), write W s on the writer
  // thread (... N requests coalesced)"): when, the loop's time on the snapshot and its longest stall, the
  // writer thread's time, and the p99 of the scans fused while a write ran (snapshot start to logged end)
  // against the rest.
  struct WriteEvent {
    std::int64_t start_ns = 0, end_ns = 0;
    double snapshot_s = 0, slice_max_ms = 0, span_s = 0, write_s = 0;
    unsigned slices = 0;
  };
  // The live map following the pose graph (events.log: "fusion: the map follows the pose graph's
  // estimate (N nodes, M loop closures): S scans of the session decided again in T s (K loop turns, at
  // most L ms of one; ...)"): how many, the longest, the longest loop turn, the last one's line.
  {
    std::ifstream in(session + "/events.log");
    std::string line, last;
    unsigned follows = 0;
    double longest_s = 0.0, turn_max_ms = 0.0;
    while (std::getline(in, line)) {
      const auto at = line.find("the map follows the pose graph's estimate");
      if (at == std::string::npos) continue;
      ++follows;
      last = line.substr(at);
      double t_s = 0.0, turn_ms = 0.0;
      unsigned long long scans = 0, turns = 0;
      const auto d = line.find(": ", at);
      const auto moved = line.find(" model points moved rigidly", at);  // a rigid follow's line
      const auto from = moved != std::string::npos ? line.find(" in ", moved) : std::string::npos;
      if (from != std::string::npos &&
          std::sscanf(line.c_str() + from, " in %lf s (%llu loop turns, at most %lf ms", &t_s, &turns, &turn_ms) == 3) {
        longest_s = std::max(longest_s, t_s);
        turn_max_ms = std::max(turn_max_ms, turn_ms);
      } else if (d != std::string::npos &&
          std::sscanf(line.c_str() + d, ": %llu scans of the session decided again in %lf s (%llu loop turns, at most %lf ms",
                      &scans, &t_s, &turns, &turn_ms) == 4) {
        longest_s = std::max(longest_s, t_s);
        turn_max_ms = std::max(turn_max_ms, turn_ms);
      }
    }
    if (follows > 0)
      std::printf("graph follows: %u, the longest %.2f s, the longest loop turn %.1f ms; the last: %s\n", follows, longest_s,
                  turn_max_ms, last.c_str());
  }
  std::vector<WriteEvent> writes;
  unsigned long long coalesced = 0;
  {
    std::ifstream in(session + "/events.log");
    std::string line;
    while (std::getline(in, line)) {
      if (line.find("fused model written (periodic)") == std::string::npos) continue;
      WriteEvent w;
      w.end_ns = std::atoll(line.c_str());
      const auto at = line.find("snapshot ");
      if (at == std::string::npos ||
          std::sscanf(line.c_str() + at, "snapshot %lf s in the loop (%u slices, longest %lf ms, over %lf s), write %lf s",
                      &w.snapshot_s, &w.slices, &w.slice_max_ms, &w.span_s, &w.write_s) != 5)
        continue;
      if (const auto c = line.find(" requests coalesced"); c != std::string::npos) {
        const auto from = line.rfind(' ', c - 1);
        coalesced = std::strtoull(line.c_str() + from + 1, nullptr, 10);
      }
      w.start_ns = w.end_ns - static_cast<std::int64_t>((w.span_s + w.write_s) * 1e9);
      writes.push_back(w);
    }
  }
  if (!writes.empty()) {
    std::vector<double> during, outside;
    for (const auto& [fused, ms] : fused_at) {
      bool in = false;
      for (const WriteEvent& w : writes) in = in || (fused >= w.start_ns && fused <= w.end_ns);
      (in ? during : outside).push_back(ms);
    }
    const std::int64_t feed_start_rt = now_realtime().ns() - static_cast<std::int64_t>(to_seconds(now_monotonic() - wall0) * 1e9);
    double stall_max_ms = 0, write_max_s = 0;
    std::printf("model writes: %zu (%llu requests coalesced); at robot time (s): snapshot in the loop (ms, slices, "
                "longest slice ms, span s) / writer thread (s):",
                writes.size(), coalesced);
    for (const WriteEvent& w : writes) {
      std::printf(" %.0f: %.1f, %u, %.1f, %.1f / %.2f", static_cast<double>(w.start_ns - feed_start_rt) * 1e-9 * o.warp,
                  w.snapshot_s * 1e3, w.slices, w.slice_max_ms, w.span_s, w.write_s);
      stall_max_ms = std::max(stall_max_ms, w.slice_max_ms);
      write_max_s = std::max(write_max_s, w.write_s);
    }
    std::printf("\nmodel writes: longest loop stall %.1f ms, longest write on the writer thread %.2f s\n", stall_max_ms, write_max_s);
    std::printf("scan -> fused map p99 during writes %.1f ms (%zu scans), outside writes %.1f ms (%zu scans)\n",
                quantile(during, 0.99), during.size(), quantile(outside, 0.99), outside.size());
  }
  if (!exited) {
    std::printf("station exit: killed after --stop-timeout (final model pass not waited for)");
  } else if (WIFEXITED(exit_status) && WEXITSTATUS(exit_status) == 0) {
    std::printf("station exit: clean (final model pass done)");
  } else if (WIFSIGNALED(exit_status)) {
    std::printf("station exit: died of signal %d", WTERMSIG(exit_status));
  } else {
    std::printf("station exit: exit code %d", WIFEXITED(exit_status) ? WEXITSTATUS(exit_status) : -1);
  }
  std::printf(" after %.1f s; RSS at most %.1f MiB during the stop\n", stop_s, static_cast<double>(stop_max_kib) / 1024.0);
  {
    // The station's pose graph ([pose_graph]): its line at the stop (scans, nodes, how far it was behind),
    // and how often the live map followed it.
    std::ifstream in(session + "/events.log");
    std::string line;
    while (std::getline(in, line)) {
      if (const auto at = line.find("pose graph: "); at != std::string::npos) std::printf("%s\n", line.c_str() + at);
      if (const auto at = line.find("fusion: the live map followed"); at != std::string::npos) std::printf("%s\n", line.c_str() + at);
    }
  }
  if (!o.keep_session && o.session_dir.empty()) {
    std::error_code ec;
    std::filesystem::remove_all(work, ec);
  } else {
    std::printf("session: %s\n", session.c_str());
  }
  return 0;
}
