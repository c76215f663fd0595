// Live device feeding (live.hpp): per robot a PioneerEmulator behind a PtyRunner fed by the wheel model
// (SipSource) and an LmsPtyEmulator fed by the ray caster (RangeSource), both on the runners' clock
// (CLOCK_MONOTONIC) mapped to world time as (now − t0) × speed.
#include "sim/live.hpp"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <ctime>
#include <limits>
#include <filesystem>
#include <thread>

#include "common/clock.hpp"
#include "drivers/arcos/emulator.hpp"
#include "drivers/lms200/emulator_pty.hpp"
#include "drivers/serial/pty_runner.hpp"
#include "sim/devices.hpp"
#include "sim/motion_hold.hpp"
#include "sim/rng.hpp"
#include "sim/simulator.hpp"

namespace teamscan::sim {

namespace {

// World time of a monotonic instant.
// World time of a monotonic instant. t0 may move later while the robots still stand (LiveTeam::precast),
// read by the feeder thread meanwhile: atomic.
struct WorldClock {
  std::atomic<std::int64_t> t0_monotonic_ns{0};
  double speed = 1.0;
  double loop_s = 0;  // > 0: the scene (tracks) repeats with this period (LiveOptions::loop)
  [[nodiscard]] double at(Time monotonic) const {
    return static_cast<double>(monotonic.ns() - t0_monotonic_ns.load(std::memory_order_relaxed)) * 1e-9 * speed;
  }
  // Where the scene is at world time t_s. Looping keeps world time (and so the wheel model's dt)
  // continuous and only wraps the tracks; a closed track (lap2's ovals) ends where it started.
  [[nodiscard]] double scene(double t_s) const { return loop_s > 0 && t_s > 0 ? std::fmod(t_s, loop_s) : t_s; }
};

// The live world: the scenario's robots on their tracks, each held still while its firmware holds it
// (client silent, MotionHold), at world time from a WorldClock. Every pose the feeder, the ray casters
// and the scoring use comes from here.
struct LiveWorld {
  LiveWorld(const TeamWorld& t, std::size_t robots) : team{t}, holds(robots) {}
  const TeamWorld& team;
  std::vector<MotionHold> holds;  // by team index
  // World time from which the precast tables no longer hold (a robot was held or released): +inf.
  std::atomic<double> precast_valid_until_s{std::numeric_limits<double>::infinity()};

  // Robot k's true pose at world time t_s (>= 0), as `clock` maps it onto the scene.
  [[nodiscard]] Pose2 pose(std::size_t k, double t_s, const WorldClock& clock) const {
    return team.motion(k).pose_at(clock.scene(holds[k].track_time(t_s)));
  }
  void changed_at(double t_s) {
    double cur = precast_valid_until_s.load();
    while (t_s < cur && !precast_valid_until_s.compare_exchange_weak(cur, t_s)) {
    }
  }
};

// The Pioneer's wheel model behind the SIP hook (as in simulator.cpp's device path): true motion at
// the SIP's world time -> noisy firmware odometry -> XPOS/YPOS/THPOS and wheel velocities. Before
// world time 0 the robot stands at its start pose.
class LiveWheels final : public arcos::SipSource {
 public:
  LiveWheels(const TeamWorld& team, LiveWorld& world, std::size_t ri, std::uint64_t seed, const WorldClock& clock)
      : team_{team},
        world_{world},
        ri_{ri},
        clock_{clock},
        firmware_{pioneer_params(team.spec(ri).subclass), team.spec(ri).odometry,
                  Rng{seed, team.spec(ri).id, RngStream::odometry}, team.motion(ri).pose_at(0.0)} {}

  bool fill_sip(Time now, arcos::SipPacket& sip) override {
    const double t_s = std::max(0.0, clock_.at(now));
    const Pose2 truth = world_.pose(ri_, t_s, clock_);  // held still while the firmware holds the robot
    const double dt_s = have_last_ ? std::max(0.0, t_s - last_s_) : 0.0;
    const SipOdometry o = firmware_.step(truth, dt_s);
    last_s_ = t_s;
    have_last_ = true;
    fill_sip_odometry(o, sip);
    return true;
  }

  // PROTOCOLS.md §1.6: the emulated firmware stopped the robot (its client went silent) / the client
  // is back. Before world time 0 the robot stands anyway.
  void on_client_silent(Time since) override {
    const double t_s = std::max(0.0, clock_.at(since));
    world_.holds[ri_].hold(t_s);
    world_.changed_at(t_s);
  }
  void on_client_back(Time at) override {
    const double t_s = std::max(0.0, clock_.at(at));
    world_.holds[ri_].release(t_s);
    world_.changed_at(t_s);
  }

 private:
  const TeamWorld& team_;
  LiveWorld& world_;
  std::size_t ri_;
  const WorldClock& clock_;
  PioneerOdometry firmware_;
  double last_s_ = 0;
  bool have_last_ = false;
};

// Ray casting of one sweep: every beam at its own world time (laser_geometry.hpp beam_age) against the
// room and the teammates' bodies at that time. Holds its own scratch, so each thread has one.
class SweepCaster {
 public:
  SweepCaster(const LiveWorld& world, std::size_t ri)
      : team_{world.team}, world_{world}, ri_{ri}, bound_radius_m_{bound_radii(world.team)} {}

  // Casts the sweep ending at monotonic `sweep_end`, world time from `clock`; fills n readings and truths.
  // Returns the beams that hit a teammate.
  std::uint64_t cast(Time sweep_end, const LaserVariant& variant, const WorldClock& clock, Rng& rng,
                     lms200::BeamReading* readings, LiveBeamTruth* truths, Hit* hits_out = nullptr) {
    const RobotSpec& spec = team_.spec(ri_);
    const std::uint16_t n = variant.beams();
    std::uint64_t ghosts = 0;
    // Which teammates can a beam of this sweep hit at all? Placed once at mid-sweep: teammate k is a
    // candidate for a beam only if the beam's horizontal direction passes within its bounding radius
    // (plus a margin for the motion of both robots during the 13 ms sweep) of its centre. The others
    // are left out of that beam's cast: the same hits (checked against the full cast: 0 differences in
    // 1.8 M beams, 46 k of them on a teammate, 8 robots), without placing and testing every body per beam.
    const Time mid_time = sweep_end - variant.beam_age(static_cast<std::uint16_t>(n / 2));
    const double mid_s = std::max(0.0, clock.at(mid_time));
    team_.place(clock.scene(mid_s), placed_);
    for (std::size_t k = 0; k < placed_.size(); ++k) placed_[k].map_from_robot = world_.pose(k, mid_s, clock);
    const Ray mid_ray = team_.beam_ray(ri_, placed_[ri_].map_from_robot, Vec3{1.0, 0.0, 0.0});
    cull_.clear();
    for (std::size_t k = 0; k < placed_.size(); ++k) {
      if (k == ri_ || placed_[k].body == nullptr) continue;
      const double dx = placed_[k].map_from_robot.x_m - mid_ray.origin.x, dy = placed_[k].map_from_robot.y_m - mid_ray.origin.y;
      const double d = std::hypot(dx, dy), r = bound_radius_m_[k] + kCullMarginM;
      // cos of the half-angle the bounding circle subtends; inside it (d <= r) every beam is a candidate.
      cull_.push_back({k, d > r ? dx / d : 0.0, d > r ? dy / d : 0.0, d > r ? std::sqrt(1.0 - (r / d) * (r / d)) : -2.0});
    }
    for (std::uint16_t i = 0; i < n; ++i) {
      const Time beam_time = sweep_end - variant.beam_age(i);
      const double t_s = std::max(0.0, clock.at(beam_time));
      const double a = variant.beam_angle_rad(i);
      const Vec3 dir = spec.robot_from_laser.rotation.apply({std::cos(a), std::sin(a), 0.0});
      const Ray ray = team_.beam_ray(ri_, world_.pose(ri_, t_s, clock), dir);
      const double h = std::hypot(ray.direction.x, ray.direction.y);
      beam_robots_.clear();
      for (const Candidate& c : cull_) {
        if (h > 1e-9 && (ray.direction.x * c.ux + ray.direction.y * c.uy) / h < c.cos_half) continue;
        beam_robots_.push_back({team_.spec(c.index).id, world_.pose(c.index, t_s, clock), &team_.body(c.index)});
      }
      const Hit hit = team_.world().cast(ray, beam_robots_, spec.id);
      if (hits_out != nullptr) hits_out[i] = hit;
      if (reading(hit, spec.range_noise_mm, rng, readings[i], truths[i])) ++ghosts;
    }
    return ghosts;
  }

  // The scanner's reading of one hit (range noise drawn from `rng`) and its truth; true on a teammate.
  static bool reading(const Hit& hit, double range_noise_mm, Rng& rng, lms200::BeamReading& r, LiveBeamTruth& b) {
    const std::uint16_t word = lms_value_word(hit.hit, hit.range_m, range_noise_mm, rng);
    r = {};
    if (word == kLmsCodeNotValid) r.invalid = lms200::BeamInvalid::not_valid;
    else if (word == kLmsCodeTooFar) r.invalid = lms200::BeamInvalid::over_range;
    else r.range_mm = word;
    b.tx = static_cast<float>(hit.point_m.x);
    b.ty = static_cast<float>(hit.point_m.y);
    b.tz = static_cast<float>(hit.point_m.z);
    b.label = hit.label;
    b.hit_robot = hit.hit_robot;
    return hit.label == PointClass::robot;
  }

 private:
  struct Candidate {
    std::size_t index;
    double ux, uy;    // unit vector laser -> teammate centre (horizontal)
    double cos_half;  // a beam is a candidate if cos(angle to u) >= this
  };
  static constexpr double kCullMarginM = 0.15;  // > 2 × 13 ms × the fastest track speed, plus the mount offset's swing

  // Horizontal bounding radius of every robot's body around its centre.
  static std::vector<double> bound_radii(const TeamWorld& team) {
    std::vector<double> r(team.robot_count());
    for (std::size_t k = 0; k < r.size(); ++k) {
      const RobotBody& b = team.body(k);
      const double x = std::max(std::fabs(b.bound_min_m.x), std::fabs(b.bound_max_m.x));
      const double y = std::max(std::fabs(b.bound_min_m.y), std::fabs(b.bound_max_m.y));
      r[k] = std::hypot(x, y);
    }
    return r;
  }

  const TeamWorld& team_;
  const LiveWorld& world_;
  std::size_t ri_;
  std::vector<double> bound_radius_m_;
  std::vector<PlacedRobot> placed_;
  std::vector<Candidate> cull_;
  std::vector<PlacedRobot> beam_robots_;
};

std::int64_t thread_cpu_ns() {
  timespec ts{};
  ::clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return static_cast<std::int64_t>(ts.tv_sec) * 1'000'000'000 + ts.tv_nsec;
}

// The LMS-200's measurement: each sent scan from the precast table if it holds that sweep (LiveTeam::
// precast), else ray-cast now; the truth of each sent scan recorded with its sweep end in CLOCK_REALTIME.
class LiveLaser final : public lms200::RangeSource {
 public:
  LiveLaser(const LiveWorld& world, std::size_t ri, std::uint64_t seed, const WorldClock& clock,
            std::int64_t realtime_offset_ns)
      : team_{world.team},
        world_{world},
        ri_{ri},
        seed_{seed},
        clock_{clock},
        realtime_offset_ns_{realtime_offset_ns},
        rng_{seed, world.team.spec(ri).id, RngStream::range_noise},
        caster_{world, ri} {}

  void measure(const lms200::SweepTiming& sweep, std::span<lms200::BeamReading> beams) override {
    const std::int64_t cpu_start_ns = thread_cpu_ns();
    const std::uint16_t n = static_cast<std::uint16_t>(std::min<std::size_t>(sweep.variant.beams(), beams.size()));
    LiveScanTruth truth;
    truth.sweep_end_realtime_ns = sweep.sweep_end.ns() + realtime_offset_ns_;
    truth.beams.resize(n);
    std::uint64_t ghosts = 0;
    // The sweep grid: the scanner's sweeps end every scan period after the first one it streamed.
    const std::int64_t period_ns = (kLmsRevolution * sweep.variant.revolutions()).count();
    if (!grid_known_.load()) {
      grid_first_end_ns_ = sweep.sweep_end.ns();
      grid_period_ns_ = period_ns;
      variant_ = sweep.variant;
      grid_known_.store(true);
    }
    const Precast* pc = lookup(sweep, n);
    // Before world time 0 every robot stands at its start pose: a sweep that ends by then sees what the
    // first standing sweep saw, only the range noise is new (bring-up costs no casting).
    const bool standing = clock_.at(sweep.sweep_end) <= 0.0;
    if (pc != nullptr) {
      const std::size_t k = static_cast<std::size_t>((sweep.sweep_end.ns() - pc->first_end_ns) / pc->period_ns);
      std::copy_n(pc->readings.begin() + static_cast<std::ptrdiff_t>(k * n), n, beams.begin());
      std::copy_n(pc->truths.begin() + static_cast<std::ptrdiff_t>(k * n), n, truth.beams.begin());
      ghosts = pc->ghosts[k];
    } else if (standing && standing_hits_.size() == n && sweep.variant == standing_variant_) {
      const double noise_mm = team_.spec(ri_).range_noise_mm;
      for (std::uint16_t i = 0; i < n; ++i) ghosts += SweepCaster::reading(standing_hits_[i], noise_mm, rng_, beams[i], truth.beams[i]) ? 1 : 0;
    } else {
      if (standing) standing_hits_.resize(n);
      ghosts = caster_.cast(sweep.sweep_end, sweep.variant, clock_, rng_, beams.data(), truth.beams.data(),
                            standing ? standing_hits_.data() : nullptr);
      standing_variant_ = sweep.variant;
    }
    std::lock_guard<std::mutex> lock{mutex_};
    truths_.push_back(std::move(truth));
    ++measured_;
    ghost_beams_ += ghosts;
    if (pc != nullptr) ++from_precast_;
    cast_cpu_ns_ += thread_cpu_ns() - cpu_start_ns;
  }

  // The sweep grid once the scanner streams (first sweep end, period; monotonic ns).
  [[nodiscard]] bool grid_known() const { return grid_known_.load(); }
  // Casts every sweep of the grid ending in [from, to) (monotonic) into a table, world time from
  // `clock` (a provisional t0); publish_precast() hands it to measure(). Runs on a worker thread;
  // returns the CPU time spent.
  std::int64_t precast(Time from, Time to, const WorldClock& clock) {
    const std::int64_t cpu_start_ns = thread_cpu_ns();
    auto pc = std::make_unique<Precast>();
    pc->first_end_ns = grid_first_end_ns_;
    pc->period_ns = grid_period_ns_;
    const std::int64_t k0 = std::max<std::int64_t>(0, (from.ns() - pc->first_end_ns + pc->period_ns - 1) / pc->period_ns);
    const std::int64_t k1 = std::max<std::int64_t>(k0, (to.ns() - pc->first_end_ns) / pc->period_ns);
    pc->first_end_ns += k0 * pc->period_ns;
    const auto count = static_cast<std::size_t>(k1 - k0);
    const std::uint16_t n = variant_.beams();
    pc->beams = n;
    pc->count = count;
    pc->readings.resize(count * n);
    pc->truths.resize(count * n);
    pc->ghosts.resize(count);
    pc->ready = std::make_unique<std::atomic<bool>[]>(count);
    SweepCaster caster{world_, ri_};
    Rng rng{seed_ ^ 0x5eedULL, team_.spec(ri_).id, RngStream::range_noise};
    for (std::size_t k = 0; k < count; ++k) {
      const Time end = Time::from_ns(pc->first_end_ns + static_cast<std::int64_t>(k) * pc->period_ns);
      pc->ghosts[k] = caster.cast(end, variant_, clock, rng, &pc->readings[k * n], &pc->truths[k * n]);
      pc->ready[k].store(true, std::memory_order_release);
    }
    pending_precast_ = std::move(pc);
    return thread_cpu_ns() - cpu_start_ns;
  }
  // The table moves `shift_ns` later (the final t0 is the provisional one plus `shift_ns`, a whole number
  // of this scanner's periods, so every sweep keeps its world time) and measure() starts to use it.
  void publish_precast(std::int64_t shift_ns) {
    if (!pending_precast_) return;
    pending_precast_->first_end_ns += shift_ns;
    std::lock_guard<std::mutex> lock{mutex_};
    precast_ = std::move(pending_precast_);
  }

  std::uint64_t ghost_beams() const {
    std::lock_guard<std::mutex> lock{mutex_};
    return ghost_beams_;
  }
  std::vector<LiveScanTruth> take() {
    std::lock_guard<std::mutex> lock{mutex_};
    std::vector<LiveScanTruth> out;
    out.swap(truths_);
    return out;
  }
  std::uint64_t measured() const {
    std::lock_guard<std::mutex> lock{mutex_};
    return measured_;
  }
  std::uint64_t from_precast() const {
    std::lock_guard<std::mutex> lock{mutex_};
    return from_precast_;
  }
  std::int64_t cast_cpu_ns() const {
    std::lock_guard<std::mutex> lock{mutex_};
    return cast_cpu_ns_;
  }

 private:
  struct Precast {
    std::int64_t first_end_ns = 0, period_ns = 1;
    std::uint16_t beams = 0;
    std::size_t count = 0;
    std::vector<lms200::BeamReading> readings;
    std::vector<LiveBeamTruth> truths;
    std::vector<std::uint64_t> ghosts;
    std::unique_ptr<std::atomic<bool>[]> ready;
  };
  // The precast sweep ending at this sweep's end, if the table has it ready (same grid, same variant).
  const Precast* lookup(const lms200::SweepTiming& sweep, std::uint16_t n) {
    const Precast* pc = nullptr;
    {
      std::lock_guard<std::mutex> lock{mutex_};
      pc = precast_.get();
    }
    if (pc == nullptr || pc->beams != n || !(sweep.variant == variant_)) return nullptr;
    // Cast before a robot was held or released: from then on the table shows a world that did not happen.
    if (clock_.at(sweep.sweep_end) >= world_.precast_valid_until_s.load()) return nullptr;
    const std::int64_t d = sweep.sweep_end.ns() - pc->first_end_ns;
    if (d < 0 || d % pc->period_ns != 0) return nullptr;  // before the table, or a new grid (scanner restarted)
    const auto k = static_cast<std::size_t>(d / pc->period_ns);
    if (k >= pc->count || !pc->ready[k].load(std::memory_order_acquire)) return nullptr;
    return pc;
  }

  const TeamWorld& team_;
  const LiveWorld& world_;
  std::size_t ri_;
  std::uint64_t seed_;
  const WorldClock& clock_;
  std::int64_t realtime_offset_ns_;
  Rng rng_;
  SweepCaster caster_;  // the feeder thread's
  std::vector<Hit> standing_hits_;  // the first sweep before world time 0 (robots at their start poses)
  LaserVariant standing_variant_{};
  std::atomic<bool> grid_known_{false};
  std::int64_t grid_first_end_ns_ = 0, grid_period_ns_ = 1;  // written once before grid_known_
  LaserVariant variant_{};
  std::unique_ptr<Precast> precast_;
  std::unique_ptr<Precast> pending_precast_;  // cast, not yet published
  mutable std::mutex mutex_;
  std::vector<LiveScanTruth> truths_;
  std::uint64_t measured_ = 0;
  std::uint64_t ghost_beams_ = 0;
  std::uint64_t from_precast_ = 0;
  std::int64_t cast_cpu_ns_ = 0;
};

}  // namespace

class LiveRobot {
 public:
  LiveRobot(LiveWorld& world, std::size_t ri, std::uint64_t seed, const WorldClock& clock, std::int64_t rt_offset)
      : index{ri}, wheels{world.team, world, ri, seed, clock}, laser{world, ri, seed, clock, rt_offset} {}
  std::size_t index;
  LiveWheels wheels;
  LiveLaser laser;
  std::unique_ptr<arcos::PioneerEmulator> pioneer;
  std::unique_ptr<serial::PtyRunner> arcos_runner;
  std::unique_ptr<lms200::LmsPtyEmulator> lms;
};

struct LiveTeam::Impl {
  explicit Impl(const Scenario& s) : scenario{s}, team{s}, world{team, team.robot_count()} {}
  Scenario scenario;
  TeamWorld team;
  LiveWorld world;
  WorldClock clock;
  std::vector<std::unique_ptr<LiveRobot>> robots;
  bool started = false;
  // The shared feeder (LiveOptions::feed_period > 0): one thread steps every robot's two ptys.
  std::thread feeder;
  std::atomic<bool> feeder_stop{false};
  std::atomic<std::uint64_t> feeder_errors{0};
};

LiveTeam::LiveTeam(const Scenario& scenario, const LiveOptions& options)
    : impl_{std::make_unique<Impl>(scenario)}, options_{options} {}

LiveTeam::~LiveTeam() { stop(); }

Result<std::unique_ptr<LiveTeam>> LiveTeam::create(const Scenario& scenario, const LiveOptions& options) {
  if (!(options.speed > 0.0)) return Error{"live: speed must be positive"};
  std::unique_ptr<LiveTeam> live{new LiveTeam(scenario, options)};
  Impl& im = *live->impl_;
  im.clock.speed = options.speed;
  if (options.loop) im.clock.loop_s = scenario.duration_s.value_or(im.team.finish_s());
  std::error_code ec;
  if (!options.run_dir.empty()) std::filesystem::create_directories(options.run_dir, ec);
  const std::uint64_t seed = options.seed.value_or(scenario.seed);
  const std::int64_t rt_offset = now_realtime().ns() - now_monotonic().ns();
  for (std::size_t ri = 0; ri < im.team.robot_count(); ++ri) {
    const RobotSpec& spec = im.team.spec(ri);
    if (!options.robot_ids.empty() &&
        std::find(options.robot_ids.begin(), options.robot_ids.end(), spec.id) == options.robot_ids.end())
      continue;
    auto r = std::make_unique<LiveRobot>(im.world, ri, seed, im.clock, rt_offset);
    const std::string base = options.run_dir.empty() ? std::string{} : options.run_dir + "/robot" + std::to_string(spec.id);

    arcos::PioneerEmulatorOptions po;
    po.subclass = spec.subclass;
    po.baud = spec.arcos_baud;
    po.sip_period = from_seconds(spec.sip_cycle_s / options.speed);
    po.motors_enabled_at_open = true;
    r->pioneer = std::make_unique<arcos::PioneerEmulator>(po);
    r->pioneer->set_sip_source(&r->wheels);
    serial::PtyRunnerOptions ao;
    ao.link_path = base.empty() ? std::string{} : base + "-arcos";
    auto ar = serial::PtyRunner::create(*r->pioneer, ao);
    if (!ar) return ar.error();
    r->arcos_runner = std::move(ar.value());

    lms200::LmsEmulatorOptions eo;
    serial::PtyRunnerOptions lo;
    lo.link_path = base.empty() ? std::string{} : base + "-lms200";
    auto lr = lms200::LmsPtyEmulator::create(eo, &r->laser, lo);
    if (!lr) return lr.error();
    r->lms = std::move(lr.value());
    im.robots.push_back(std::move(r));
  }
  if (im.robots.empty()) return Error{"live: no robot of the scenario selected"};
  return live;
}

Status LiveTeam::start() {
  Impl& im = *impl_;
  const std::int64_t bring_ns = static_cast<std::int64_t>(options_.bringup_s * 1e9);
  t0_monotonic_ns_ = now_monotonic().ns() + bring_ns;
  t0_realtime_ns_ = now_realtime().ns() + bring_ns;
  im.clock.t0_monotonic_ns = t0_monotonic_ns_;
  if (options_.feed_period <= Duration::zero()) {
    // One thread per pty (serial::PtyRunner::start): each wakes for every byte it releases.
    for (auto& r : im.robots) {
      if (Status s = r->arcos_runner->start(); !s) return s;
      if (Status s = r->lms->start(); !s) return s;
    }
    im.started = true;
    return ok_status();
  }
  // One thread for all 2N ptys, every feed_period: each step releases the bytes that are due (at most a
  // period's worth, ~50 bytes at 500 kBd), as a USB-serial adapter hands over its buffer on its latency
  // timer (FTDI: 1-16 ms). A thread per pty woke for every byte, 2N threads × up to 50 k wake-ups/s:
  // at 32 robots that, not the system under test, saturated the machine (docs/demo.md "Scale").
  const Time power_up = now_monotonic();
  for (auto& r : im.robots) r->lms->with_emulator([&](lms200::LmsEmulator& e) { e.power_up(power_up); });
  im.feeder_stop = false;
  im.feeder = std::thread([&im, period = options_.feed_period] {
    timespec next{};
    ::clock_gettime(CLOCK_MONOTONIC, &next);
    while (!im.feeder_stop.load()) {
      for (auto& r : im.robots) {
        // An I/O fault is counted (the runner's io_errors) and the device carries on, as with its own thread.
        if (!r->arcos_runner->step(Duration::zero())) ++im.feeder_errors;
        if (!r->lms->runner().step(Duration::zero())) ++im.feeder_errors;
      }
      next.tv_nsec += static_cast<long>(period.count());
      while (next.tv_nsec >= 1'000'000'000L) {
        next.tv_nsec -= 1'000'000'000L;
        ++next.tv_sec;
      }
      timespec now{};
      ::clock_gettime(CLOCK_MONOTONIC, &now);
      if (now.tv_sec > next.tv_sec || (now.tv_sec == next.tv_sec && now.tv_nsec > next.tv_nsec)) next = now;  // overran: no catch-up burst
      (void)::clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &next, nullptr);
    }
  });
  im.started = true;
  return ok_status();
}

void LiveTeam::stop() {
  if (!impl_ || !impl_->started) return;
  if (impl_->feeder.joinable()) {
    impl_->feeder_stop = true;
    impl_->feeder.join();
  }
  for (auto& r : impl_->robots) {
    r->lms->stop();
    r->arcos_runner->stop();
  }
  impl_->started = false;
}

std::size_t LiveTeam::robot_count() const { return impl_->robots.size(); }
const RobotSpec& LiveTeam::spec(std::size_t i) const { return impl_->team.spec(impl_->robots[i]->index); }
std::string LiveTeam::arcos_path(std::size_t i) const { return impl_->robots[i]->arcos_runner->host_path(); }
std::string LiveTeam::lms_path(std::size_t i) const { return impl_->robots[i]->lms->host_path(); }
double LiveTeam::world_time_s() const { return impl_->clock.at(now_monotonic()); }
double LiveTeam::world_time_of(std::int64_t realtime_ns) const {
  return static_cast<double>(realtime_ns - t0_realtime_ns_) * 1e-9 * options_.speed;
}
void LiveTeam::unplug_laser(std::size_t i) { impl_->robots[i]->lms->unplug(); }
Status LiveTeam::replug_laser(std::size_t i) { return impl_->robots[i]->lms->replug(); }
std::vector<LiveScanTruth> LiveTeam::take_truth(std::size_t i) { return impl_->robots[i]->laser.take(); }
std::uint64_t LiveTeam::scans_measured(std::size_t i) const { return impl_->robots[i]->laser.measured(); }
std::uint64_t LiveTeam::ghost_beams(std::size_t i) const { return impl_->robots[i]->laser.ghost_beams(); }
LiveTruth LiveTeam::true_motion(std::size_t i, double world_t_s) const {
  const Impl& im = *impl_;
  const std::size_t k = im.robots[i]->index;
  const double t_s = std::max(0.0, world_t_s);
  LiveTruth out;
  out.pose = im.world.pose(k, t_s, im.clock);
  out.held = im.world.holds[k].held_at(t_s);
  if (!out.held) {
    const double track_s = im.clock.scene(im.world.holds[k].track_time(t_s));
    out.v_mps = im.team.motion(k).speed_at(track_s);
    out.w_radps = im.team.motion(k).yaw_rate_at(track_s);
  }
  return out;
}
std::size_t LiveTeam::holds(std::size_t i) const { return impl_->world.holds[impl_->robots[i]->index].holds(); }
std::uint64_t LiveTeam::scans_from_precast() const {
  std::uint64_t n = 0;
  for (const auto& r : impl_->robots) n += r->laser.from_precast();
  return n;
}

Result<PrecastReport> LiveTeam::precast(double world_duration_s, Duration grid_timeout) {
  Impl& im = *impl_;
  if (!im.started) return Error{"live: precast before start()"};
  PrecastReport rep;
  const Time wait_from = now_monotonic();
  // 1. Every scanner streams (its sweep grid is known): during bring-up, robots standing.
  for (;;) {
    bool all = true;
    for (auto& r : im.robots) all = all && r->laser.grid_known();
    if (all) break;
    if (now_monotonic() - wait_from > grid_timeout) return Error{"live: not every scanner streams yet (no sweep grid to precast)"};
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  // 2. Cast every sweep from a provisional world time 0 (t0p, half a second from now) to the end, on up
  // to 2 threads (robots shared out). The robots keep standing meanwhile.
  const std::int64_t old_t0 = im.clock.t0_monotonic_ns.load();
  WorldClock provisional;
  provisional.speed = options_.speed;
  provisional.t0_monotonic_ns = std::max(old_t0, (now_monotonic() + std::chrono::milliseconds(500)).ns());
  const Time from = Time::from_ns(provisional.t0_monotonic_ns.load());
  const Time to = from + from_seconds(world_duration_s / options_.speed + 1.0);
  const unsigned threads = std::max(1u, std::min(2u, std::thread::hardware_concurrency()));
  std::atomic<std::size_t> next{0};
  std::atomic<std::int64_t> cpu_ns{0};
  std::vector<std::thread> workers;
  for (unsigned w = 0; w < threads; ++w) {
    workers.emplace_back([&] {
      for (std::size_t i = next++; i < im.robots.size(); i = next++) cpu_ns += im.robots[i]->laser.precast(from, to, provisional);
    });
  }
  for (std::thread& t : workers) t.join();
  // 3. World time 0 = t0p moved on by whole multiples of 4 revolutions (a multiple of every scanner's
  // period: 1, 2 or 4 revolutions), far enough to be still ahead; every table moves with it, so each
  // precast sweep keeps its world time. Then the tables go live.
  const std::int64_t step_ns = (4 * kLmsRevolution).count();
  const std::int64_t earliest = std::max(old_t0, (now_monotonic() + std::chrono::milliseconds(200)).ns());
  const std::int64_t t0p = provisional.t0_monotonic_ns.load();
  const std::int64_t shift_ns = earliest > t0p ? (earliest - t0p + step_ns - 1) / step_ns * step_ns : 0;
  for (auto& r : im.robots) r->laser.publish_precast(shift_ns);
  const std::int64_t new_t0 = t0p + shift_ns;
  im.clock.t0_monotonic_ns.store(new_t0);
  t0_monotonic_ns_ = new_t0;
  t0_realtime_ns_ += new_t0 - old_t0;
  rep.delayed_s = static_cast<double>(new_t0 - old_t0) * 1e-9;
  rep.cpu_s = static_cast<double>(cpu_ns.load()) * 1e-9;
  rep.wall_s = to_seconds(now_monotonic() - wait_from);
  rep.finished_before_t0 = now_monotonic().ns() < new_t0;
  const double scans = static_cast<double>(im.robots.size()) * (world_duration_s / options_.speed + 1.0) * 75.0;
  rep.scans = static_cast<std::uint64_t>(scans);
  return rep;
}
double LiveTeam::cast_cpu_s() const {
  std::int64_t ns = 0;
  for (const auto& r : impl_->robots) ns += r->laser.cast_cpu_ns();
  return static_cast<double>(ns) * 1e-9;
}

const LiveScanTruth* match_truth(const std::vector<LiveScanTruth>& truths, std::int64_t stamp_ns, std::int64_t tolerance_ns) {
  auto it = std::lower_bound(truths.begin(), truths.end(), stamp_ns,
                             [](const LiveScanTruth& t, std::int64_t s) { return t.sweep_end_realtime_ns < s; });
  const LiveScanTruth* best = nullptr;
  std::int64_t best_d = tolerance_ns + 1;
  for (auto c : {it, it == truths.begin() ? it : std::prev(it)}) {
    if (c == truths.end()) continue;
    const std::int64_t d = std::llabs(c->sweep_end_realtime_ns - stamp_ns);
    if (d < best_d) {
      best_d = d;
      best = &*c;
    }
  }
  return best;
}

}  // namespace teamscan::sim
