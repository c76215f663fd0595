// Live device feeding: the simulator in real time. Per robot, an emulated Pioneer and LMS-200 run on
// pseudo-terminals (serial::PtyRunner, symlinks RUN/robotN-arcos and RUN/robotN-lms200) and are fed
// by the simulator's wheel model (the emulator's SIP source hook) and ray caster at wall-clock time ×
// speed, so a real teamscan-onboard can open them like /dev/ttyS*. The host's VEL/RVEL commands do
// not move the simulated robot: the scenario's tracks do, except that a robot whose client goes silent
// stops as the firmware stops it (PROTOCOLS.md §1.6) and drives on when its client is back. The ray cast's truth of every sent scan is
// recorded (per beam: class, hit robot, true point) so the live result can be scored (docs/demo.md).
#pragma once

#include <cstdint>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "common/dataset/dataset.hpp"
#include "common/pose.hpp"
#include "common/result.hpp"
#include "common/time.hpp"
#include "sim/scenario.hpp"

namespace teamscan::sim {

struct LiveOptions {
  std::string run_dir;                 // the pty symlinks go here
  double speed = 1.0;                  // world seconds per wall-clock second
  double bringup_s = 5.0;              // robots stand still this long after start() (device bring-up)
  std::optional<std::uint64_t> seed;   // overrides the scenario's
  std::vector<std::uint8_t> robot_ids; // robots to run (empty: all of the scenario)
  // > 0: one thread steps every pty this often and releases the bytes due, in chunks, as a USB-serial
  // adapter does on its latency timer; 0: a thread per pty, each byte on time (serial::PtyRunner::start).
  Duration feed_period = std::chrono::milliseconds(1);
  bool loop = false;                   // replay the scenario's motion forever (period: its duration), for soaks
};

// What robot i is doing at a world time in the live world: its true pose and motion; `held` while its
// firmware holds it still (client silent, PROTOCOLS.md §1.6), velocities 0 then.
struct LiveTruth {
  Pose2 pose;
  double v_mps = 0, w_radps = 0;
  bool held = false;
};

// Truth of one beam as cast (what the scanner's value word was made from).
struct LiveBeamTruth {
  float tx = 0, ty = 0, tz = 0;
  PointClass label = PointClass::none;
  std::uint8_t hit_robot = 0;
};

// Truth of one sent scan: its sweep end (CLOCK_REALTIME, the clock the onboard daemon stamps with)
// and every beam.
struct LiveScanTruth {
  std::int64_t sweep_end_realtime_ns = 0;
  std::vector<LiveBeamTruth> beams;
};

class LiveRobot;

// What LiveTeam::precast did.
struct PrecastReport {
  std::uint64_t scans = 0;          // sweeps cast ahead (about)
  double cpu_s = 0;                 // CPU time of the casting workers
  double wall_s = 0;                // waiting for the scanners + casting
  double delayed_s = 0;             // how much later world time 0 is than start() said
  bool finished_before_t0 = false;  // else the first sweeps after t0 were cast live
};

class LiveTeam {
 public:
  [[nodiscard]] static Result<std::unique_ptr<LiveTeam>> create(const Scenario& scenario, const LiveOptions& options);
  ~LiveTeam();
  LiveTeam(const LiveTeam&) = delete;
  LiveTeam& operator=(const LiveTeam&) = delete;

  // Starts every device now; world time 0 (the robots start to drive) is bringup_s later.
  [[nodiscard]] Status start();
  // Casts every sweep of every scanner from world time 0 to `world_duration_s` (+1 s) ahead of time, so
  // that during the run the feeder only looks scans up and paces bytes (docs/demo.md "Scale"). Waits
  // until every scanner streams (its sweep grid is then known), moves world time 0 on by the expected
  // casting time (the robots still stand), and casts on up to 2 threads. A sweep not in the table (a
  // restarted scanner, a late table) is cast live as before. Call after start(), during bring-up.
  [[nodiscard]] Result<PrecastReport> precast(double world_duration_s, Duration grid_timeout = std::chrono::seconds(30));
  // Scans the LMS emulators took from the precast table.
  [[nodiscard]] std::uint64_t scans_from_precast() const;
  void stop();

  [[nodiscard]] std::size_t robot_count() const;
  [[nodiscard]] const RobotSpec& spec(std::size_t i) const;
  [[nodiscard]] std::string arcos_path(std::size_t i) const;
  [[nodiscard]] std::string lms_path(std::size_t i) const;
  // CLOCK_REALTIME of world time 0, and world time now (negative during bring-up).
  [[nodiscard]] std::int64_t t0_realtime_ns() const { return t0_realtime_ns_; }
  [[nodiscard]] double world_time_s() const;
  // World time of a CLOCK_REALTIME stamp.
  [[nodiscard]] double world_time_of(std::int64_t realtime_ns) const;
  [[nodiscard]] double speed() const { return options_.speed; }

  // Robot i's truth at world time t_s: the scenario's track, held still from the moment its emulated
  // firmware stopped it (no client command for the watchdog time, or a CLOSE) until its client is back;
  // the track drives on from where the robot stopped. The ray casts (its own scans and its teammates'
  // scans of it) use the same poses.
  [[nodiscard]] LiveTruth true_motion(std::size_t i, double world_t_s) const;
  // How many times robot i's firmware held it still so far.
  [[nodiscard]] std::size_t holds(std::size_t i) const;

  // Cable out / in on one robot's laser (index i): the host sees EIO, then a new pty.
  void unplug_laser(std::size_t i);
  [[nodiscard]] Status replug_laser(std::size_t i);

  // The truth of the scans sent so far by robot i (moved out; later calls return newer ones).
  [[nodiscard]] std::vector<LiveScanTruth> take_truth(std::size_t i);
  // Scans the LMS emulator of robot i has measured so far.
  [[nodiscard]] std::uint64_t scans_measured(std::size_t i) const;
  // Beams of robot i whose ray hit a teammate (ghosts in the making).
  [[nodiscard]] std::uint64_t ghost_beams(std::size_t i) const;
  // CPU time (thread CPU clock) spent ray casting scans, all robots together, seconds.
  [[nodiscard]] double cast_cpu_s() const;

 private:
  LiveTeam(const Scenario& scenario, const LiveOptions& options);
  struct Impl;
  std::unique_ptr<Impl> impl_;
  LiveOptions options_;
  std::int64_t t0_realtime_ns_ = 0;
  std::int64_t t0_monotonic_ns_ = 0;
};

// Labels the points of one stored scan with the truth of the scan whose sweep end is nearest its stamp
// (within `tolerance_ns`); returns nullptr if none. `truths` is sorted by sweep end.
[[nodiscard]] const LiveScanTruth* match_truth(const std::vector<LiveScanTruth>& truths, std::int64_t stamp_ns,
                                               std::int64_t tolerance_ns);

}  // namespace teamscan::sim
