// `teamscan demo`: the whole system live on one machine. The scenario's robots as emulated devices on
// ptys fed by the simulator in real time (sim/live.hpp), one real teamscan-onboard per robot, one real
// teamscan-groundstation, Cyclone DDS on loopback; at the end the ground station's session is scored
// against the simulator's truth with the same code as `teamscan eval` and compared with an offline
// simulation of the same scenario and seed (docs/demo.md).
#include <fcntl.h>
#include <signal.h>
#include <sys/prctl.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <map>
#include <memory>
#include <optional>
#include <set>
#include <sstream>
#include <string>
#include <thread>
#include <unordered_map>
#include <vector>

#include "common/clock.hpp"
#include "common/data_paths.hpp"
#include "common/dataset/dataset.hpp"
#include "common/dataset/pcd.hpp"
#include "common/laser_geometry.hpp"
#include "common/scan_points.hpp"
#include "groundstation/fusion/evaluation.hpp"
#include "groundstation/station/config.hpp"
#include "groundstation/station/model_check.hpp"
#include "groundstation/station/scan_record.hpp"
#include "sim/live.hpp"
#include "sim/scenario.hpp"
#include "sim/simulator.hpp"
#include "tools/pki/site_pki.hpp"
#include "tools/teamscan/subcommand.hpp"
#if __has_include("tools/render/render.hpp")
#include "tools/render/render.hpp"
#define TEAMSCAN_DEMO_RENDER 1
#endif

namespace teamscan::tool {
namespace {

namespace fs = std::filesystem;

std::atomic<int> g_demo_signal{0};
extern "C" void demo_on_signal(int sig) { g_demo_signal.store(sig); }

struct DemoArgs {
  std::string scenario = "lap2";
  double speed = 1.0;
  bool force_speed = false;  // run above real time although the live figures are then not honest
  std::optional<int> robots;
  std::optional<double> duration_s;
  std::string out = "demo-out";
  std::optional<std::uint64_t> seed;
  double bringup_s = 6.0;
  std::optional<int> domain;
  std::string dds_config;
  std::string onboard_bin, station_bin;
  // Agreement with offline eval, percentage points (docs/demo.md "Tolerance").
  double tolerance_da_pct = 5.0;
  double tolerance_sa_pct = 1.0;
  double tolerance_map_sa_pct = 8.0;  // the map-based methods (frequency, visibility, combined)
  double tolerance_map_da_pct = 10.0;
  std::string methods = "all";
  bool quiet = false;
  // Live faults (docs/demo.md "Faults"), times in seconds of world time.
  std::optional<double> kill_station_at_s;
  double station_down_s = 2.0;
  std::optional<int> unplug_robot;
  double unplug_at_s = 0, unplug_for_s = 2.0;
  std::optional<int> kill_robot;
  double kill_robot_at_s = 0;
  // Onboard [odometry] max_hold_s (unset: the daemon's default, docs/demo.md "Latency").
  std::optional<double> max_hold_s;
  // Station [fusion] write_interval_s (0: the model is written once, at shutdown).
  double write_interval_s = 0.0;
  // The ground station's live fusion method (its [fusion] method); the demo scores its model.
  std::string station_method = "best";
  // The station's [ros2] publishers (rt/teamscan/map_cloud, rt/tf, rt/robotN/odom; docs/ros2.md).
  bool station_ros2 = true;
  // The device feeder: one thread steps every pty this often (ms); 0: a thread per pty (sim/live.hpp).
  double feed_period_ms = 1.0;
  bool no_precast = false;  // cast every scan in real time instead of ahead (sim/live.hpp precast)
  bool secure = false;      // DDS Security with a throwaway site PKI in <out>/pki (docs/security.md)
  // The station's browser view on 127.0.0.1:PORT (its [view] listen; unset: off), docs/view.md.
  std::optional<int> view_port;
};

// The first of `candidates` that exists.
std::string find_file(const std::vector<std::string>& candidates) {
  for (const std::string& c : candidates) {
    std::error_code ec;
    if (fs::exists(c, ec)) return fs::absolute(c).lexically_normal().string();
  }
  return {};
}

std::string find_binary(const std::string& name, const std::string& sub) {
  const std::string d = executable_dir();
  std::string f = find_file({d + "/" + name, d + "/../../" + sub + "/" + name, d + "/../bin/" + name});
  if (!f.empty()) return f;
  if (const char* path = std::getenv("PATH")) {
    std::stringstream ss{path};
    for (std::string dir; std::getline(ss, dir, ':');)
      if (::access((dir + "/" + name).c_str(), X_OK) == 0) return dir + "/" + name;
  }
  return {};
}

bool write_text(const std::string& path, const std::string& text) {
  std::ofstream o(path, std::ios::trunc);
  o << text;
  return static_cast<bool>(o);
}

std::string fmt(const char* f, double v) {
  char b[64];
  std::snprintf(b, sizeof b, f, v);
  return b;
}

// The onboard config of one robot: ports = the pty symlinks, mount/variant/registration from the scenario.
std::string onboard_config(const sim::RobotSpec& spec, const Pose2& registration, const std::string& arcos,
                           const std::string& lms, int domain, std::optional<double> max_hold_s) {
  std::ostringstream o;
  o << "# generated by teamscan demo for " << spec.name << " (" << spec.role << ")\n";
  o << "[robot]\nid = " << unsigned(spec.id) << "\n\n";
  o << "[arcos]\ndevice = \"" << arcos << "\"\nbaud = " << spec.arcos_baud << "\n\n";
  o << "[lms]\ndevice = \"" << lms << "\"\nbaud = " << spec.lms_baud << "\nfov_deg = " << spec.variant.fov_deg
    << "\nresolution_deg = " << fmt("%g", spec.variant.resolution_cdeg / 100.0)
    << "\nunits = \"mm\"\nmax_range_m = 8.0\n\n";
  o << "[mount]\nx_m = " << fmt("%.6f", spec.mount_xyz_m[0]) << "\ny_m = " << fmt("%.6f", spec.mount_xyz_m[1])
    << "\nz_m = " << fmt("%.6f", spec.mount_xyz_m[2]) << "\nroll_deg = " << fmt("%.6f", rad_to_deg(spec.mount_rpy_rad[0]))
    << "\npitch_deg = " << fmt("%.6f", rad_to_deg(spec.mount_rpy_rad[1]))
    << "\nyaw_deg = " << fmt("%.6f", rad_to_deg(spec.mount_rpy_rad[2])) << "\n\n";
  o << "[registration]\nx_m = " << fmt("%.6f", registration.x_m) << "\ny_m = " << fmt("%.6f", registration.y_m)
    << "\ntheta_deg = " << fmt("%.6f", rad_to_deg(registration.theta_rad)) << "\n\n";
  o << "[filter]\nenabled = true\nhalf_angle_deg = 7.0\nrange_gate = true\nrange_gate_margin_m = 0.3\n"
       "height_gate = true\nheight_gate_margin_m = 0.1\nbody_radius_m = 0.36\nheight_m = 0.5\nmax_team_age_s = 0.5\n"
       "stale_policy = \"widen\"\nstale_growth_deg_per_s = 10.0\nextrapolate_team = true\n\n";
  o << "[dds]\ndomain = " << domain << "\npublish = \"all\"\nscan_history_depth = 300\n\n";
  o << "[status]\nperiod_s = 1.0\n\n[odometry]\nmax_extrapolation_s = 0.2\n";
  if (max_hold_s) o << "max_hold_s = " << fmt("%.6f", *max_hold_s) << "\n";
  return o.str();
}

std::string station_config(const std::string& session_root, int domain, const std::string& method,
                           double write_interval_s, bool ros2, std::optional<int> view_port) {
  std::ostringstream o;
  o << "# generated by teamscan demo\n[station]\nsession_root = \"" << session_root
    << "\"\nsync_interval_s = 1.0\nstatus_interval_s = 1.0\n\n[dds]\ndomain_id = " << domain
    << "\nscan_history_depth = 300\ntake_batch = 64\n\n[team]\npublish_rate_hz = 20.0\nliveliness_lease_s = 2.0\n"
       "silence_timeout_s = 5.0\n\n[team.body]\nlength_m = 0.508\nwidth_m = 0.497\nheight_m = 0.80\n\n"
       "[team.last_pose]\nsigma0_m = 0.05\nsigma_velocity_mps = 0.30\nmax_extrapolation_s = 0.5\n\n"
       "[team.kalman]\naccel_noise_mps2 = 0.5\nposition_noise_m = 0.02\nvelocity_noise_mps = 0.05\nlost_after_s = 1.0\n";
  // The live fusion stage: its fused_all.pcd (every point with the station's keep flags and scan/beam
  // ids) is what the demo scores against the truth (docs/demo.md "Scoring the live model").
  // write_interval_s (--write-interval; default 0: the model is written once, at shutdown). Periodic
  // writes run on the station's ModelWriter thread from the session files, off the receive loop
  // (docs/groundstation.md "Model writes"); the demo scores the shutdown model either way.
  o << "\n[fusion]\nenabled = true\nmethod = \"" << method << "\"\nresolution_m = 0.1\nhalf_angle_deg = 7.0\n"
       "write_all_points = true\nwrite_interval_s = "
    << write_interval_s << "\nlatency_log = true\n";
  // ROS 2 wire names, for RViz2 / Foxglove watching the demo (docs/ros2.md; --station-ros2 false: off).
  o << "\n[ros2]\nenabled = " << (ros2 ? "true" : "false") << "\n";
  // The browser view only when asked for (--view PORT): loopback only.
  o << "\n[view]\nlisten = \"" << (view_port ? "127.0.0.1:" + std::to_string(*view_port) : std::string{}) << "\"\n";
  return o.str();
}

// A child process of the demo, in the demo's own process group (so Ctrl-C on the terminal reaches only
// the demo, which then stops its children in order).
struct Child {
  std::string name;
  std::string log;
  pid_t pid = -1;
  int exit_code = -1;  // 128 + signal if killed
  bool exited = false;
  double cpu_s = 0;    // user + system CPU time (from wait4)
  double run_cpu_s = 0;  // user + system CPU time up to the end of the run (before stopping)
};

// utime + stime of a live process (/proc/PID/stat fields 14 and 15), seconds; 0 if unreadable.
double proc_cpu_s(pid_t pid) {
  if (pid <= 0) return 0;
  std::ifstream in("/proc/" + std::to_string(pid) + "/stat");
  std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const auto close = text.rfind(')');
  if (close == std::string::npos) return 0;
  std::istringstream fields(text.substr(close + 2));
  std::string f;
  double ticks = 0;
  for (int k = 3; k <= 15 && fields >> f; ++k)
    if (k == 14 || k == 15) ticks += std::stod(f);
  return ticks / static_cast<double>(::sysconf(_SC_CLK_TCK));
}

pid_t g_pgid = 0;

Result<pid_t> spawn(const std::vector<std::string>& argv, const std::string& log) {
  const pid_t pid = ::fork();
  if (pid < 0) return Error{"fork failed", errno};
  if (pid == 0) {
    ::setpgid(0, g_pgid);  // g_pgid == 0 for the first child: a new group led by it
    ::prctl(PR_SET_PDEATHSIG, SIGTERM);  // the demo killed outright (SIGKILL): its children still stop
    ::signal(SIGINT, SIG_DFL);
    ::signal(SIGTERM, SIG_DFL);
    const int fd = ::open(log.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
    if (fd >= 0) {
      ::dup2(fd, 1);
      ::dup2(fd, 2);
    }
    std::vector<char*> args;
    for (const std::string& a : argv) args.push_back(const_cast<char*>(a.c_str()));
    args.push_back(nullptr);
    ::execv(args[0], args.data());
    std::fprintf(stderr, "exec %s: %s\n", args[0], std::strerror(errno));
    ::_exit(127);
  }
  ::setpgid(pid, g_pgid);  // also from the parent: no race with the child's own call
  if (g_pgid == 0) g_pgid = pid;
  return pid;
}

void reap(Child& c, bool block) {
  if (c.exited || c.pid <= 0) return;
  int st = 0;
  struct rusage ru{};
  const pid_t r = ::wait4(c.pid, &st, block ? 0 : WNOHANG, &ru);
  if (r == c.pid) {
    c.exited = true;
    c.cpu_s = static_cast<double>(ru.ru_utime.tv_sec + ru.ru_stime.tv_sec) + 1e-6 * static_cast<double>(ru.ru_utime.tv_usec + ru.ru_stime.tv_usec);
    c.exit_code = WIFEXITED(st) ? WEXITSTATUS(st) : 128 + WTERMSIG(st);
  }
}

// SIGTERM, then SIGKILL after `grace`.
void stop_child(Child& c, std::chrono::milliseconds grace) {
  reap(c, false);
  if (c.exited || c.pid <= 0) return;
  ::kill(c.pid, SIGTERM);
  const auto end = std::chrono::steady_clock::now() + grace;
  while (std::chrono::steady_clock::now() < end) {
    reap(c, false);
    if (c.exited) return;
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  ::kill(c.pid, SIGKILL);
  reap(c, true);
}

struct StatusRow {
  std::uint32_t robot = 0;
  std::uint32_t scans_published = 0;
  unsigned lms_state = 0;
};

std::vector<std::vector<std::string>> read_csv(const std::string& path) {
  std::vector<std::vector<std::string>> rows;
  std::ifstream in(path);
  for (std::string line; std::getline(in, line);) {
    if (line.empty() || !std::isdigit(static_cast<unsigned char>(line[0]))) continue;
    std::vector<std::string> f;
    std::stringstream ss{line};
    for (std::string s; std::getline(ss, s, ',');) f.push_back(s);
    rows.push_back(std::move(f));
  }
  return rows;
}

// What the ground station stored of one robot.
struct RobotDelivery {
  std::uint8_t id = 0;
  std::uint64_t stored = 0, duplicates = 0, gaps = 0;  // gaps: seq numbers missing between first and last
  std::uint32_t seq_first = 0, seq_last = 0;
  std::uint32_t last_status_published = 0;  // scans_published in the robot's last status
  std::uint64_t in_window = 0, truth_matched = 0, truth_unmatched = 0;
  std::uint64_t measured = 0;  // scans the emulated LMS sent
  std::uint64_t truth_ghost_beams = 0;  // beams cast on a teammate within the run window
};

// Live session -> labelled data set on the simulator's time base (scenario start + world time).
struct LiveDataset {
  Dataset ds;
  std::vector<RobotDelivery> delivery;
  station::ScanDecodeStats decode;
  std::vector<double> latency_ms;  // scan stamp (sweep end) -> stored by the station, per stored scan
  std::vector<std::uint32_t> point_seq;  // per ds.points: the robot's scan sequence number (the station's `scan`)
  std::vector<double> point_error_mm;    // per point with a true hit: |measured − true hit point|
};

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

LiveDataset build_live_dataset(const std::string& session, sim::LiveTeam& live, const std::vector<std::vector<sim::LiveScanTruth>>& truths,
                               const sim::Scenario& scenario, const sim::TeamWorld& team, const Dataset& offline,
                               double duration_s) {
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
  auto team_index = [&](std::uint8_t id) {
    for (std::size_t k = 0; k < team.robot_count(); ++k)
      if (team.spec(k).id == id) return k;
    return std::size_t{0};
  };
  const std::int64_t end_ns = scenario.start_time_ns + static_cast<std::int64_t>(duration_s * 1e9);

  // Odometry as the robots published it (poses.csv), truth from the tracks at the same instants.
  for (const auto& f : read_csv(session + "/poses.csv")) {
    if (f.size() < 11) continue;
    const auto id = static_cast<std::uint8_t>(std::stoul(f[2]));
    if (!live_index.count(id)) continue;
    const std::int64_t t = to_sim_ns(std::stoll(f[4]));
    if (t < scenario.start_time_ns || t > end_ns + 200'000'000) continue;
    TrajectorySample o;
    o.robot = id;
    o.stamp_ns = t;
    o.pose = {std::stod(f[5]) * 1e-3, std::stod(f[6]) * 1e-3, std::stod(f[7]) * 1e-6};
    // The tracker is fed the forward speed, as the station's (common/pose.hpp).
    o.v_mps = forward_speed_mps(std::stod(f[8]) * 1e-3, std::stod(f[9]) * 1e-3, o.pose.theta_rad);
    o.w_radps = std::stod(f[10]) * 1e-3;
    ds.odom.push_back(o);
    const sim::Motion& m = team.motion(team_index(id));
    const double ts = static_cast<double>(t - scenario.start_time_ns) * 1e-9;
    ds.truth.push_back({id, t, m.pose_at(ts), m.speed_at(ts), m.yaw_rate_at(ts)});
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
  station::read_scan_file(session + "/scans.bin", [&](const station::StoredScan& s) {
    const auto id = static_cast<std::uint8_t>(s.robot_id);
    if (!live_index.count(id)) return;
    RobotDelivery& d = del[id];
    d.id = id;
    ++d.stored;
    seqs[id].push_back(s.seq);
    // A restarted ground station gets the robots' history again (DDS transient-local, depth 300): a scan
    // already stored is stored twice; the data set keeps the first.
    if (!seen[id].insert(s.seq).second) return;
    if (s.rejected != 0) return;  // refused at the edge (docs/validation.md): stored, never fused
    const std::int64_t t = to_sim_ns(s.stamp_ns);
    if (t < scenario.start_time_ns || t > end_ns) return;  // bring-up (robots standing) or after the end
    // Latency in the run window only: bring-up (the station matching the robots' writers gets their
    // history) and the ordered shutdown are not the steady state.
    L.latency_ms.push_back(static_cast<double>(s.recv_realtime_ns - s.stamp_ns) * 1e-6);
    ++d.in_window;
    const sim::LiveScanTruth* truth = sim::match_truth(truths[live_index[id]], s.stamp_ns, 6'000'000);
    if (!truth) {
      ++d.truth_unmatched;
      return;
    }
    ++d.truth_matched;
    const sim::Motion& m = team.motion(team_index(id));
    ScanRecord rec;
    rec.robot = id;
    rec.scan = next_scan[id]++;
    rec.stamp_ns = t;
    rec.beams = static_cast<std::uint16_t>(truth->beams.size());
    rec.origin = {s.origin_x_mm * 1e-3, s.origin_y_mm * 1e-3, s.origin_z_mm * 1e-3};
    rec.pose = interpolate_pose(odom_of[id], t);
    rec.true_pose = m.pose_at(static_cast<double>(t - scenario.start_time_ns) * 1e-9);
    for (std::uint16_t k = 0; k < s.count; ++k) {
      const station::StoredPoint& p = s.points[k];
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
  }, L.decode, err);

  std::map<std::uint8_t, std::uint32_t> last_pub;
  for (const auto& f : read_csv(session + "/status.csv"))
    if (f.size() > 13) last_pub[static_cast<std::uint8_t>(std::stoul(f[2]))] = static_cast<std::uint32_t>(std::stoul(f[13]));
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

// The station's latency.csv (groundstation/station/latency_histogram.hpp): the two histograms' summary
// lines, in file order scan -> stored, then scan -> fused map.
struct LatencySummary {
  bool present = false;
  double count = 0, p50_ms = 0, p90_ms = 0, p99_ms = 0, max_ms = 0;
};
std::vector<LatencySummary> read_latency_csv(const std::string& path) {
  std::vector<LatencySummary> out;
  std::ifstream in(path);
  for (std::string line; std::getline(in, line);) {
    const auto comma = line.find(',');
    if (comma == std::string::npos) continue;
    const std::string key = line.substr(0, comma);
    double v = 0;
    try {
      v = std::stod(line.substr(comma + 1));
    } catch (...) {
      continue;
    }
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

// The ground station's own fused model scored against the truth: fused_all.pcd carries per point the
// robot, its scan sequence number, the beam, `keep` (the station's last model write: the offline pass
// over everything it received, docs/groundstation.md) and `live_keep` (the live decision at arrival).
struct StationScore {
  bool present = false;
  std::string error;
  std::uint64_t model_points = 0, matched = 0, unmatched = 0;
  mapping::RemovalMetrics model, live;
  std::vector<std::uint8_t> removed;  // per LiveDataset point (1 = the station's model removed it)
};
StationScore score_station_model(const std::string& path, const LiveDataset& L) {
  StationScore ss;
  auto cloud = read_pcd(path);
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
    return (static_cast<std::uint64_t>(robot) << 48) | (static_cast<std::uint64_t>(seq) << 16) | static_cast<std::uint64_t>(beam);
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
  ss.removed.assign(L.ds.points.size(), 0);
  for (std::size_t i = 0; i < L.ds.points.size(); ++i) {
    const LabelledPoint& p = L.ds.points[i];
    const auto it = flags.find(key(p.robot, L.point_seq[i], p.beam));
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

// The station's fused_latency.csv (fusion.latency_log): scan -> fused map per scan, ms, for the scans
// stamped in [from_ns, to_ns] (CLOCK_REALTIME).
std::vector<double> read_fused_latency_log(const std::string& path, std::int64_t from_ns, std::int64_t to_ns) {
  std::vector<double> out;
  std::ifstream in(path);
  std::string line;
  std::getline(in, line);  // header
  while (std::getline(in, line)) {
    long long stamp = 0, received = 0, fused = 0;
    unsigned robot = 0, seq = 0;
    if (std::sscanf(line.c_str(), "%u,%u,%lld,%lld,%lld", &robot, &seq, &stamp, &received, &fused) != 5) continue;
    if (stamp < from_ns || stamp > to_ns) continue;
    out.push_back(static_cast<double>(fused - stamp) * 1e-6);
  }
  std::sort(out.begin(), out.end());
  return out;
}

double sorted_pct(const std::vector<double>& v, double q) {
  return v.empty() ? 0.0 : v[std::min(v.size() - 1, static_cast<std::size_t>(q * static_cast<double>(v.size())))];
}

std::string json_escape(const std::string& s) {
  std::string o;
  for (char c : s) {
    if (c == '"' || c == '\\') o += '\\';
    o += c;
  }
  return o;
}

int run_demo(const DemoArgs& a) {
  // The robots' and the station's timing is real time (poses at 10 Hz, teamscan/team at 20 Hz, the
  // tracker's noise in m/s²): at --speed s the world moves s times further between two poses, so the
  // ghost filters see their teammates s times staler. Measured at --speed 4 (lap2): the station's best
  // DA 77.9 % and the onboard direction flags 69.2 % against 99.8 % offline. Not an honest figure.
  if (a.speed > 1.0 && !a.force_speed) {
    std::fprintf(stderr,
                 "teamscan demo: --speed %.3g refused: the robots and the station run on real time (10 Hz poses, 20 Hz "
                 "team state), so above real time the ghost filters see teammates --speed times staler and the live "
                 "figures are not comparable with offline (docs/demo.md \"Speed\"); --force-speed runs it anyway\n",
                 a.speed);
    return 2;
  }
  const auto wall_start = std::chrono::steady_clock::now();
  const sim::ScenarioLoad load = sim::resolve_scenario(a.scenario);
  if (!load.scenario) {
    std::fprintf(stderr, "teamscan demo: %s\n", load.error.c_str());
    return 2;
  }
  sim::Scenario scenario = *load.scenario;
  if (a.robots) {
    if (*a.robots < 1 || static_cast<std::size_t>(*a.robots) > scenario.robots.size()) {
      std::fprintf(stderr, "teamscan demo: --robots %d: the scenario has %zu robots\n", *a.robots, scenario.robots.size());
      return 2;
    }
    scenario.robots.resize(static_cast<std::size_t>(*a.robots));
  }
  const sim::TeamWorld team{scenario};
  const double duration_s = a.duration_s.value_or(scenario.duration_s.value_or(team.finish_s()));

  // Loopback DDS, never the default config (DDS_SYSTEMD.md; the children inherit the environment).
  std::string dds = a.dds_config;
  if (dds.empty()) {
    const DataFile lo = find_data_file("cyclonedds-lo.xml", "deploy/cyclonedds-lo.xml");
    if (lo.path.empty()) {
      std::fprintf(stderr, "teamscan demo: cannot find cyclonedds-lo.xml (looked in %s; give --dds-config)\n",
                   lo.searched.c_str());
      return 2;
    }
    dds = lo.path;
  }
  ::setenv("CYCLONEDDS_URI", ("file://" + fs::absolute(dds).string()).c_str(), 1);
  const int domain = a.domain.value_or(1 + static_cast<int>(::getpid() % 230));

  const std::string onboard_bin = a.onboard_bin.empty() ? find_binary("teamscan-onboard", "onboard/daemon") : a.onboard_bin;
  const std::string station_bin =
      a.station_bin.empty() ? find_binary("teamscan-groundstation", "groundstation/station") : a.station_bin;
  if (onboard_bin.empty() || station_bin.empty()) {
    std::fprintf(stderr, "teamscan demo: cannot find teamscan-onboard / teamscan-groundstation (build them, or give --onboard-bin/--station-bin)\n");
    return 2;
  }

  std::error_code ec;
  const std::string out = fs::absolute(a.out).lexically_normal().string();
  fs::create_directories(out + "/logs", ec);
  fs::create_directories(out + "/config", ec);
  fs::remove_all(out + "/session", ec);
  fs::remove_all(out + "/run", ec);
  const std::string session = out + "/session";
  // --secure: a fresh site PKI for this run's domain; every daemon gets its bundle with --pki-dir.
  const std::string pki_dir = out + "/pki";
  auto pki_args = [&](const std::string& name) {
    return a.secure ? std::vector<std::string>{"--pki-dir", pki_dir + "/" + name} : std::vector<std::string>{};
  };
  if (a.secure) {
    fs::remove_all(pki_dir, ec);
    pki::SiteOptions so;
    for (const sim::RobotSpec& r : scenario.robots) so.robots = std::max<std::uint32_t>(so.robots, static_cast<std::uint32_t>(r.id));
    so.domain_min = so.domain_max = static_cast<std::uint32_t>(domain);
    so.now_s = static_cast<std::int64_t>(std::time(nullptr));
    so.identity_days = 2;
    if (const std::string e = pki::create_site(pki_dir, so); !e.empty()) {
      std::fprintf(stderr, "teamscan demo: --secure: %s\n", e.c_str());
      return 1;
    }
  }
  auto with = [](std::vector<std::string> v, const std::vector<std::string>& more) {
    v.insert(v.end(), more.begin(), more.end());
    return v;
  };

  sim::LiveOptions lo;
  lo.run_dir = out + "/run";
  lo.speed = a.speed;
  lo.seed = a.seed;
  lo.bringup_s = a.bringup_s;
  lo.feed_period = from_seconds(a.feed_period_ms * 1e-3);
  auto live_r = sim::LiveTeam::create(scenario, lo);
  if (!live_r) {
    std::fprintf(stderr, "teamscan demo: %s\n", live_r.error().what);
    return 1;
  }
  sim::LiveTeam& live = *live_r.value();

  struct sigaction sa{};
  sa.sa_handler = demo_on_signal;
  ::sigemptyset(&sa.sa_mask);
  ::sigaction(SIGINT, &sa, nullptr);
  ::sigaction(SIGTERM, &sa, nullptr);
  ::sigaction(SIGHUP, &sa, nullptr);

  std::printf("teamscan demo: %s, %zu robots, %.0f s of robot time at %.2fx, DDS domain %d on loopback (%s)\n",
              scenario.name.c_str(), live.robot_count(), duration_s, a.speed, domain, dds.c_str());
  std::printf("teamscan demo: output in %s\n", out.c_str());
  if (a.secure) std::printf("teamscan demo: DDS Security on: site PKI in %s (station, robot1..)\n", pki_dir.c_str());

  std::vector<Child> children;
  write_text(out + "/config/groundstation.toml",
             station_config(out, domain, a.station_method, a.write_interval_s, a.station_ros2, a.view_port));
  {
    Child c{"teamscan-groundstation", out + "/logs/groundstation.log"};
    auto pid = spawn(with({station_bin, "--config", out + "/config/groundstation.toml", "--session-dir", session, "--domain",
                           std::to_string(domain)},
                          pki_args("station")),
                     c.log);
    if (!pid) {
      std::fprintf(stderr, "teamscan demo: %s\n", pid.error().what);
      return 1;
    }
    c.pid = pid.value();
    children.push_back(c);
  }
  if (a.view_port) {
    std::printf("teamscan demo: live view at http://127.0.0.1:%d/ (served by the ground station)\n", *a.view_port);
    std::fflush(stdout);
  }
  auto self_cpu_s = [] {
    struct rusage ru{};
    ::getrusage(RUSAGE_SELF, &ru);
    return static_cast<double>(ru.ru_utime.tv_sec + ru.ru_stime.tv_sec) +
           1e-6 * static_cast<double>(ru.ru_utime.tv_usec + ru.ru_stime.tv_usec);
  };
  const double feeder_cpu_start_s = self_cpu_s();
  const auto run_start = std::chrono::steady_clock::now();
  if (Status s = live.start(); !s) {
    std::fprintf(stderr, "teamscan demo: devices: %s\n", s.error().what);
    for (Child& c : children) stop_child(c, std::chrono::milliseconds(3000));
    return 1;
  }
  for (std::size_t i = 0; i < live.robot_count(); ++i) {
    const sim::RobotSpec& spec = live.spec(i);
    std::size_t ti = 0;
    for (std::size_t k = 0; k < team.robot_count(); ++k)
      if (team.spec(k).id == spec.id) ti = k;
    const std::string cfg = out + "/config/onboard-robot" + std::to_string(spec.id) + ".toml";
    write_text(cfg, onboard_config(spec, team.motion(ti).pose_at(0.0), live.arcos_path(i), live.lms_path(i), domain, a.max_hold_s));
    Child c{"teamscan-onboard robot" + std::to_string(spec.id), out + "/logs/onboard-robot" + std::to_string(spec.id) + ".log"};
    auto pid = spawn(with({onboard_bin, "--config", cfg}, pki_args("robot" + std::to_string(spec.id))), c.log);
    if (pid) c.pid = pid.value();
    children.push_back(c);
  }

  // Cast the scans ahead of time (the robots stand during bring-up): the real-time part then only paces
  // bytes, so the feeder, which is not the system under test, takes less CPU from the daemons and the
  // station (docs/demo.md "Scale").
  double precast_cpu_s = 0;
  if (!a.no_precast) {
    if (!a.quiet) std::printf("teamscan demo: waiting for the scanners to stream, then casting the scans ahead...\n");
    std::fflush(stdout);
    auto pr = live.precast(duration_s + 0.5 * a.speed);
    if (!pr) {
      std::printf("teamscan demo: no precast (%s); scans are cast in real time\n", pr.error().what);
    } else {
      precast_cpu_s = pr->cpu_s;
      std::printf("teamscan demo: %llu scans cast ahead in %.1f s (CPU %.1f s); the robots start %.1f s later than planned%s\n",
                  static_cast<unsigned long long>(pr->scans), pr->wall_s, pr->cpu_s, pr->delayed_s,
                  pr->finished_before_t0 ? "" : " (the casting ran past world time 0: the first scans were cast live)");
    }
    std::fflush(stdout);
  }
  // Run: the robots drive from world time 0 to the duration, plus a moment for the last scans.
  std::vector<std::vector<sim::LiveScanTruth>> truths(live.robot_count());
  const double end_s = duration_s + 0.5 * a.speed;
  double last_print = -1e9;
  bool interrupted = false, child_died = false;
  const std::vector<std::string> station_argv = with(
      {station_bin, "--config", out + "/config/groundstation.toml", "--session-dir", session, "--domain", std::to_string(domain)},
      pki_args("station"));
  enum class Fault { pending, active, done };
  Fault station_fault = a.kill_station_at_s ? Fault::pending : Fault::done;
  Fault unplug_fault = a.unplug_robot ? Fault::pending : Fault::done;
  Fault kill_fault = a.kill_robot ? Fault::pending : Fault::done;
  std::vector<Child> old_stations;  // ground stations killed by the fault (their exit codes are reported)
  std::size_t killed_child = 0;     // index in children of the killed daemon (0 = none)
  std::ostringstream faults_log;
  auto live_index_of = [&](int id) {
    for (std::size_t i = 0; i < live.robot_count(); ++i)
      if (live.spec(i).id == id) return i;
    return live.robot_count();
  };
  while (live.world_time_s() < end_s) {
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
    for (std::size_t i = 0; i < live.robot_count(); ++i)
      for (sim::LiveScanTruth& t : live.take_truth(i)) truths[i].push_back(std::move(t));
    if (g_demo_signal.load() != 0) {
      interrupted = true;
      break;
    }
    const double wt = live.world_time_s();
    if (station_fault == Fault::pending && wt >= *a.kill_station_at_s) {
      ::kill(children[0].pid, SIGKILL);
      reap(children[0], true);
      old_stations.push_back(children[0]);
      faults_log << "ground station killed (SIGKILL) at t = " << wt << " s\n";
      station_fault = Fault::active;
    } else if (station_fault == Fault::active && wt >= *a.kill_station_at_s + a.station_down_s) {
      Child c{"teamscan-groundstation (restarted)", out + "/logs/groundstation-restarted.log"};
      if (auto pid = spawn(station_argv, c.log)) c.pid = pid.value();
      children[0] = c;
      faults_log << "ground station restarted at t = " << wt << " s\n";
      station_fault = Fault::done;
    }
    if (unplug_fault == Fault::pending && wt >= a.unplug_at_s) {
      const std::size_t i = live_index_of(*a.unplug_robot);
      if (i < live.robot_count()) live.unplug_laser(i);
      faults_log << "robot" << *a.unplug_robot << " laser unplugged at t = " << wt << " s\n";
      unplug_fault = Fault::active;
    } else if (unplug_fault == Fault::active && wt >= a.unplug_at_s + a.unplug_for_s) {
      const std::size_t i = live_index_of(*a.unplug_robot);
      if (i < live.robot_count() && !live.replug_laser(i)) faults_log << "replug failed\n";
      faults_log << "robot" << *a.unplug_robot << " laser replugged at t = " << wt << " s\n";
      unplug_fault = Fault::done;
    }
    if (kill_fault == Fault::pending && wt >= a.kill_robot_at_s) {
      const std::size_t i = live_index_of(*a.kill_robot);
      if (i < live.robot_count() && children[1 + i].pid > 0) {
        ::kill(children[1 + i].pid, SIGKILL);
        reap(children[1 + i], true);
        killed_child = 1 + i;
      }
      faults_log << "robot" << *a.kill_robot << " daemon killed (SIGKILL) at t = " << wt << " s\n";
      std::printf("teamscan demo: fault: robot%d daemon killed (SIGKILL) at t = %.1f s\n", *a.kill_robot, wt);
      std::fflush(stdout);
      kill_fault = Fault::done;
    }
    for (std::size_t ci = 0; ci < children.size(); ++ci) {
      Child& c = children[ci];
      if ((ci == killed_child && ci != 0) || (ci == 0 && station_fault == Fault::active)) continue;  // killed by a fault
      reap(c, false);
      if (c.exited && !child_died) {
        child_died = true;
        std::fprintf(stderr, "teamscan demo: %s exited early (code %d), see %s\n", c.name.c_str(), c.exit_code, c.log.c_str());
      }
    }
    const double now_s = live.world_time_s();
    if (!a.quiet && now_s - last_print >= 5.0 * a.speed) {
      last_print = now_s;
      std::error_code e2;
      const auto bytes = fs::file_size(session + "/scans.bin", e2);
      std::printf("  t = %6.1f / %.0f s  scans sent:", now_s, duration_s);
      for (std::size_t i = 0; i < live.robot_count(); ++i)
        std::printf(" robot%u %llu (%llu ghost beams)", unsigned(live.spec(i).id), static_cast<unsigned long long>(live.scans_measured(i)),
                    static_cast<unsigned long long>(live.ghost_beams(i)));
      std::printf("  stored: %.1f MB\n", e2 ? 0.0 : static_cast<double>(bytes) / 1e6);
      std::fflush(stdout);
    }
  }

  // CPU of each process over the run itself (before the station's final model write), /proc/PID/stat.
  for (Child& c : children) c.run_cpu_s = proc_cpu_s(c.pid);
  // This process during the run: the device feeder (pty pacing, SIP source, ray casting) and the demo's
  // loop, without the casting done ahead of time.
  const double feeder_cpu_s = self_cpu_s() - feeder_cpu_start_s - precast_cpu_s;
  const double run_cast_cpu_s = live.cast_cpu_s();
  const double run_wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - run_start).count();
  // Stop in order: the robots first (their last scans reach the station), then the station, which
  // writes its final model (an offline pass over the whole session: seconds for many robots).
  for (std::size_t i = 1; i < children.size(); ++i) stop_child(children[i], std::chrono::milliseconds(5000));
  std::this_thread::sleep_for(std::chrono::milliseconds(500));
  stop_child(children[0], std::chrono::milliseconds(120000));
  live.stop();
  for (std::size_t i = 0; i < live.robot_count(); ++i)
    for (sim::LiveScanTruth& t : live.take_truth(i)) truths[i].push_back(std::move(t));
  if (g_pgid > 0) ::kill(-g_pgid, SIGKILL);  // anything left in the group (none expected)

  for (const Child& c : old_stations) children.push_back(c);
  std::printf("teamscan demo: processes stopped:\n");
  for (const Child& c : children) std::printf("  %-28s exit %d   log %s\n", c.name.c_str(), c.exit_code, c.log.c_str());
  if (interrupted) {
    std::printf("teamscan demo: interrupted; the session is in %s\n", session.c_str());
    return 130;
  }

  // Offline reference: the same scenario, seed and duration through `teamscan sim`'s direct path.
  std::printf("teamscan demo: offline simulation of the same scenario for the reference...\n");
  std::fflush(stdout);
  sim::SimOptions so;
  so.seed = a.seed;
  so.duration_s = duration_s;
  so.device_streams = false;
  const sim::SimOutput offline = sim::simulate(scenario, so);

  {  // Every beam the ray caster put on a teammate: for checking the labels of the live map.
    std::ofstream g(out + "/truth-ghost-beams.csv");
    g << "robot,world_time_s,beam,tx_m,ty_m,tz_m,hit_robot\n";
    for (std::size_t i = 0; i < live.robot_count(); ++i)
      for (const sim::LiveScanTruth& t : truths[i])
        for (std::size_t k = 0; k < t.beams.size(); ++k)
          if (t.beams[k].label == PointClass::robot)
            g << unsigned(live.spec(i).id) << ',' << live.world_time_of(t.sweep_end_realtime_ns) << ',' << k << ','
              << t.beams[k].tx << ',' << t.beams[k].ty << ',' << t.beams[k].tz << ',' << unsigned(t.beams[k].hit_robot) << '\n';
  }
  LiveDataset L = build_live_dataset(session, live, truths, scenario, team, offline.dataset, duration_s);

  auto methods = mapping::parse_methods(a.methods, std::nullopt, std::nullopt, {});
  if (!methods) {
    std::fprintf(stderr, "teamscan demo: --method %s: %s\n", a.methods.c_str(), methods.error().what);
    return 2;
  }
  mapping::EvalOptions eo;
  eo.methods = methods.value();
  // The station's own method is always evaluated offline too, so its live model has its comparison.
  if (std::none_of(eo.methods.begin(), eo.methods.end(),
                   [&](const mapping::MethodSpec& m) { return m.method == a.station_method; })) {
    if (auto extra = mapping::parse_methods(a.station_method, std::nullopt, std::nullopt, {})) {
      const std::vector<mapping::MethodSpec> specs = extra.value();
      eo.methods.insert(eo.methods.end(), specs.begin(), specs.end());
    }
  }
  std::printf("teamscan demo: evaluating the live map (%zu points, %zu scans) and the offline one (%zu points)...\n",
              L.ds.points.size(), L.ds.scans.size(), offline.dataset.points.size());
  std::fflush(stdout);
  const mapping::EvalReport offline_report = mapping::evaluate(offline.dataset, eo);
  // The live map also with the robots' own direction-filter flags (what the onboard removed live).
  mapping::EvalOptions live_eo = eo;
  {
    mapping::MethodOptions flags_opt;
    flags_opt.direction.source = mapping::DirectionSource::flags;
    live_eo.methods.push_back({"direction-onboard-flags", "direction", flags_opt});
  }
  const mapping::EvalReport live_report = mapping::evaluate(L.ds, live_eo);

  // Compare.
  bool agree = true;
  std::ostringstream cmp;
  cmp << "| method | live DA % | offline DA % | ΔDA | live SA % | offline SA % | ΔSA | live AA | offline AA |\n"
         "| --- | --- | --- | --- | --- | --- | --- | --- | --- |\n";
  std::ostringstream mj;
  for (const mapping::MethodResult& lm : live_report.methods) {
    const mapping::MethodResult* om = nullptr;
    for (const mapping::MethodResult& m : offline_report.methods)
      if (m.name == lm.name) om = &m;
    char row[400];
    if (om) {
      const double dda = lm.removal.da - om->removal.da, dsa = lm.removal.sa - om->removal.sa;
      const bool map_based = lm.method == "frequency" || lm.method == "visibility" || lm.method == "combined";
      const bool ok = std::fabs(dda) <= (map_based ? a.tolerance_map_da_pct : a.tolerance_da_pct) &&
                      std::fabs(dsa) <= (map_based ? a.tolerance_map_sa_pct : a.tolerance_sa_pct);
      agree = agree && ok;
      std::snprintf(row, sizeof row, "| %s | %.1f | %.1f | %+.1f | %.2f | %.2f | %+.2f | %.1f | %.1f |%s\n", lm.name.c_str(),
                    lm.removal.da, om->removal.da, dda, lm.removal.sa, om->removal.sa, dsa, lm.removal.aa, om->removal.aa,
                    ok ? "" : " outside tolerance");
      mj << (mj.tellp() > 0 ? ",\n" : "") << "    {\"name\": \"" << lm.name << "\", \"live_da\": " << lm.removal.da
         << ", \"offline_da\": " << om->removal.da << ", \"live_sa\": " << lm.removal.sa << ", \"offline_sa\": " << om->removal.sa
         << ", \"live_aa\": " << lm.removal.aa << ", \"offline_aa\": " << om->removal.aa << ", \"within_tolerance\": "
         << (ok ? "true" : "false") << "}";
    } else {
      std::snprintf(row, sizeof row, "| %s | %.1f | – | – | %.2f | – | – | %.1f | – |\n", lm.name.c_str(), lm.removal.da,
                    lm.removal.sa, lm.removal.aa);
      mj << (mj.tellp() > 0 ? ",\n" : "") << "    {\"name\": \"" << lm.name << "\", \"live_da\": " << lm.removal.da
         << ", \"live_sa\": " << lm.removal.sa << ", \"live_aa\": " << lm.removal.aa << "}";
    }
    cmp << row;
  }

  // The ground station's own live model, scored against the truth, next to the offline `teamscan eval`
  // of the same method (the tolerance of the map-based methods applies to combined/frequency/visibility).
  const StationScore station = score_station_model(session + "/fused_all.pcd", L);
  const mapping::MethodResult* station_offline = nullptr;
  for (const mapping::MethodResult& m : offline_report.methods)
    if (m.method == a.station_method && !station_offline) station_offline = &m;
  bool station_agree = false;
  std::ostringstream stxt, stj;
  {
    const bool map_based = a.station_method == "frequency" || a.station_method == "visibility" || a.station_method == "combined";
    const double tol_da = map_based ? a.tolerance_map_da_pct : a.tolerance_da_pct;
    const double tol_sa = map_based ? a.tolerance_map_sa_pct : a.tolerance_sa_pct;
    char line[600];
    if (!station.present) {
      std::snprintf(line, sizeof line, "  the ground station wrote no usable fused_all.pcd (%s)\n", station.error.c_str());
      stxt << line;
    } else {
      const double off_da = station_offline ? station_offline->removal.da : 0.0;
      const double off_sa = station_offline ? station_offline->removal.sa : 0.0;
      // Not evaluated offline (--method without it): reported, not compared.
      station_agree = station_offline == nullptr ||
                      (std::fabs(station.model.da - off_da) <= tol_da && std::fabs(station.model.sa - off_sa) <= tol_sa);
      std::snprintf(line, sizeof line,
                    "  station model (%s, session/fused_all.pcd `keep`): DA %.1f %%, SA %.2f %%, AA %.1f  |  offline `teamscan eval` %s: "
                    "DA %.1f %%, SA %.2f %%  |  ΔDA %+.1f, ΔSA %+.2f (tolerance %.0f / %.0f points): %s\n"
                    "  station live decisions at arrival (`live_keep`): DA %.1f %%, SA %.2f %%\n"
                    "  %llu of %zu labelled live points found in the station's model (%llu not; the model has %llu points incl. bring-up)\n",
                    a.station_method.c_str(), station.model.da, station.model.sa, station.model.aa,
                    station_offline ? station_offline->name.c_str() : "(method not evaluated offline)", off_da, off_sa,
                    station.model.da - off_da, station.model.sa - off_sa, tol_da, tol_sa, !station_offline ? "not compared" : station_agree ? "agree" : "OUTSIDE",
                    station.live.da, station.live.sa, static_cast<unsigned long long>(station.matched), L.ds.points.size(),
                    static_cast<unsigned long long>(station.unmatched), static_cast<unsigned long long>(station.model_points));
      stxt << line;
    }
    stj << "  \"station_model\": {\"present\": " << (station.present ? "true" : "false") << ", \"method\": \""
        << json_escape(a.station_method) << "\", \"da\": " << station.model.da << ", \"sa\": " << station.model.sa
        << ", \"aa\": " << station.model.aa << ", \"live_da\": " << station.live.da << ", \"live_sa\": " << station.live.sa
        << ", \"offline_da\": " << (station_offline ? station_offline->removal.da : 0.0)
        << ", \"offline_sa\": " << (station_offline ? station_offline->removal.sa : 0.0) << ", \"tolerance_da\": " << tol_da
        << ", \"tolerance_sa\": " << tol_sa << ", \"within_tolerance\": " << (station_agree ? "true" : "false")
        << ", \"matched\": " << station.matched << ", \"unmatched\": " << station.unmatched
        << ", \"model_points\": " << station.model_points << "},\n";
  }
  // The station's model against `teamscan eval` of its own session (the fusion core fed the session
  // read back, in time order): the same decision for every point (docs/groundstation.md "The fusion core").
  bool session_agree = false;
  {
    station::GroundStationConfig gcfg;
    station::ConfigError gerr;
    char line[700];
    if (!station::load_groundstation_config(out + "/config/groundstation.toml", gcfg, gerr)) {
      std::snprintf(line, sizeof line, "  station model vs `teamscan eval SESSION`: cannot read the station config (%s)\n", gerr.message.c_str());
      stxt << line;
    } else if (auto check = station::check_model_against_eval(session, station::fusion_options_from_config(gcfg.fusion, gcfg.kalman)); !check) {
      std::snprintf(line, sizeof line, "  station model vs `teamscan eval SESSION`: %s\n", check.error().what);
      stxt << line;
    } else {
      const station::ModelCheck& mc = check.value();
      std::unordered_map<std::uint64_t, std::size_t> labelled;  // identity -> L.ds index
      labelled.reserve(L.ds.points.size());
      for (std::size_t i = 0; i < L.ds.points.size(); ++i)
        labelled[station::point_key(L.ds.points[i].robot, L.point_seq[i], L.ds.points[i].beam)] = i;
      std::vector<LabelledPoint> pts;
      std::vector<std::uint8_t> rm_model, rm_eval, rm_live;
      for (const station::PointDecision& d : mc.points) {
        if (!d.in_model) continue;
        auto it = labelled.find(station::point_key(d.robot, d.seq, d.beam));
        if (it == labelled.end()) continue;  // bring-up or after the run window: no label
        pts.push_back(L.ds.points[it->second]);
        rm_model.push_back(d.model_removed ? 1 : 0);
        rm_eval.push_back(d.eval_removed ? 1 : 0);
        rm_live.push_back(d.live_removed ? 1 : 0);
      }
      const mapping::RemovalMetrics mm = mapping::removal_metrics(pts, rm_model), me = mapping::removal_metrics(pts, rm_eval),
                                    ml = mapping::removal_metrics(pts, rm_live);
      session_agree = mc.mismatches == 0 && mc.compared > 0;
      std::snprintf(line, sizeof line,
                    "  station model vs `teamscan eval SESSION` (%s, the same core on the session read back): %llu of %llu session points in "
                    "the model (%llu beyond the per-voxel cap), %llu decisions differ: %s\n"
                    "    labelled (%zu points): station DA %.2f %%, SA %.3f %% | eval DA %.2f %%, SA %.3f %% | ΔDA %+.2f, ΔSA %+.3f; "
                    "decisions at release (`live_keep`): DA %.2f %%, SA %.3f %%\n",
                    gcfg.fusion.method.c_str(), static_cast<unsigned long long>(mc.compared),
                    static_cast<unsigned long long>(mc.compared + mc.not_in_model), static_cast<unsigned long long>(mc.not_in_model),
                    static_cast<unsigned long long>(mc.mismatches), session_agree ? "identical" : "DIFFERENT", pts.size(), mm.da, mm.sa,
                    me.da, me.sa, mm.da - me.da, mm.sa - me.sa, ml.da, ml.sa);
      stxt << line;
      stj << "  \"station_vs_session_eval\": {\"method\": \"" << json_escape(gcfg.fusion.method) << "\", \"compared\": " << mc.compared
          << ", \"not_in_model\": " << mc.not_in_model << ", \"mismatches\": " << mc.mismatches << ", \"labelled\": " << pts.size()
          << ", \"station_da\": " << mm.da << ", \"station_sa\": " << mm.sa << ", \"eval_da\": " << me.da << ", \"eval_sa\": " << me.sa
          << ", \"live_da\": " << ml.da << ", \"live_sa\": " << ml.sa << ", \"identical\": " << (session_agree ? "true" : "false") << "},\n";
    }
  }
  agree = agree && station_agree && session_agree;

  // Delivery: every scan a robot published reached the session.
  bool none_lost = true;
  std::ostringstream dj, dtxt;
  for (const RobotDelivery& d : L.delivery) {
    const bool lost = d.gaps > 0 || d.stored == 0 || d.seq_last < d.last_status_published;
    none_lost = none_lost && !lost;
    char line[300];
    std::snprintf(line, sizeof line,
                  "  robot%u: stored %llu scans (seq %u..%u, %llu missing, %llu duplicates; last status said %u published), "
                  "%llu in the run window, %llu matched to truth, %llu unmatched; the emulated LMS sent %llu (%llu beams on a teammate in the window)\n",
                  unsigned(d.id), static_cast<unsigned long long>(d.stored), d.seq_first, d.seq_last,
                  static_cast<unsigned long long>(d.gaps), static_cast<unsigned long long>(d.duplicates), d.last_status_published,
                  static_cast<unsigned long long>(d.in_window), static_cast<unsigned long long>(d.truth_matched),
                  static_cast<unsigned long long>(d.truth_unmatched), static_cast<unsigned long long>(d.measured),
                  static_cast<unsigned long long>(d.truth_ghost_beams));
    dtxt << line;
    dj << (dj.tellp() > 0 ? ",\n" : "") << "    {\"id\": " << unsigned(d.id) << ", \"stored\": " << d.stored
       << ", \"seq_first\": " << d.seq_first << ", \"seq_last\": " << d.seq_last << ", \"missing\": " << d.gaps
       << ", \"duplicates\": " << d.duplicates << ", \"last_status_published\": " << d.last_status_published
       << ", \"in_window\": " << d.in_window << ", \"truth_matched\": " << d.truth_matched
       << ", \"truth_unmatched\": " << d.truth_unmatched << ", \"lms_sent\": " << d.measured << "}";
  }

  // Outputs: live data set (for `teamscan eval`), offline data set, fused PCD, reports, pictures.
  const std::string live_ds_dir = out + "/live-dataset", off_ds_dir = out + "/offline-dataset";
  if (Status s = write_dataset(live_ds_dir, L.ds); !s) std::fprintf(stderr, "teamscan demo: %s: %s\n", live_ds_dir.c_str(), s.error().what);
  if (Status s = write_dataset(off_ds_dir, offline.dataset); !s) std::fprintf(stderr, "teamscan demo: %s: %s\n", off_ds_dir.c_str(), s.error().what);
  // The fused map: the labelled live points the ground station's own model keeps (its fused_all.pcd);
  // without it, the points the station's method keeps post-run.
  const mapping::MethodResult* fused_by = nullptr;
  for (const mapping::MethodResult& m : live_report.methods)
    if (m.method == a.station_method) fused_by = &m;
  if (!fused_by && !live_report.methods.empty()) fused_by = &live_report.methods.front();
  const std::vector<std::uint8_t>* fused_removed = station.present ? &station.removed : (fused_by ? &fused_by->removed : nullptr);
  std::vector<LabelledPoint> fused;
  for (std::size_t i = 0; i < L.ds.points.size(); ++i)
    if (!fused_removed || !(*fused_removed)[i]) fused.push_back(L.ds.points[i]);
  if (Status s = write_labelled_pcd(out + "/fused.pcd", fused); !s) std::fprintf(stderr, "teamscan demo: fused.pcd: %s\n", s.error().what);

  std::string pictures;
#ifdef TEAMSCAN_DEMO_RENDER
  {
    render::RenderOptions ro;
    ro.view = render::View::top;
    ro.color = render::ColorMode::class_label;
    ro.title = scenario.name + " live: all points (ghosts black)";
    if (render::render_dataset_png(out + "/live-all-top.png", L.ds, {}, ro)) pictures += "![live, all points](live-all-top.png)\n";
    if (fused_removed) {
      std::vector<std::uint8_t> keep(fused_removed->size());
      for (std::size_t i = 0; i < keep.size(); ++i) keep[i] = (*fused_removed)[i] ? 0 : 1;
      ro.color = render::ColorMode::filter;
      ro.title = scenario.name + " live: fused map (filtered points white)";
      if (render::render_dataset_png(out + "/live-fused-top.png", L.ds, keep, ro)) pictures += "![live, fused](live-fused-top.png)\n";
      ro.view = render::View::side;
      if (render::render_dataset_png(out + "/live-fused-side.png", L.ds, keep, ro)) pictures += "![live, fused, side](live-fused-side.png)\n";
    }
  }
#endif

  const double wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_start).count();
  std::ostringstream md;
  md << "# teamscan demo: " << scenario.name << "\n\n" << live.robot_count() << " robots, " << duration_s
     << " s of robot time at " << a.speed << "x real time, " << wall_s << " s wall clock.\n\n## Delivery\n\n```\n"
     << dtxt.str() << "```\n\n## The ground station's live fused model vs the truth\n\n```\n" << stxt.str()
     << "```\n\n## Post-run `teamscan eval` of the live session vs offline (`teamscan eval " << off_ds_dir << "`)\n\nTolerance: |ΔDA| ≤ "
     << a.tolerance_da_pct << " points, |ΔSA| ≤ " << a.tolerance_sa_pct << " points (position, direction); |ΔDA| ≤ "
     << a.tolerance_map_da_pct << ", |ΔSA| ≤ " << a.tolerance_map_sa_pct
     << " points (frequency, visibility, combined: map-based, docs/demo.md).\n\n" << cmp.str()
     << "\n## Live report\n\n" << mapping::report_markdown(live_report, "teamscan eval " + live_ds_dir)
     << "\n## Offline report\n\n" << mapping::report_markdown(offline_report, "teamscan eval " + off_ds_dir) << "\n"
     << pictures << "\n## Logs\n\n";
  for (const Child& c : children) md << "- " << c.name << ": `" << c.log << "` (exit " << c.exit_code << ")\n";
  write_text(out + "/report.md", md.str());
  write_text(out + "/report-live.json", mapping::report_json(live_report, "teamscan eval " + live_ds_dir));
  write_text(out + "/report-offline.json", mapping::report_json(offline_report, "teamscan eval " + off_ds_dir));

  // Fault analysis from the session (status.csv, events.log, scans.bin).
  std::ostringstream fj;
  if (a.unplug_robot) {
    std::vector<unsigned> states;  // the robot's lms_state as the station saw it, consecutive duplicates merged
    std::uint32_t reopens = 0;
    for (const auto& f : read_csv(session + "/status.csv")) {
      if (f.size() < 20 || std::stoi(f[2]) != *a.unplug_robot) continue;
      const unsigned st = static_cast<unsigned>(std::stoul(f[6]));
      if (states.empty() || states.back() != st) states.push_back(st);
      // status.csv (session_store.cpp append_status): column 18 is lms_reopens (19 is points_team_stale).
      reopens = std::max(reopens, static_cast<std::uint32_t>(std::stoul(f[18])));
    }
    fj << "  \"unplug\": {\"robot\": " << *a.unplug_robot << ", \"lms_states\": [";
    for (std::size_t k = 0; k < states.size(); ++k) fj << (k ? ", " : "") << states[k];
    fj << "], \"lms_reopens\": " << reopens << "},\n";
    std::printf("fault: robot%d laser unplugged: lms_state sequence in status.csv:", *a.unplug_robot);
    for (unsigned st : states) std::printf(" %u", st);
    std::printf("; lms reopens %u\n", reopens);
  }
  if (a.kill_robot) {
    const std::int64_t kill_rt = live.t0_realtime_ns() + static_cast<std::int64_t>(a.kill_robot_at_s / a.speed * 1e9);
    double lost_after_s = -1;
    std::ifstream ev(session + "/events.log");
    const std::string needle = "robot " + std::to_string(*a.kill_robot) + " LOST";
    for (std::string line; std::getline(ev, line);) {
      if (line.find(needle) == std::string::npos) continue;
      const std::int64_t t = std::stoll(line.substr(0, line.find(' ')));
      if (t >= kill_rt) {
        lost_after_s = static_cast<double>(t - kill_rt) * 1e-9;
        break;
      }
    }
    // The other robots' scans from 1 s after the kill: points flagged team-stale, and points filtered.
    std::uint64_t stale_before = 0, stale_after = 0, filtered_after = 0, scans_after = 0;
    station::ScanDecodeStats st;
    std::string err;
    station::read_scan_file(session + "/scans.bin", [&](const station::StoredScan& sc) {
      if (static_cast<int>(sc.robot_id) == *a.kill_robot) return;
      const bool after = sc.stamp_ns >= kill_rt + 1'000'000'000;
      if (after) ++scans_after;
      for (std::uint16_t k = 0; k < sc.count; ++k) {
        const std::uint16_t fl = sc.points[k].flags;
        if (fl & kPointTeamStale) ++(after ? stale_after : stale_before);
        if (after && (fl & kPointDirectionFiltered)) ++filtered_after;
      }
    }, st, err);
    fj << "  \"kill_robot\": {\"robot\": " << *a.kill_robot << ", \"lost_after_s\": " << lost_after_s
       << ", \"others_scans_after\": " << scans_after << ", \"others_team_stale_points_before\": " << stale_before
       << ", \"others_team_stale_points_after\": " << stale_after << ", \"others_direction_filtered_points_after\": "
       << filtered_after << "},\n";
    std::printf("fault: robot%d daemon killed: station marked it lost after %.2f s; the others' scans from 1 s after: %llu, "
                "team-stale points %llu (before: %llu), direction-filtered points %llu\n",
                *a.kill_robot, lost_after_s, static_cast<unsigned long long>(scans_after),
                static_cast<unsigned long long>(stale_after), static_cast<unsigned long long>(stale_before),
                static_cast<unsigned long long>(filtered_after));
  }
  if (!faults_log.str().empty()) std::printf("faults:\n%s", faults_log.str().c_str());

  // Scan -> stored latency (the station stores before any mapping hook; docs/demo.md "Scale").
  std::vector<double> lat = L.latency_ms;
  std::sort(lat.begin(), lat.end());
  auto pct = [&](double q) { return lat.empty() ? 0.0 : lat[std::min(lat.size() - 1, static_cast<std::size_t>(q * static_cast<double>(lat.size())))]; };
  double station_cpu_s = 0, onboard_cpu_s = 0, station_run_cpu_s = 0;
  for (const Child& c : children) {
    if (c.name.rfind("teamscan-groundstation", 0) == 0) {
      station_cpu_s += c.cpu_s;
      station_run_cpu_s += c.run_cpu_s;
    }
    if (c.name.rfind("teamscan-onboard", 0) == 0) onboard_cpu_s += c.run_cpu_s;
  }
  std::printf("CPU over the run (%.1f s): ground station %.2f s (%.0f %% of a core; %.2f s with its final model write), "
              "onboard daemons %.2f s together, device feeder (this process) %.2f s (ray casting %.2f s)\n",
              run_wall_s, station_run_cpu_s, 100.0 * station_run_cpu_s / run_wall_s, station_cpu_s, onboard_cpu_s,
              feeder_cpu_s, run_cast_cpu_s);
  std::printf("scans from the precast table: %llu of %llu sent (casting ahead took %.2f s CPU before the run)\n",
              static_cast<unsigned long long>(live.scans_from_precast()),
              static_cast<unsigned long long>([&] {
                std::uint64_t t = 0;
                for (std::size_t i = 0; i < live.robot_count(); ++i) t += live.scans_measured(i);
                return t;
              }()),
              precast_cpu_s);
  std::printf("scan -> stored latency in the run window: p50 %.1f ms, p99 %.1f ms, max %.1f ms over %zu scans; ground station CPU %.2f s incl. its final model write (%.1f %% of one core over the run)\n",
              pct(0.5), pct(0.99), lat.empty() ? 0.0 : lat.back(), lat.size(), station_cpu_s,
              100.0 * station_cpu_s / run_wall_s);
  // Scan -> fused map, as the station measured it (session/latency.csv, last station process).
  const std::vector<LatencySummary> station_lat = read_latency_csv(session + "/latency.csv");
  const LatencySummary fused_lat = station_lat.size() >= 2 ? station_lat[1] : LatencySummary{};
  const std::vector<double> fused_win = read_fused_latency_log(
      session + "/fused_latency.csv", live.t0_realtime_ns(),
      live.t0_realtime_ns() + static_cast<std::int64_t>(duration_s / a.speed * 1e9));
  std::printf("scan -> fused map latency in the run window: p50 %.1f ms, p99 %.1f ms, max %.1f ms over %zu scans (session/fused_latency.csv)\n",
              sorted_pct(fused_win, 0.5), sorted_pct(fused_win, 0.99), fused_win.empty() ? 0.0 : fused_win.back(), fused_win.size());
  if (fused_lat.present) {
    std::printf("scan -> fused map latency, every scan incl. bring-up and shutdown (the station's histogram): p50 %.1f ms, p90 %.1f ms, "
                "p99 %.1f ms, max %.1f ms over %.0f scans\n",
                fused_lat.p50_ms, fused_lat.p90_ms, fused_lat.p99_ms, fused_lat.max_ms, fused_lat.count);
  } else {
    std::printf("scan -> fused map latency: the station wrote no %s/latency.csv\n", session.c_str());
  }
  // Point accuracy: every live point with a true hit against the ray caster's hit point (mm). It holds the
  // range noise, the odometry's drift, the stamp and the odometry interpolation/extrapolation (max_hold_s).
  std::vector<double> err_mm = L.point_error_mm;
  std::sort(err_mm.begin(), err_mm.end());
  std::printf("point error vs truth: p50 %.1f mm, p99 %.1f mm, max %.1f mm over %zu points (onboard max_hold_s %s)\n",
              sorted_pct(err_mm, 0.5), sorted_pct(err_mm, 0.99), err_mm.empty() ? 0.0 : err_mm.back(), err_mm.size(),
              a.max_hold_s ? fmt("%.3f", *a.max_hold_s).c_str() : "default");

  bool clean = true;
  std::ostringstream pj;
  for (std::size_t ci = 0; ci < children.size(); ++ci) {
    const Child& c = children[ci];
    const bool killed_by_fault = (killed_child != 0 && ci == killed_child) ||
                                 (c.name == "teamscan-groundstation" && a.kill_station_at_s && ci >= 1 + live.robot_count());
    clean = clean && (c.exit_code == 0 || (killed_by_fault && c.exit_code == 128 + SIGKILL));
    pj << (pj.tellp() > 0 ? ",\n" : "") << "    {\"name\": \"" << json_escape(c.name) << "\", \"exit\": " << c.exit_code << ", \"cpu_s\": " << c.cpu_s
       << ", \"log\": \"" << json_escape(c.log) << "\"}";
  }
  std::ostringstream sj;
  sj << "{\n  \"scenario\": \"" << json_escape(scenario.name) << "\",\n  \"secure\": " << (a.secure ? "true" : "false") << ",\n  \"duration_s\": " << duration_s
     << ",\n  \"speed\": " << a.speed << ",\n  \"wall_s\": " << wall_s << ",\n  \"none_lost\": " << (none_lost ? "true" : "false")
     << ",\n  \"agree\": " << (agree ? "true" : "false") << ",\n  \"clean_exit\": " << (clean ? "true" : "false")
     << ",\n  \"tolerance_da_pct\": " << a.tolerance_da_pct << ",\n  \"tolerance_sa_pct\": " << a.tolerance_sa_pct
     << ",\n  \"latency_ms_p50\": " << pct(0.5) << ",\n  \"latency_ms_p99\": " << pct(0.99)
     << ",\n  \"latency_ms_max\": " << (lat.empty() ? 0.0 : lat.back()) << ",\n  \"fused_latency_present\": "
     << (fused_lat.present ? "true" : "false") << ",\n  \"fused_latency_scans\": " << fused_lat.count
     << ",\n  \"fused_latency_ms_p50\": " << sorted_pct(fused_win, 0.5) << ",\n  \"fused_latency_ms_p99\": "
     << sorted_pct(fused_win, 0.99) << ",\n  \"fused_latency_ms_max\": " << (fused_win.empty() ? 0.0 : fused_win.back())
     << ",\n  \"fused_latency_window_scans\": " << fused_win.size() << ",\n  \"station_hist_fused_ms_p50\": " << fused_lat.p50_ms
     << ",\n  \"station_hist_fused_ms_p99\": " << fused_lat.p99_ms << ",\n  \"station_hist_fused_ms_max\": " << fused_lat.max_ms << ",\n  \"point_error_mm_p50\": " << sorted_pct(err_mm, 0.5)
     << ",\n  \"point_error_mm_p99\": " << sorted_pct(err_mm, 0.99) << ",\n  \"point_error_mm_max\": "
     << (err_mm.empty() ? 0.0 : err_mm.back()) << ",\n  \"max_hold_s\": " << (a.max_hold_s ? *a.max_hold_s : -1.0)
     << ",\n  \"station_cpu_s\": " << station_cpu_s << ",\n  \"station_run_cpu_s\": " << station_run_cpu_s
     << ",\n  \"feeder_cpu_s\": " << feeder_cpu_s << ",\n  \"cast_cpu_s\": " << run_cast_cpu_s
     << ",\n  \"precast_cpu_s\": " << precast_cpu_s << ",\n  \"scans_from_precast\": " << live.scans_from_precast()
     << ",\n  \"onboard_cpu_s\": " << onboard_cpu_s
     << ",\n  \"scan_file_bad_crc\": " << L.decode.bad_crc << ",\n" << fj.str() << stj.str() << "  \"robots\": [\n" << dj.str() << "\n  ],\n  \"methods\": [\n"
     << mj.str() << "\n  ],\n  \"processes\": [\n" << pj.str() << "\n  ]\n}\n";
  write_text(out + "/summary.json", sj.str());

  std::printf("\nDelivery (ground station session %s):\n%s", session.c_str(), dtxt.str().c_str());
  std::printf("\nThe ground station's live fused model vs the simulator's truth:\n%s", stxt.str().c_str());
  std::printf("\nPost-run `teamscan eval` of the live session's labelled data vs offline (same scenario, seed, methods):\n%s",
              cmp.str().c_str());
  std::printf("\nnone lost: %s   agree within tolerance: %s   clean exits: %s\n", none_lost ? "yes" : "NO", agree ? "yes" : "NO",
              clean ? "yes" : "NO");
  std::printf("wrote %s/report.md, summary.json, fused.pcd (%zu points), live-dataset/, offline-dataset/%s\n", out.c_str(),
              fused.size(), pictures.empty() ? "" : ", pictures");
  return (none_lost && agree && clean && !child_died) ? 0 : 1;
}

const SubcommandRegistration kDemo{
    {"demo", "Run the whole system live (emulated robots, onboard daemons, ground station) and score the result",
     [](CLI::App& app) {
       auto a = std::make_shared<DemoArgs>();
       app.add_option("--scenario", a->scenario, "lap2, fig8 or a scenario TOML file")->capture_default_str();
       app.add_option("--speed", a->speed, "World seconds per wall-clock second (1 = real time; see docs/demo.md)")
           ->capture_default_str()
           ->check(CLI::PositiveNumber);
       app.add_flag("--force-speed", a->force_speed,
                    "Run above real time anyway (the live ghost filters then see teammates --speed times staler)");
       app.add_option("--robots", a->robots, "Use only the first N robots of the scenario");
       app.add_option("--duration", a->duration_s, "Seconds of robot time (default: the scenario's)")->check(CLI::PositiveNumber);
       app.add_option("--out", a->out, "Output folder (session, logs, configs, reports, PCD, pictures)")->capture_default_str();
       app.add_option("--seed", a->seed, "Override the scenario's seed");
       app.add_option("--bringup", a->bringup_s, "Seconds for device bring-up before the robots drive")->capture_default_str();
       app.add_option("--domain", a->domain, "DDS domain id (default: derived from the pid)");
       app.add_option("--dds-config", a->dds_config,
                      "Cyclone DDS config (default: the installed share/teamscan/cyclonedds-lo.xml; deploy/ in a build tree)");
       app.add_option("--onboard-bin", a->onboard_bin, "teamscan-onboard executable (default: found next to teamscan)");
       app.add_option("--station-bin", a->station_bin, "teamscan-groundstation executable (default: found)");
       app.add_option("--tolerance-da", a->tolerance_da_pct, "Allowed |live DA − offline DA| in points")->capture_default_str();
       app.add_option("--tolerance-sa", a->tolerance_sa_pct, "Allowed |live SA − offline SA| in points")->capture_default_str();
       app.add_option("--tolerance-map-da", a->tolerance_map_da_pct, "Allowed |ΔDA| for frequency/visibility/combined")
           ->capture_default_str();
       app.add_option("--tolerance-map-sa", a->tolerance_map_sa_pct, "Allowed |ΔSA| for frequency/visibility/combined")
           ->capture_default_str();
       app.add_option("--method", a->methods, "Methods as in `teamscan eval --method`")->capture_default_str();
       app.add_flag("--quiet", a->quiet, "No progress lines");
       app.add_option("--kill-station-at", a->kill_station_at_s, "Fault: SIGKILL the ground station at this world time");
       app.add_option("--station-down", a->station_down_s, "Fault: ...and restart it this many seconds later")->capture_default_str();
       app.add_option("--unplug-robot", a->unplug_robot, "Fault: unplug this robot's laser pty");
       app.add_option("--unplug-at", a->unplug_at_s, "Fault: ...at this world time")->capture_default_str();
       app.add_option("--unplug-for", a->unplug_for_s, "Fault: ...for this many seconds")->capture_default_str();
       app.add_option("--kill-robot", a->kill_robot, "Fault: SIGKILL this robot's onboard daemon");
       app.add_option("--kill-robot-at", a->kill_robot_at_s, "Fault: ...at this world time")->capture_default_str();
       app.add_option("--max-hold", a->max_hold_s,
                      "Onboard [odometry] max_hold_s: how long a scan waits for its covering SIP (0: publish at once)")
           ->check(CLI::Range(0.0, 0.2));
       app.add_option("--write-interval", a->write_interval_s,
                      "Station [fusion] write_interval_s: periodic fused-model writes (written off the receive loop)")
           ->capture_default_str()
           ->check(CLI::Range(0.0, 3600.0));
       app.add_option("--feed-period", a->feed_period_ms,
                      "Device feeder: one thread steps every pty this often, ms (0: a thread per pty, byte-exact pacing)")
           ->capture_default_str()
           ->check(CLI::Range(0.0, 10.0));
       app.add_option("--view", a->view_port, "Serve the station's browser view on 127.0.0.1:PORT during the demo (docs/view.md)")
           ->check(CLI::Range(1, 65535));
       app.add_flag("--no-precast", a->no_precast, "Cast every scan in real time instead of ahead, during bring-up");
       app.add_flag("--secure", a->secure,
                    "DDS Security: a throwaway site PKI in <out>/pki, every daemon authenticated, encrypted, access-controlled");
       app.add_option("--station-method", a->station_method, "The ground station's live fusion method ([fusion] method)")
           ->capture_default_str();
       app.add_option("--station-ros2", a->station_ros2,
                      "The station's ROS 2 publishers ([ros2] enabled: rt/teamscan/map_cloud, rt/tf, rt/robotN/odom)")
           ->capture_default_str();
       return [a] { return run_demo(*a); };
     }}};

}  // namespace
}  // namespace teamscan::tool
