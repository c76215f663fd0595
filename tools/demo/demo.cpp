// `teamscan demo` (demo.hpp): configure, start the processes, run the world with its faults, stop in
// order; scoring and reports are demo_report.cpp's. The pieces live in supervisor.hpp,
// config_writer.hpp, session_csv.hpp and scoring.hpp; the stages' types in demo_run.hpp.
#include "tools/demo/demo.hpp"

#include <signal.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <thread>
#include <vector>

#include "common/data_paths.hpp"
#include "groundstation/fusion/evaluation.hpp"
#include "groundstation/station/config.hpp"
#include "sim/live.hpp"
#include "sim/scenario.hpp"
#include "sim/simulator.hpp"
#include "tools/demo/config_writer.hpp"
#include "tools/demo/demo_run.hpp"
#include "tools/demo/supervisor.hpp"
#include "tools/pki/site_pki.hpp"

namespace teamscan::demo {
namespace {

namespace fs = std::filesystem;

std::atomic<int> g_demo_signal{0};
extern "C" void demo_on_signal(int sig) { g_demo_signal.store(sig); }

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

std::string seconds_text(double s) {
  char b[32];
  std::snprintf(b, sizeof b, "%.1f", s);
  return b;
}

// The scenario, trimmed to --robots: 0, else the exit code.
int load_scenario(const DemoOptions& a, DemoSetup& s) {
  const sim::ScenarioLoad load = sim::resolve_scenario(a.scenario);
  if (!load.scenario) {
    std::fprintf(stderr, "teamscan demo: %s\n", load.error.c_str());
    return 2;
  }
  s.scenario = *load.scenario;
  if (a.robots) {
    if (*a.robots < 1 || static_cast<std::size_t>(*a.robots) > s.scenario.robots.size()) {
      std::fprintf(stderr, "teamscan demo: --robots %d: the scenario has %zu robots\n", *a.robots,
                   s.scenario.robots.size());
      return 2;
    }
    s.scenario.robots.resize(static_cast<std::size_t>(*a.robots));
  }
  const sim::TeamWorld team{s.scenario};
  s.duration_s = a.duration_s.value_or(s.scenario.duration_s.value_or(team.finish_s()));
  return 0;
}

// Registration as asked, else on exactly when the robots' odometry drifts (docs/demo.md
// "Registration"); a calibration (--calibration) turns it on too: its priors are the registration's.
int resolve_registration(const DemoOptions& a, DemoSetup& s) {
  s.registration = a.registration.value_or(!a.calibration_path.empty() || scenario_drifts(s.scenario));
  s.pose_graph = a.pose_graph.value_or(a.registration != std::optional<bool>(false));
  s.registration_why = a.registration ? (s.registration ? "on (--registration)" : "off (--no-registration)")
                       : !a.calibration_path.empty() ? "on (--calibration)"
                       : s.registration              ? "on: the scenario's robots drift"
                                                     : "off: the scenario's robots do not drift";
  if (a.calibration_path.empty()) return 0;
  // Each robot's odometry prior: checked as the station will read it, then appended to its config.
  station::ConfigError error;
  if (!station::load_registration_priors(a.calibration_path, s.priors, error)) {
    std::fprintf(stderr, "teamscan demo: --calibration %s\n", error.message.c_str());
    return 2;
  }
  std::ifstream in(a.calibration_path);
  std::ostringstream text;
  text << in.rdbuf();
  s.calibration_toml = text.str();
  return 0;
}

// Loopback DDS (never the default config; the children inherit the environment) and the daemons.
int resolve_processes(const DemoOptions& a, DemoSetup& s) {
  s.dds = a.dds_config;
  if (s.dds.empty()) {
    const DataFile lo = find_data_file("cyclonedds-lo.xml", "deploy/cyclonedds-lo.xml");
    if (lo.path.empty()) {
      std::fprintf(stderr, "teamscan demo: cannot find cyclonedds-lo.xml (looked in %s; give --dds-config)\n",
                   lo.searched.c_str());
      return 2;
    }
    s.dds = lo.path;
  }
  ::setenv("CYCLONEDDS_URI", ("file://" + fs::absolute(s.dds).string()).c_str(), 1);
  s.domain = a.domain.value_or(1 + static_cast<int>(::getpid() % 230));
  s.onboard_bin = a.onboard_bin.empty() ? find_binary("teamscan-onboard", "onboard/daemon") : a.onboard_bin;
  s.station_bin =
      a.station_bin.empty() ? find_binary("teamscan-groundstation", "groundstation/station") : a.station_bin;
  if (s.onboard_bin.empty() || s.station_bin.empty()) {
    std::fprintf(stderr,
                 "teamscan demo: cannot find teamscan-onboard / teamscan-groundstation (build them, or give "
                 "--onboard-bin/--station-bin)\n");
    return 2;
  }
  return 0;
}

// The output folder, fresh session and run folders, and (--secure) a site PKI for this run's domain.
int prepare_output(const DemoOptions& a, DemoSetup& s) {
  std::error_code ec;
  s.out = fs::absolute(a.out).lexically_normal().string();
  s.session = s.out + "/session";
  s.pki_dir = s.out + "/pki";
  s.station_config = s.out + "/config/groundstation.toml";
  fs::create_directories(s.out + "/logs", ec);
  fs::create_directories(s.out + "/config", ec);
  fs::remove_all(s.session, ec);
  fs::remove_all(s.out + "/run", ec);
  if (!a.secure) return 0;
  fs::remove_all(s.pki_dir, ec);
  pki::SiteOptions so;
  for (const sim::RobotSpec& r : s.scenario.robots)
    so.robots = std::max<std::uint32_t>(so.robots, static_cast<std::uint32_t>(r.id));
  so.domain_min = so.domain_max = static_cast<std::uint32_t>(s.domain);
  so.now_s = static_cast<std::int64_t>(std::time(nullptr));
  so.identity_days = 2;
  if (const Status e = pki::create_site(s.pki_dir, so); !e.ok()) {
    std::fprintf(stderr, "teamscan demo: --secure: %s\n", e.error().what);
    return 1;
  }
  return 0;
}

std::vector<std::string> pki_args(const DemoOptions& a, const DemoSetup& s, const std::string& name) {
  return a.secure ? std::vector<std::string>{"--pki-dir", s.pki_dir + "/" + name} : std::vector<std::string>{};
}

std::vector<std::string> with(std::vector<std::string> v, const std::vector<std::string>& more) {
  v.insert(v.end(), more.begin(), more.end());
  return v;
}

std::vector<std::string> station_argv(const DemoOptions& a, const DemoSetup& s) {
  return with(
      with(s.links ? s.links->station_prefix() : std::vector<std::string>{}, {s.station_bin, "--config", s.station_config, "--session-dir", s.session, "--domain", std::to_string(s.domain)}),
      pki_args(a, s, "station"));
}

// The ground station (children[0]), then the devices, then one onboard daemon per robot.
int start_processes(const DemoOptions& a, const DemoSetup& s, sim::LiveTeam& live, Supervisor& supervisor,
                    Progress& progress, RunRecord& r) {
  write_text(s.station_config,
             station_config({s.out, s.domain, a.station_method, station_compare_methods(a), a.write_interval_s,
                             a.station_ros2, a.view_port, s.registration, s.pose_graph, s.calibration_toml, s.scenario.robots}));
  Child station{"teamscan-groundstation", s.out + "/logs/groundstation.log"};
  auto pid = supervisor.spawn(station_argv(a, s), station.log);
  if (!pid) {
    std::fprintf(stderr, "teamscan demo: %s\n", pid.error().what);
    return 1;
  }
  station.pid = pid.value();
  r.children.push_back(station);
  if (a.view_port)
    progress.event("teamscan demo: live view at http://127.0.0.1:" + std::to_string(*a.view_port) +
                   "/ (served by the ground station)");
  if (Status st = live.start(); !st) {
    std::fprintf(stderr, "teamscan demo: devices: %s\n", st.error().what);
    for (Child& c : r.children) stop_child(c, std::chrono::milliseconds(3000));
    return 1;
  }
  const sim::TeamWorld team{s.scenario};
  for (std::size_t i = 0; i < live.robot_count(); ++i) {
    const sim::RobotSpec& spec = live.spec(i);
    std::size_t ti = 0;
    for (std::size_t k = 0; k < team.robot_count(); ++k)
      if (team.spec(k).id == spec.id) ti = k;
    const std::string id = std::to_string(spec.id);
    const std::string cfg = s.out + "/config/onboard-robot" + id + ".toml";
    // Store and forward: each robot's ring in the run's folder, as long as the run (docs/onboard.md "The ring").
    const std::string ring = s.out + "/config/ring-robot" + id + ".bin";
    write_text(cfg, onboard_config(spec, {live.arcos_path(i), live.lms_path(i), team.motion(ti).pose_at(0.0), s.domain,
                                          a.max_hold_s, ring, std::max(60.0, 2.0 * s.duration_s)}));
    Child c{"teamscan-onboard robot" + id, s.out + "/logs/onboard-robot" + id + ".log"};
    const std::vector<std::string> netns = s.links ? s.links->robot_prefix(spec.id) : std::vector<std::string>{};
    if (auto p = supervisor.spawn(with(with(netns, {s.onboard_bin, "--config", cfg}), pki_args(a, s, "robot" + id)), c.log))
      c.pid = p.value();
    r.children.push_back(c);
  }
  r.robot_children = live.robot_count();
  return 0;
}

// Cast the scans ahead of time (the robots stand during bring-up): the real-time part then only paces
// bytes, so the feeder, which is not the system under test, takes less CPU from the daemons and the
// station (docs/demo.md "Scale").
void precast(const DemoOptions& a, const DemoSetup& s, sim::LiveTeam& live, Progress& progress, RunRecord& r) {
  if (a.no_precast) return;
  progress.stage("teamscan demo: waiting for the scanners to stream, then casting the scans ahead...");
  auto pr = live.precast(s.duration_s + 0.5 * a.speed);
  if (!pr) {
    progress.event(std::string("teamscan demo: no precast (") + pr.error().what + "); scans are cast in real time");
    return;
  }
  r.precast_cpu_s = pr->cpu_s;
  r.precast_scans = pr->scans;
  progress.stage(
      "teamscan demo: " + std::to_string(pr->scans) + " scans cast ahead in " + seconds_text(pr->wall_s) +
      " s; the robots start " + seconds_text(pr->delayed_s) + " s later than planned" +
      (pr->finished_before_t0 ? "" : " (the casting ran past world time 0: the first scans were cast live)"));
}

// The faults of the run (docs/demo.md "Faults"), each stepped through pending -> active -> done by
// world time.
class FaultSchedule {
 public:
  FaultSchedule(const DemoOptions& a, const DemoSetup& s, sim::LiveTeam& live, Supervisor& supervisor,
                Progress& progress, RunRecord& r)
      : a_(a),
        s_(s),
        live_(live),
        supervisor_(supervisor),
        progress_(progress),
        r_(r),
        station_(a.kill_station_at_s ? State::pending : State::done),
        unplug_(a.unplug_robot ? State::pending : State::done),
        kill_(a.kill_robot ? State::pending : State::done),
        shadows_(s.links.get(), s.shadows) {}

  // Killed stations, to be reported with the others once the run is over.
  std::vector<Child> old_stations;

  void step(double wt) {
    step_station(wt);
    step_unplug(wt);
    step_kill(wt);
    for (const std::string& line : shadows_.step(wt)) {
      log(line);
      progress_.event("teamscan demo: fault: " + line);
    }
  }
  // Whether children[ci] is down because of a fault (not watched for an early exit).
  [[nodiscard]] bool down_by_fault(std::size_t ci) const {
    return (ci == 0 && station_ == State::active) || (ci != 0 && ci == r_.killed_child);
  }

 private:
  enum class State { pending, active, done };

  void log(const std::string& line) { r_.faults.push_back(line); }
  std::size_t live_index_of(int id) const {
    for (std::size_t i = 0; i < live_.robot_count(); ++i)
      if (live_.spec(i).id == id) return i;
    return live_.robot_count();
  }
  void step_station(double wt) {
    if (station_ == State::pending && wt >= *a_.kill_station_at_s) {
      kill_child(r_.children[0]);
      old_stations.push_back(r_.children[0]);
      log("ground station killed (SIGKILL) at t = " + seconds_text(wt) + " s");
      station_ = State::active;
    } else if (station_ == State::active && wt >= *a_.kill_station_at_s + a_.station_down_s) {
      Child c{"teamscan-groundstation (restarted)", s_.out + "/logs/groundstation-restarted.log"};
      if (auto pid = supervisor_.spawn(station_argv(a_, s_), c.log)) c.pid = pid.value();
      r_.children[0] = c;
      log("ground station restarted at t = " + seconds_text(wt) + " s");
      station_ = State::done;
    }
  }
  void step_unplug(double wt) {
    const std::string robot = "robot" + std::to_string(a_.unplug_robot.value_or(0));
    if (unplug_ == State::pending && wt >= a_.unplug_at_s) {
      const std::size_t i = live_index_of(*a_.unplug_robot);
      if (i < live_.robot_count()) live_.unplug_laser(i);
      log(robot + " laser unplugged at t = " + seconds_text(wt) + " s");
      unplug_ = State::active;
    } else if (unplug_ == State::active && wt >= a_.unplug_at_s + a_.unplug_for_s) {
      const std::size_t i = live_index_of(*a_.unplug_robot);
      if (i < live_.robot_count() && !live_.replug_laser(i)) log("replug failed");
      log(robot + " laser replugged at t = " + seconds_text(wt) + " s");
      unplug_ = State::done;
    }
  }
  void step_kill(double wt) {
    if (kill_ != State::pending || wt < a_.kill_robot_at_s) return;
    const std::size_t i = live_index_of(*a_.kill_robot);
    if (i < live_.robot_count() && r_.children[1 + i].pid > 0) {
      kill_child(r_.children[1 + i]);
      r_.killed_child = 1 + i;
    }
    const std::string line =
        "robot" + std::to_string(*a_.kill_robot) + " daemon killed (SIGKILL) at t = " + seconds_text(wt) + " s";
    log(line);
    progress_.event("teamscan demo: fault: " + line);
    kill_ = State::done;
  }

  const DemoOptions& a_;
  const DemoSetup& s_;
  sim::LiveTeam& live_;
  Supervisor& supervisor_;
  Progress& progress_;
  RunRecord& r_;
  State station_, unplug_, kill_;
  ShadowSchedule shadows_;  // --shadow: robots' links down and up
};

std::string run_status(const DemoSetup& s, sim::LiveTeam& live, double now_s) {
  std::uint64_t scans = 0;
  for (std::size_t i = 0; i < live.robot_count(); ++i) scans += live.scans_measured(i);
  std::error_code ec;
  const auto bytes = fs::file_size(s.session + "/scans.bin", ec);
  char b[160];
  std::snprintf(b, sizeof b, "t = %.0f / %.0f s, %llu scans sent, %.1f MB stored", now_s, s.duration_s,
                static_cast<unsigned long long>(scans), ec ? 0.0 : static_cast<double>(bytes) / 1e6);
  return b;
}

// The robots drive from world time 0 to the duration, plus a moment for the last scans.
void drive(const DemoOptions& a, const DemoSetup& s, sim::LiveTeam& live, Supervisor& supervisor, Progress& progress,
           RunRecord& r, std::vector<Child>& old_stations) {
  FaultSchedule faults(a, s, live, supervisor, progress, r);
  const double end_s = s.duration_s + 0.5 * a.speed;
  while (live.world_time_s() < end_s) {
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
    for (std::size_t i = 0; i < live.robot_count(); ++i)
      for (sim::LiveScanTruth& t : live.take_truth(i)) r.truths[i].push_back(std::move(t));
    if (g_demo_signal.load() != 0) {
      r.interrupted = true;
      break;
    }
    faults.step(live.world_time_s());
    for (std::size_t ci = 0; ci < r.children.size(); ++ci) {
      Child& c = r.children[ci];
      if (faults.down_by_fault(ci)) continue;
      reap(c, false);
      if (c.exited && !r.child_died) {
        r.child_died = true;
        progress.event("teamscan demo: " + c.name + " exited early (code " + std::to_string(c.exit_code) + "), see " +
                       c.log);
      }
    }
    const double now_s = live.world_time_s();
    if (progress.shows_progress())
      progress.update(now_s / s.duration_s, now_s / a.speed, run_status(s, live, now_s));
  }
  progress.finish();
  old_stations = faults.old_stations;
}

// Stop in order: the robots first (their last scans reach the station), then the station, which
// writes its final model (an offline pass over the whole session: seconds for many robots).
void stop_processes(sim::LiveTeam& live, Supervisor& supervisor, RunRecord& r) {
  for (std::size_t i = 1; i < r.children.size(); ++i) stop_child(r.children[i], std::chrono::milliseconds(5000));
  std::this_thread::sleep_for(std::chrono::milliseconds(500));
  stop_child(r.children[0], std::chrono::milliseconds(120000));
  live.stop();
  for (std::size_t i = 0; i < live.robot_count(); ++i)
    for (sim::LiveScanTruth& t : live.take_truth(i)) r.truths[i].push_back(std::move(t));
  supervisor.kill_group();  // anything left in the group (none expected)
}

void catch_signals() {
  struct sigaction sa {};
  sa.sa_handler = demo_on_signal;
  ::sigemptyset(&sa.sa_mask);
  ::sigaction(SIGINT, &sa, nullptr);
  ::sigaction(SIGTERM, &sa, nullptr);
  ::sigaction(SIGHUP, &sa, nullptr);
}

}  // namespace

bool scenario_drifts(const sim::Scenario& scenario) {
  return std::any_of(scenario.robots.begin(), scenario.robots.end(), [](const sim::RobotSpec& r) {
    const sim::OdometryNoise& o = r.odometry;
    return o.slip != 0.0 || o.turn_slip != 0.0 || o.drift_rad_per_m != 0.0 || o.heading_walk_rad_per_sqrt_m > 0.0;
  });
}

std::vector<std::string> station_compare_methods(const DemoOptions& a) {
  std::vector<std::string> out;
  if (a.station_compare == "none") return out;
  if (a.station_compare == "paper") {
    out = mapping::known_methods();
    out.push_back("best");
    std::erase(out, a.station_method);
    return out;
  }
  std::stringstream list(a.station_compare);
  for (std::string m; std::getline(list, m, ',');)
    if (!m.empty()) out.push_back(m);
  return out;
}

int configure_demo(const DemoOptions& a, DemoSetup& setup) {
  // The robots' and the station's timing is real time (poses at 10 Hz, teamscan/team at 20 Hz, the
  // tracker's noise in m/s²): at --speed s the world moves s times further between two poses, so the
  // ghost filters see their teammates s times staler (docs/demo.md "Speed").
  if (a.speed > 1.0 && !a.force_speed) {
    std::fprintf(stderr,
                 "teamscan demo: --speed %.3g refused: the robots and the station run on real time (10 Hz poses, 20 Hz "
                 "team state), so above real time the ghost filters see teammates --speed times staler and the live "
                 "figures are not comparable with offline (docs/demo.md \"Speed\"); --force-speed runs it anyway\n",
                 a.speed);
    return 2;
  }
  setup.wall_start = std::chrono::steady_clock::now();
  if (int rc = load_scenario(a, setup)) return rc;
  if (int rc = resolve_registration(a, setup)) return rc;
  if (int rc = resolve_processes(a, setup)) return rc;
  if (int rc = check_link_faults(a, setup)) return rc;
  if (int rc = prepare_output(a, setup)) return rc;
  return make_link_network(a, setup);
}

int run_live(const DemoOptions& a, const DemoSetup& s, sim::LiveTeam& live, Progress& progress, RunRecord& r) {
  catch_signals();
  progress.stage("teamscan demo: " + s.scenario.name + ", " + std::to_string(live.robot_count()) + " robots, " +
                 seconds_text(s.duration_s) + " s of robot time, DDS domain " + std::to_string(s.domain) +
                 (s.links ? " in network namespaces" : " on loopback") + " (" + s.dds + "), registration " + s.registration_why +
                 (s.pose_graph ? ", pose graph on" : ", pose graph off") + (a.secure ? ", DDS Security on" : "") + "; output in " + s.out);
  Supervisor supervisor;
  const double feeder_cpu_start_s = self_cpu_s();
  const auto run_start = std::chrono::steady_clock::now();
  if (int rc = start_processes(a, s, live, supervisor, progress, r)) return rc;
  precast(a, s, live, progress, r);
  r.truths.assign(live.robot_count(), {});
  std::vector<Child> old_stations;
  drive(a, s, live, supervisor, progress, r, old_stations);
  // CPU of each process over the run itself (before the station's final model write), /proc/PID/stat.
  for (Child& c : r.children) c.run_cpu_s = proc_cpu_s(c.pid);
  // This process during the run: the device feeder (pty pacing, SIP source, ray casting) and the demo's
  // loop, without the casting done ahead of time.
  r.feeder_cpu_s = self_cpu_s() - feeder_cpu_start_s - r.precast_cpu_s;
  r.cast_cpu_s = live.cast_cpu_s();
  r.run_wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - run_start).count();
  progress.stage("teamscan demo: stopping the robots, then the ground station (it writes its final model)...");
  stop_processes(live, supervisor, r);
  for (const Child& c : old_stations) r.children.push_back(c);
  return 0;
}

int run_demo(const DemoOptions& a) {
  DemoSetup setup;
  if (int rc = configure_demo(a, setup)) return rc;
  sim::LiveOptions lo;
  lo.run_dir = setup.out + "/run";
  lo.speed = a.speed;
  lo.seed = a.seed;
  lo.bringup_s = a.bringup_s;
  lo.feed_period = from_seconds(a.feed_period_ms * 1e-3);
  auto live = sim::LiveTeam::create(setup.scenario, lo);
  if (!live) {
    std::fprintf(stderr, "teamscan demo: %s\n", live.error().what);
    return 1;
  }
  Progress progress(a.quiet);
  RunRecord record;
  if (int rc = run_live(a, setup, *live.value(), progress, record)) return rc;
  setup.links.reset();  // the namespaces deleted once every process has stopped
  if (record.interrupted) {
    std::printf("teamscan demo: interrupted; the session is in %s\n", setup.session.c_str());
    return 130;
  }
  return score_and_report(a, setup, *live.value(), progress, record);
}

}  // namespace teamscan::demo
