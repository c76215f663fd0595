// `teamscan demo` (demo.hpp): process supervision, configs, the run's loop with its faults, scoring and
// reports; the pieces live in supervisor.hpp, config_writer.hpp, session_csv.hpp and scoring.hpp.
#include "tools/demo/demo.hpp"

#include <signal.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <thread>
#include <vector>

#include "common/data_paths.hpp"
#include "common/dataset/dataset.hpp"
#include "common/dataset/pcd.hpp"
#include "groundstation/fusion/evaluation.hpp"
#include "groundstation/station/config.hpp"
#include "sim/live.hpp"
#include "sim/scenario.hpp"
#include "sim/simulator.hpp"
#include "tools/demo/config_writer.hpp"
#include "tools/demo/scoring.hpp"
#include "tools/demo/session_csv.hpp"
#include "tools/demo/supervisor.hpp"
#include "tools/pki/site_pki.hpp"
#include "tools/render/render.hpp"

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

std::string fmt(const char* f, double v) {
  char b[64];
  std::snprintf(b, sizeof b, f, v);
  return b;
}

std::string json_escape(const std::string& s) {
  std::string o;
  for (char c : s) {
    if (c == '"' || c == '\\') o += '\\';
    o += c;
  }
  return o;
}

// "p50 / p99 / max" of an error statistic, scaled.
std::string stats_text(const mapping::ErrorStats& e, double scale, const char* f) {
  return fmt(f, e.p50 * scale) + " / " + fmt(f, e.p99 * scale) + " / " + fmt(f, e.max * scale);
}

std::string stats_json(const mapping::ErrorStats& e) {
  std::ostringstream o;
  o << "{\"p50\": " << e.p50 << ", \"p99\": " << e.p99 << ", \"max\": " << e.max << ", \"count\": " << e.count << "}";
  return o.str();
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

int run_demo(const DemoOptions& a) {
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
  // Registration: as asked, else on exactly when the robots' odometry drifts (docs/demo.md "Registration").
  // A calibration (--calibration) turns it on too: its priors are the registration's.
  const bool registration = a.registration.value_or(!a.calibration_path.empty() || scenario_drifts(scenario));
  const char* registration_why = a.registration ? (registration ? "on (--registration)" : "off (--no-registration)")
                                 : !a.calibration_path.empty() ? "on (--calibration)"
                                 : registration ? "on: the scenario's robots drift"
                                                : "off: the scenario's robots do not drift";
  // Each robot's odometry prior: checked as the station will read it, then appended to its config.
  registration::RegistrationOptions priors;
  std::string calibration_toml;
  if (!a.calibration_path.empty()) {
    station::ConfigError error;
    if (!station::load_registration_priors(a.calibration_path, priors, error)) {
      std::fprintf(stderr, "teamscan demo: --calibration %s\n", error.message.c_str());
      return 2;
    }
    std::ifstream in(a.calibration_path);
    std::ostringstream text;
    text << in.rdbuf();
    calibration_toml = text.str();
  }

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
  std::printf("teamscan demo: registration %s\n", registration_why);

  Supervisor supervisor;
  std::vector<Child> children;
  write_text(out + "/config/groundstation.toml",
             station_config({out, domain, a.station_method, station_compare_methods(a), a.write_interval_s, a.station_ros2, a.view_port,
                             registration, calibration_toml}));
  const std::vector<std::string> station_argv = with(
      {station_bin, "--config", out + "/config/groundstation.toml", "--session-dir", session, "--domain", std::to_string(domain)},
      pki_args("station"));
  {
    Child c{"teamscan-groundstation", out + "/logs/groundstation.log"};
    auto pid = supervisor.spawn(station_argv, c.log);
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
    write_text(cfg, onboard_config(spec, {live.arcos_path(i), live.lms_path(i), team.motion(ti).pose_at(0.0), domain, a.max_hold_s}));
    Child c{"teamscan-onboard robot" + std::to_string(spec.id), out + "/logs/onboard-robot" + std::to_string(spec.id) + ".log"};
    auto pid = supervisor.spawn(with({onboard_bin, "--config", cfg}, pki_args("robot" + std::to_string(spec.id))), c.log);
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
      kill_child(children[0]);
      old_stations.push_back(children[0]);
      faults_log << "ground station killed (SIGKILL) at t = " << wt << " s\n";
      station_fault = Fault::active;
    } else if (station_fault == Fault::active && wt >= *a.kill_station_at_s + a.station_down_s) {
      Child c{"teamscan-groundstation (restarted)", out + "/logs/groundstation-restarted.log"};
      if (auto pid = supervisor.spawn(station_argv, c.log)) c.pid = pid.value();
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
        kill_child(children[1 + i]);
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
  supervisor.kill_group();  // anything left in the group (none expected)

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
  LiveDataset L = build_live_dataset(session, live, truths, scenario, offline.dataset, duration_s);
  if (!L.session_error.empty()) std::fprintf(stderr, "teamscan demo: session %s: %s\n", session.c_str(), L.session_error.c_str());

  auto methods = mapping::parse_methods(a.methods, std::nullopt, std::nullopt, {});
  if (!methods) {
    std::fprintf(stderr, "teamscan demo: --method %s: %s\n", a.methods.c_str(), methods.error().what);
    return 2;
  }
  mapping::EvalOptions eo;
  eo.methods = methods.value();
  // With the station's registration on, the offline and live evaluations run with it too
  // (`teamscan eval --registration`): the station's corrected model is compared with corrected evals.
  eo.registration = registration;
  eo.registration_options.prior = priors.prior;
  eo.registration_options.robot_priors = priors.robot_priors;
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
  const StationScore station = score_station_model(session + "/fused_all.pcd", L.ds.points, L.point_seq);
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
  // The station's models against `teamscan eval` of its own session (the fusion core fed the session
  // read back, in time order): the same decision for every point (docs/groundstation.md "The fusion
  // core"), for its method and for each of its [fusion] compare_methods, one line each.
  bool session_agree = true;
  std::ostringstream by_method;
  for (const SessionEvalCheck& sc :
       check_station_models_against_session_eval(session, out + "/config/groundstation.toml", L.ds.points, L.point_seq)) {
    char line[700];
    session_agree = session_agree && sc.identical;
    if (!sc.error.empty()) {
      std::snprintf(line, sizeof line, "  station model (%s) vs `teamscan eval SESSION`: %s\n", sc.method.c_str(), sc.error.c_str());
      stxt << line;
    } else {
      std::snprintf(line, sizeof line,
                    "  station model vs `teamscan eval SESSION` (%s, the same core on the session read back): %llu of %llu session points in "
                    "the model (%llu beyond the per-voxel cap), %llu decisions differ: %s\n"
                    "    labelled (%zu points): station DA %.2f %%, SA %.3f %% | eval DA %.2f %%, SA %.3f %% | ΔDA %+.2f, ΔSA %+.3f; "
                    "decisions at release (`live_keep`): DA %.2f %%, SA %.3f %%\n",
                    sc.method.c_str(), static_cast<unsigned long long>(sc.compared),
                    static_cast<unsigned long long>(sc.compared + sc.not_in_model), static_cast<unsigned long long>(sc.not_in_model),
                    static_cast<unsigned long long>(sc.mismatches), sc.identical ? "identical" : "DIFFERENT", sc.labelled,
                    sc.station.da, sc.station.sa, sc.eval.da, sc.eval.sa, sc.station.da - sc.eval.da, sc.station.sa - sc.eval.sa,
                    sc.live.da, sc.live.sa);
      stxt << line;
      std::ostringstream obj;
      obj << "{\"method\": \"" << json_escape(sc.method) << "\", \"compared\": " << sc.compared
          << ", \"not_in_model\": " << sc.not_in_model << ", \"mismatches\": " << sc.mismatches << ", \"labelled\": " << sc.labelled
          << ", \"station_da\": " << sc.station.da << ", \"station_sa\": " << sc.station.sa << ", \"eval_da\": " << sc.eval.da
          << ", \"eval_sa\": " << sc.eval.sa << ", \"live_da\": " << sc.live.da << ", \"live_sa\": " << sc.live.sa
          << ", \"identical\": " << (sc.identical ? "true" : "false") << "}";
      if (sc.primary) stj << "  \"station_vs_session_eval\": " << obj.str() << ",\n";
      by_method << (by_method.tellp() > 0 ? ",\n    " : "\n    ") << obj.str();
    }
  }
  stj << "  \"station_vs_session_eval_by_method\": [" << by_method.str() << "\n  ],\n";
  // The station's models against its own core replaying its session in arrival order: with the
  // registration on, the identity the verdict requires (the registration's corrections follow the
  // release order, live the arrival order; `teamscan eval SESSION` feeds stamp order, so its decisions
  // above are reported, not required then: docs/demo.md "Registration").
  const std::string replay_dir = out + "/session-replay";
  const SessionReplay replay = replay_station_session(session, out + "/config/groundstation.toml", replay_dir);
  fs::remove_all(replay_dir, ec);
  bool replay_agree = replay.error.empty() && !replay.models.empty();
  {
    std::ostringstream t, by;
    if (!replay.error.empty()) t << "  station models vs the station's core replaying its session in arrival order: " << replay.error << "\n";
    for (const ReplayModelCheck& m : replay.models) {
      replay_agree = replay_agree && m.identical;
      if (!m.error.empty()) {
        t << "  station model (" << m.method << ") vs the replay in arrival order: " << m.error << "\n";
      } else {
        t << "  station model vs its core replaying the session in arrival order (" << m.method << "): " << m.compared << " of "
          << m.model_points << " rows compared (replay " << m.replay_points << "), " << m.decisions_differ << " decisions and "
          << m.placed_differ << " positions (> 1 mm, largest " << fmt("%.1f", m.placed_differ_max_m * 1e3)
          << " mm) differ: " << (m.identical ? "identical" : "DIFFERENT") << "\n";
      }
      by << (by.tellp() > 0 ? ",\n    " : "\n    ") << "{\"method\": \"" << json_escape(m.method) << "\", \"error\": \"" << json_escape(m.error)
         << "\", \"model_points\": " << m.model_points << ", \"replay_points\": " << m.replay_points << ", \"compared\": " << m.compared
         << ", \"decisions_differ\": " << m.decisions_differ << ", \"placed_differ\": " << m.placed_differ
         << ", \"placed_differ_max_m\": " << m.placed_differ_max_m << ", \"identical\": " << (m.identical ? "true" : "false") << "}";
    }
    stxt << t.str();
    stj << "  \"station_vs_session_replay_by_method\": [" << by.str() << "\n  ],\n";
  }
  // The registration live: pose and point error against the truth with the odometry alone and as the
  // station corrected them (docs/demo.md "Registration"), beside the model's DA/SA above.
  const LiveRegistrationScore reg = score_live_registration(session, out + "/config/groundstation.toml", replay, L);
  const mapping::RegistrationReport& reg_offline = offline_report.registration;
  {
    std::ostringstream t;
    t << "  registration " << registration_why << "; pose error per scan (" << reg.scans
      << " scans of the run window) and point error per non-ghost point (" << reg.points << ") against the truth:\n";
    if (!reg.error.empty()) t << "    not measured: " << reg.error << "\n";
    t << "    odometry alone:                translation p50 / p99 / max " << stats_text(reg.pose_m_odometry, 100, "%.1f")
      << " cm, rotation " << stats_text(reg.pose_deg_odometry, 1, "%.2f") << " deg, point error "
      << stats_text(reg.point_m_odometry, 100, "%.1f") << " cm\n";
    if (reg.enabled) {
      t << "    the station's corrected model: translation p50 / p99 / max " << stats_text(reg.pose_m_corrected, 100, "%.1f")
        << " cm, rotation " << stats_text(reg.pose_deg_corrected, 1, "%.2f") << " deg, point error "
        << stats_text(reg.point_m_corrected, 100, "%.1f") << " cm\n";
      if (reg_offline.enabled && reg_offline.have_truth)
        t << "    offline `teamscan eval --registration` of the same scenario: translation " << stats_text(reg_offline.pose_m_after, 100, "%.1f")
          << " cm, rotation " << stats_text(reg_offline.pose_deg_after, 1, "%.2f") << " deg, point error "
          << stats_text(reg_offline.point_m_after, 100, "%.1f") << " cm (odometry alone: translation p99 "
          << fmt("%.1f", reg_offline.pose_m_before.p99 * 100) << " cm, rotation p99 " << fmt("%.2f", reg_offline.pose_deg_before.p99)
          << " deg)\n";
      t << "    matches:";
      for (const registration::RobotCorrection& c : replay.robots)
        t << " robot" << unsigned(c.robot) << " " << c.accepted << " accepted of " << c.matches << " (" << c.too_few_features
          << " too few features, " << c.degenerate << " degenerate, " << c.rejected_overlap + c.rejected_fit + c.rejected_step
          << " rejected);";
      t << " " << reg.points_moved << " session points moved by the corrections (up to " << fmt("%.1f", reg.points_moved_max_m * 100)
        << " cm)\n";
    }
    stxt << t.str();
    stj << "  \"registration\": {\"enabled\": " << (reg.enabled ? "true" : "false") << ", \"why\": \"" << json_escape(registration_why)
        << "\", \"error\": \"" << json_escape(reg.error) << "\", \"scans\": " << reg.scans << ", \"points\": " << reg.points
        << ",\n    \"pose_m_odometry\": " << stats_json(reg.pose_m_odometry) << ", \"pose_deg_odometry\": " << stats_json(reg.pose_deg_odometry)
        << ", \"point_m_odometry\": " << stats_json(reg.point_m_odometry) << ",\n    \"pose_m_corrected\": " << stats_json(reg.pose_m_corrected)
        << ", \"pose_deg_corrected\": " << stats_json(reg.pose_deg_corrected) << ", \"point_m_corrected\": " << stats_json(reg.point_m_corrected)
        << ",\n    \"points_moved\": " << reg.points_moved << ", \"points_moved_max_m\": " << reg.points_moved_max_m
        << ",\n    \"offline_pose_m_registered\": " << stats_json(reg_offline.pose_m_after) << ", \"offline_pose_deg_registered\": "
        << stats_json(reg_offline.pose_deg_after) << ", \"offline_point_m_registered\": " << stats_json(reg_offline.point_m_after)
        << ",\n    \"robots\": [";
    for (std::size_t i = 0; i < replay.robots.size(); ++i) {
      const registration::RobotCorrection& c = replay.robots[i];
      stj << (i ? ", " : "") << "{\"robot\": " << unsigned(c.robot) << ", \"matches\": " << c.matches << ", \"accepted\": " << c.accepted
          << ", \"degenerate\": " << c.degenerate << ", \"too_few_features\": " << c.too_few_features << "}";
    }
    stj << "]},\n";
  }
  // The corrections back on the robots: what each daemon took from teamscan/team and applied to the
  // scans it published, and the pose error of those scans as the robot placed them.
  {
    const RobotCorrections rc = score_robot_corrections(session, L);
    std::ostringstream t;
    std::ostringstream j;
    if (!rc.error.empty()) t << "  corrections on the robots: not measured: " << rc.error << "\n";
    for (const RobotCorrectionScore& r : rc.robots) {
      t << "  robot" << unsigned(r.robot) << " applied " << r.corrections_applied << " corrections from teamscan/team (refused "
        << r.corrections_rejected << "); " << r.scans_corrected << " of " << r.scans << " stored scans carry one ("
        << r.corrections_carried << " distinct, the last (" << r.last.x_mm << " mm, " << r.last.y_mm << " mm, "
        << fmt("%.3f", r.last.yaw_urad * 1e-6 * kRadToDeg) << " deg) #" << r.last.seq << ")";
      if (r.pose_m_robot.count > 0)
        t << "; pose error of the " << r.pose_m_robot.count << " run-window scans carrying one: as the robot placed them "
          << stats_text(r.pose_m_robot, 100, "%.1f") << " cm, " << stats_text(r.pose_deg_robot, 1, "%.2f")
          << " deg; odometry alone " << stats_text(r.pose_m_odometry, 100, "%.1f") << " cm, " << stats_text(r.pose_deg_odometry, 1, "%.2f")
          << " deg";
      t << "\n";
      j << (j.tellp() > 0 ? ",\n    " : "\n    ") << "{\"robot\": " << unsigned(r.robot) << ", \"corrections_applied\": " << r.corrections_applied
        << ", \"corrections_rejected\": " << r.corrections_rejected << ", \"scans\": " << r.scans
        << ", \"scans_corrected\": " << r.scans_corrected << ", \"corrections_carried\": " << r.corrections_carried
        << ", \"last_x_mm\": " << r.last.x_mm << ", \"last_y_mm\": " << r.last.y_mm << ", \"last_yaw_urad\": " << r.last.yaw_urad
        << ", \"last_seq\": " << r.last.seq << ",\n      \"pose_m_robot\": " << stats_json(r.pose_m_robot)
        << ", \"pose_deg_robot\": " << stats_json(r.pose_deg_robot) << ", \"pose_m_odometry\": " << stats_json(r.pose_m_odometry)
        << ", \"pose_deg_odometry\": " << stats_json(r.pose_deg_odometry) << "}";
    }
    stxt << t.str();
    stj << "  \"robot_corrections\": {\"error\": \"" << json_escape(rc.error) << "\", \"robots\": [" << j.str() << "\n  ]},\n";
  }
  // The identity the verdict requires: with the registration off, `teamscan eval SESSION` (stamp order:
  // the decisions do not depend on the order); with it on, the station's own core on its session in
  // arrival order (the corrections follow the order), and the eval's differences are reported above.
  agree = agree && station_agree && (registration ? replay_agree : session_agree);

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
       << ", \"duplicates\": " << d.duplicates << ", \"refused\": " << d.refused
       << ", \"last_status_published\": " << d.last_status_published
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
    Result<std::vector<StatusRow>> status = read_status_csv(session + "/status.csv");
    if (!status) std::fprintf(stderr, "teamscan demo: %s/status.csv: %s\n", session.c_str(), status.error().what);
    const UnplugReport u = unplug_report(status ? status.value() : std::vector<StatusRow>{},
                                         static_cast<std::uint32_t>(*a.unplug_robot));
    const std::vector<unsigned>& states = u.lms_states;
    const std::uint32_t reopens = u.lms_reopens;
    fj << "  \"unplug\": {\"robot\": " << *a.unplug_robot << ", \"lms_states\": [";
    for (std::size_t k = 0; k < states.size(); ++k) fj << (k ? ", " : "") << states[k];
    fj << "], \"lms_reopens\": " << reopens << "},\n";
    std::printf("fault: robot%d laser unplugged: lms_state sequence in status.csv:", *a.unplug_robot);
    for (unsigned st : states) std::printf(" %u", st);
    std::printf("; lms reopens %u\n", reopens);
  }
  if (a.kill_robot) {
    const std::int64_t kill_rt = live.t0_realtime_ns() + static_cast<std::int64_t>(a.kill_robot_at_s / a.speed * 1e9);
    const KillReport k = kill_report(session, static_cast<std::uint32_t>(*a.kill_robot), kill_rt);
    const double lost_after_s = k.lost_after_s;
    const std::uint64_t scans_after = k.others_scans_after, stale_before = k.team_stale_before,
                        stale_after = k.team_stale_after, filtered_after = k.direction_filtered_after;
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
  sj << "{\n  \"scenario\": \"" << json_escape(scenario.name) << "\",\n  \"secure\": " << (a.secure ? "true" : "false")
     << ",\n  \"duration_s\": " << duration_s
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

}  // namespace teamscan::demo
