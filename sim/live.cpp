// Live device feeding (live.hpp): per robot a PioneerEmulator behind a PtyRunner fed by the wheel model
// (SipSource) and an LmsPtyEmulator fed by the ray caster (RangeSource), both on the runners' clock
// (CLOCK_MONOTONIC) mapped to world time as (now − t0) × speed.
#include "sim/live.hpp"

#include <algorithm>
#include <cmath>
#include <filesystem>

#include "common/clock.hpp"
#include "drivers/arcos/emulator.hpp"
#include "drivers/lms200/emulator_pty.hpp"
#include "drivers/serial/pty_runner.hpp"
#include "sim/devices.hpp"
#include "sim/rng.hpp"
#include "sim/simulator.hpp"

namespace teamscan::sim {

namespace {

// World time of a monotonic instant.
struct WorldClock {
  std::int64_t t0_monotonic_ns = 0;
  double speed = 1.0;
  double loop_s = 0;  // > 0: the scene (tracks) repeats with this period (LiveOptions::loop)
  [[nodiscard]] double at(Time monotonic) const {
    return static_cast<double>(monotonic.ns() - t0_monotonic_ns) * 1e-9 * speed;
  }
  // Where the scene is at world time t_s. Looping keeps world time (and so the wheel model's dt)
  // continuous and only wraps the tracks; a closed track (lap2's ovals) ends where it started.
  [[nodiscard]] double scene(double t_s) const { return loop_s > 0 && t_s > 0 ? std::fmod(t_s, loop_s) : t_s; }
};

// The Pioneer's wheel model behind the SIP hook (as in simulator.cpp's device path): true motion at
// the SIP's world time -> noisy firmware odometry -> XPOS/YPOS/THPOS and wheel velocities. Before
// world time 0 the robot stands at its start pose.
class LiveWheels final : public arcos::SipSource {
 public:
  LiveWheels(const TeamWorld& team, std::size_t ri, std::uint64_t seed, const WorldClock& clock)
      : team_{team},
        ri_{ri},
        clock_{clock},
        firmware_{pioneer_params(team.spec(ri).subclass), team.spec(ri).odometry,
                  Rng{seed, team.spec(ri).id, RngStream::odometry}, team.motion(ri).pose_at(0.0)} {}

  bool fill_sip(Time now, arcos::SipPacket& sip) override {
    const double t_s = std::max(0.0, clock_.at(now));
    const Pose2 truth = team_.motion(ri_).pose_at(clock_.scene(t_s));
    const double dt_s = have_last_ ? std::max(0.0, t_s - last_s_) : 0.0;
    const SipOdometry o = firmware_.step(truth, dt_s);
    last_s_ = t_s;
    have_last_ = true;
    sip.x_raw = o.xpos;
    sip.y_raw = o.ypos;
    sip.th_raw = o.thpos;
    sip.left_vel = o.left_vel_mmps;
    sip.right_vel = o.right_vel_mmps;
    sip.type = (o.left_vel_mmps != 0 || o.right_vel_mmps != 0) ? 0x33 : 0x32;
    if (sip.has(arcos::SipField::kRotVel)) {
      // ROTVEL in 0.1°/s from the wheel difference (PROTOCOLS.md §1.8, DiffConvFactor §1.11).
      const double w = 0.5 * (o.right_vel_mmps - o.left_vel_mmps) * 0.0034;
      sip.rot_vel = static_cast<std::int16_t>(std::lround(rad_to_deg(w) * 10.0));
    }
    return true;
  }

 private:
  const TeamWorld& team_;
  std::size_t ri_;
  const WorldClock& clock_;
  PioneerOdometry firmware_;
  double last_s_ = 0;
  bool have_last_ = false;
};

// The LMS-200's measurement: every beam ray-cast at its own world time (laser_geometry.hpp beam_age),
// the truth of each sent scan recorded with its sweep end in CLOCK_REALTIME.
class LiveLaser final : public lms200::RangeSource {
 public:
  LiveLaser(const TeamWorld& team, std::size_t ri, std::uint64_t seed, const WorldClock& clock, std::int64_t realtime_offset_ns)
      : team_{team}, ri_{ri}, clock_{clock}, realtime_offset_ns_{realtime_offset_ns}, rng_{seed, team.spec(ri).id, RngStream::range_noise} {}

  void measure(const lms200::SweepTiming& sweep, std::span<lms200::BeamReading> beams) override {
    const RobotSpec& spec = team_.spec(ri_);
    const std::uint16_t n = sweep.variant.beams();
    std::uint64_t ghosts = 0;
    LiveScanTruth truth;
    truth.sweep_end_realtime_ns = sweep.sweep_end.ns() + realtime_offset_ns_;
    truth.beams.resize(n);
    for (std::uint16_t i = 0; i < n && i < beams.size(); ++i) {
      const Time beam_time = sweep.sweep_end - sweep.variant.beam_age(i);
      const double t_s = std::max(0.0, clock_.at(beam_time));
      team_.place(clock_.scene(t_s), placed_);
      const double a = sweep.variant.beam_angle_rad(i);
      const Vec3 dir = spec.robot_from_laser.rotation.apply({std::cos(a), std::sin(a), 0.0});
      const Ray ray = team_.beam_ray(ri_, placed_[ri_].map_from_robot, dir);
      const Hit hit = team_.world().cast(ray, placed_, spec.id);
      const std::uint16_t word = lms_value_word(hit.hit, hit.range_m, spec.range_noise_mm, rng_);
      lms200::BeamReading& r = beams[i];
      r = {};
      if (word == kLmsCodeNotValid) r.invalid = lms200::BeamInvalid::not_valid;
      else if (word == kLmsCodeTooFar) r.invalid = lms200::BeamInvalid::over_range;
      else r.range_mm = word;
      LiveBeamTruth& b = truth.beams[i];
      b.tx = static_cast<float>(hit.point_m.x);
      b.ty = static_cast<float>(hit.point_m.y);
      b.tz = static_cast<float>(hit.point_m.z);
      b.label = hit.label;
      b.hit_robot = hit.hit_robot;
      if (hit.label == PointClass::robot) ++ghosts;
    }
    std::lock_guard<std::mutex> lock{mutex_};
    truths_.push_back(std::move(truth));
    ++measured_;
    ghost_beams_ += ghosts;
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

 private:
  const TeamWorld& team_;
  std::size_t ri_;
  const WorldClock& clock_;
  std::int64_t realtime_offset_ns_;
  Rng rng_;
  std::vector<PlacedRobot> placed_;
  mutable std::mutex mutex_;
  std::vector<LiveScanTruth> truths_;
  std::uint64_t measured_ = 0;
  std::uint64_t ghost_beams_ = 0;
};

}  // namespace

class LiveRobot {
 public:
  LiveRobot(const TeamWorld& team, std::size_t ri, std::uint64_t seed, const WorldClock& clock, std::int64_t rt_offset)
      : index{ri}, wheels{team, ri, seed, clock}, laser{team, ri, seed, clock, rt_offset} {}
  std::size_t index;
  LiveWheels wheels;
  LiveLaser laser;
  std::unique_ptr<arcos::PioneerEmulator> pioneer;
  std::unique_ptr<serial::PtyRunner> arcos_runner;
  std::unique_ptr<lms200::LmsPtyEmulator> lms;
};

struct LiveTeam::Impl {
  explicit Impl(const Scenario& s) : scenario{s}, team{s} {}
  Scenario scenario;
  TeamWorld team;
  WorldClock clock;
  std::vector<std::unique_ptr<LiveRobot>> robots;
  bool started = false;
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
    auto r = std::make_unique<LiveRobot>(im.team, ri, seed, im.clock, rt_offset);
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
  for (auto& r : im.robots) {
    if (Status s = r->arcos_runner->start(); !s) return s;
    if (Status s = r->lms->start(); !s) return s;
  }
  im.started = true;
  return ok_status();
}

void LiveTeam::stop() {
  if (!impl_ || !impl_->started) return;
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
