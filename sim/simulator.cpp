// The team-survey simulator (simulator.hpp).
#include "sim/simulator.hpp"

#include <algorithm>
#include <cmath>
#include <deque>
#include <optional>

#include "drivers/arcos/client.hpp"
#include "drivers/arcos/emulator.hpp"
#include "drivers/lms200/client.hpp"
#include "drivers/lms200/emulator.hpp"
#include "drivers/serial/virtual_link.hpp"
#include "sim/receiver.hpp"
#include "sim/replay.hpp"

namespace teamscan::sim {
namespace {

Track build_track(const TrackSpec& t) {
  switch (t.kind) {
    case Track::Kind::oval: return Track::oval(t.center_m, t.semi_x_m, t.semi_y_m, t.yaw_rad, t.ccw);
    case Track::Kind::figure8: return Track::figure8(t.center_m, t.half_length_m, t.width_m, t.yaw_rad, t.ccw);
    case Track::Kind::waypoints: return Track::waypoints(t.waypoints_m, t.closed, t.spline);
  }
  return Track::oval(t.center_m, t.semi_x_m, t.semi_y_m, t.yaw_rad, t.ccw);
}

std::int64_t seconds_to_ns(double s) { return static_cast<std::int64_t>(std::llround(s * 1e9)); }
double ns_to_seconds(std::int64_t ns) { return static_cast<double>(ns) * 1e-9; }

}  // namespace

std::size_t lms_b0_telegram_bytes(std::uint16_t values) {
  // STX, address, length (2), reply code, count word (2), values, status, CRC (2): §2.2, §2.7.
  return 10u + 2u * values;
}

Duration lms_scan_period(const LaserVariant& variant, std::uint32_t baud) {
  const Duration sweep = kLmsRevolution * variant.revolutions();
  const Duration tx = serial_transmission_time(static_cast<std::int64_t>(lms_b0_telegram_bytes(variant.beams())), baud);
  const std::int64_t sweeps = std::max<std::int64_t>(1, (tx.count() + sweep.count() - 1) / sweep.count());
  return sweep * sweeps;
}

TeamWorld::TeamWorld(const Scenario& scenario) : world_{Room{scenario.room_m}}, specs_{scenario.robots} {
  for (const FurnitureSpec& f : scenario.furniture) {
    if (f.kind == FurnitureSpec::Kind::table) world_.add_table(f.center_m, f.yaw_rad, f.size_m, f.top_thickness_m, f.leg_m);
    else world_.add_box(f.center_m, f.yaw_rad, f.size_m);
  }
  for (const RobotSpec& r : specs_) {
    bodies_.push_back(make_pioneer3at_body(r.robot_from_laser));
    Track track = build_track(r.track);
    const double length = track.length_m();
    const double offset = r.start_phase ? *r.start_phase * length : r.start_offset_m;
    const double distance = track.closed() ? r.laps * length : length;
    motions_.emplace_back(std::move(track), r.speed_mps, offset, distance, r.start_s, r.pauses, r.accel_mps2,
                          deg_to_rad(r.max_turn_rate_deg_s));
  }
}

double TeamWorld::finish_s() const {
  double finish = 0;
  for (const Motion& m : motions_) finish = std::max(finish, m.finish_s());
  return finish;
}

void TeamWorld::place(double t_s, std::vector<PlacedRobot>& out) const {
  out.resize(motions_.size());
  for (std::size_t i = 0; i < motions_.size(); ++i) out[i] = {specs_[i].id, motions_[i].pose_at(t_s), &bodies_[i]};
}

Ray TeamWorld::beam_ray(std::size_t index, const Pose2& map_from_robot, double angle_rad) const {
  return beam_ray(index, map_from_robot,
                  specs_[index].robot_from_laser.rotation.apply({std::cos(angle_rad), std::sin(angle_rad), 0.0}));
}

Ray TeamWorld::beam_ray(std::size_t index, const Pose2& map_from_robot, const Vec3& direction_in_robot) const {
  // The truth path: map_from_laser written out for a planar pose (2 instead of 6 trig calls per beam).
  const Pose3& mount = specs_[index].robot_from_laser;
  const double c = std::cos(map_from_robot.theta_rad), s = std::sin(map_from_robot.theta_rad);
  auto yaw = [&](Vec3 v) { return Vec3{c * v.x - s * v.y, s * v.x + c * v.y, v.z}; };
  return {yaw(mount.translation) + Vec3{map_from_robot.x_m, map_from_robot.y_m, 0.0}, yaw(direction_in_robot)};
}

Pose2 PoseHistory::at(std::int64_t stamp_ns) const {
  if (samples_.empty()) return {};
  const Time t = Time::from_ns(stamp_ns);
  if (t <= samples_.front().stamp) return samples_.front().pose;
  if (t >= samples_.back().stamp) return samples_.back().pose;
  const auto it = std::upper_bound(samples_.begin(), samples_.end(), t, [](Time when, const OdometrySample& s) { return when < s.stamp; });
  const auto b = static_cast<std::size_t>(it - samples_.begin());  // the first sample after t (b >= 1)
  return pose_between(b >= 2 ? &samples_[b - 2] : nullptr, samples_[b - 1], samples_[b], t);
}

Vec3 beam_point_in_map(const Pose2& map_from_odom, const Pose2& odom_pose, const Pose3& robot_from_laser, double angle_rad,
                       std::uint16_t range_mm) {
  const Pose3 laser = map_from_laser(map_from_odom * odom_pose, robot_from_laser);
  return laser.apply(beam_in_laser(angle_rad, static_cast<double>(range_mm) * 1e-3));
}

namespace {

// What every robot's run shares: the world, the clock, the output, the progress.
struct Run {
  const TeamWorld& team;
  std::uint64_t seed;
  double duration_s;
  std::int64_t duration_ns;
  std::int64_t t0_ns;  // CLOCK_REALTIME of t = 0
  Dataset& ds;
  const SimOptions& options;
  double total_beams = 0, done_beams = 0, last_report = -1;

  void progressed(double beams) {
    done_beams += beams;
    if (options.progress && total_beams > 0 && done_beams / total_beams - last_report >= 0.01) {
      last_report = done_beams / total_beams;
      options.progress(std::min(1.0, last_report));
    }
  }
};

// The ray cast of one beam at its own time, and the value word the scanner sends for it.
struct BeamTruth {
  Hit hit;
  std::uint16_t word = 0;
};

BeamTruth measure_beam(const Run& run, std::size_t ri, std::int64_t beam_ns, const Vec3& dir_in_robot, Rng& rng,
                       std::vector<PlacedRobot>& placed) {
  run.team.place(ns_to_seconds(beam_ns), placed);
  const Ray ray = run.team.beam_ray(ri, placed[ri].map_from_robot, dir_in_robot);
  BeamTruth b;
  b.hit = run.team.world().cast(ray, placed, run.team.spec(ri).id);
  b.word = lms_value_word(b.hit.hit, b.hit.range_m, run.team.spec(ri).range_noise_mm, rng);
  return b;
}

std::vector<Vec3> beam_directions(const RobotSpec& spec) {
  std::vector<Vec3> dirs(spec.variant.beams());
  for (std::uint16_t i = 0; i < dirs.size(); ++i) {
    const double a = spec.variant.beam_angle_rad(i);
    dirs[i] = spec.robot_from_laser.rotation.apply({std::cos(a), std::sin(a), 0.0});
  }
  return dirs;
}

LabelledPoint labelled(const RobotSpec& spec, std::uint32_t scan, std::uint16_t beam, const Vec3& p, const Hit& hit,
                       std::uint16_t flags) {
  LabelledPoint lp;
  lp.x = static_cast<float>(p.x);
  lp.y = static_cast<float>(p.y);
  lp.z = static_cast<float>(p.z);
  lp.robot = spec.id;
  lp.scan = scan;
  lp.beam = beam;
  lp.label = hit.label;
  lp.hit_robot = hit.hit_robot;
  lp.flags = flags;
  lp.tx = static_cast<float>(hit.point_m.x);
  lp.ty = static_cast<float>(hit.point_m.y);
  lp.tz = static_cast<float>(hit.point_m.z);
  return lp;
}

void count_point(RobotStats& stats, const LabelledPoint& lp) {
  ++stats.points;
  if (lp.is_ghost()) {
    ++stats.ghosts;
    ++stats.ghosts_by_robot[std::min<std::size_t>(lp.hit_robot, kMaxRobots)];
  }
}

// ---- Direct path: device fields decoded in process, no bytes. ----
RobotStats run_direct(Run& run, std::size_t ri) {
  const RobotSpec& spec = run.team.spec(ri);
  const Motion& motion = run.team.motion(ri);
  const Pose2 registration = motion.pose_at(0.0);
  Dataset& ds = run.ds;

  // Odometry: one SIP per cycle from t = 0 until past the last beam (§1.7: 100 ms).
  const PioneerParams params = pioneer_params(spec.subclass);
  PioneerOdometry firmware{params, spec.odometry, Rng{run.seed, spec.id, RngStream::odometry}, registration};
  OdometryDecoder client{params};
  PoseHistory history;
  const std::int64_t sip_ns = seconds_to_ns(spec.sip_cycle_s);
  for (std::int64_t t_ns = 0;; t_ns += sip_ns) {
    const double t_s = ns_to_seconds(t_ns);
    const Pose2 truth = motion.pose_at(t_s);
    const SipOdometry sip = firmware.step(truth, t_ns == 0 ? 0.0 : spec.sip_cycle_s);
    const Pose2 odom = client.decode(sip);
    history.push(t_ns, odom);
    ds.truth.push_back({spec.id, run.t0_ns + t_ns, truth, motion.speed_at(t_s), motion.yaw_rate_at(t_s)});
    ds.odom.push_back({spec.id, run.t0_ns + t_ns, registration * odom, client.forward_velocity_mps(sip), client.yaw_rate_radps(sip)});
    if (t_ns > run.duration_ns) break;
  }
  if (!run.options.scans) return {.id = spec.id};

  // Scans: every beam cast at its own time (laser_geometry.hpp beam_age).
  RobotStats stats;
  stats.id = spec.id;
  Rng range_rng{run.seed, spec.id, RngStream::range_noise};
  const LaserVariant variant = spec.variant;
  const std::uint16_t beams = variant.beams();
  const std::vector<Vec3> dirs = beam_directions(spec);
  std::vector<PlacedRobot> placed;
  const std::int64_t period_ns = lms_scan_period(variant, spec.lms_baud).count();
  std::int64_t stamp_ns = seconds_to_ns(spec.scan_phase_s) + variant.sweep_duration().count();
  for (std::uint32_t scan = 0; stamp_ns <= run.duration_ns; ++scan, stamp_ns += period_ns) {
    ScanRecord rec;
    rec.robot = spec.id;
    rec.scan = scan;
    rec.stamp_ns = run.t0_ns + stamp_ns;
    rec.beams = beams;
    rec.pose = registration * history.at(stamp_ns);
    rec.origin = map_from_laser(rec.pose, spec.robot_from_laser).translation;
    rec.true_pose = motion.pose_at(ns_to_seconds(stamp_ns));
    for (std::uint16_t i = 0; i < beams; ++i) {
      const std::int64_t beam_ns = stamp_ns - variant.beam_age(i).count();
      const BeamTruth truth = measure_beam(run, ri, beam_ns, dirs[i], range_rng, placed);
      // Client side from here: only the value word and the decoded odometry.
      const DecodedRange range = decode_lms_value(truth.word);
      ++stats.beams;
      if (!range.valid) {
        ++stats.invalid;
        continue;
      }
      const Vec3 p = beam_point_in_map(registration, history.at(beam_ns), spec.robot_from_laser, variant.beam_angle_rad(i),
                                       range.range_mm);
      ds.points.push_back(labelled(spec, scan, i, p, truth.hit, range.flags));
      ++rec.points;
      count_point(stats, ds.points.back());
    }
    ++stats.scans;
    ds.scans.push_back(rec);
    run.progressed(beams);
  }
  return stats;
}

// ---- Device streams: emulators, clients, VirtualLinks, captures. ----

// The Pioneer's wheel model behind the emulator's SIP hook: true motion -> noisy firmware odometry ->
// XPOS/YPOS/THPOS and wheel velocities (devices.hpp). Also records the true pose at each SIP.
class WheelModel final : public arcos::SipSource {
 public:
  WheelModel(const Run& run, std::size_t ri, const Pose2& start)
      : run_{run},
        ri_{ri},
        firmware_{pioneer_params(run.team.spec(ri).subclass), run.team.spec(ri).odometry,
                  Rng{run.seed, run.team.spec(ri).id, RngStream::odometry}, start} {}

  bool fill_sip(Time now, arcos::SipPacket& sip) override {
    const double t_s = ns_to_seconds(now.ns() - run_.t0_ns);
    const Motion& motion = run_.team.motion(ri_);
    const Pose2 truth = motion.pose_at(t_s);
    const double dt_s = have_last_ ? to_seconds(now - last_) : 0.0;
    const SipOdometry o = firmware_.step(truth, dt_s);
    last_ = now;
    have_last_ = true;
    fill_sip_odometry(o, sip);
    if (now.ns() >= run_.t0_ns)  // the data set covers t >= 0; before that the robot stands at its start
      run_.ds.truth.push_back({run_.team.spec(ri_).id, now.ns(), truth, motion.speed_at(t_s), motion.yaw_rate_at(t_s)});
    return true;
  }

 private:
  const Run& run_;
  std::size_t ri_;
  PioneerOdometry firmware_;
  Time last_;
  bool have_last_ = false;
};

// The LMS-200's measurement behind the emulator's range hook: every beam ray-cast at its own time;
// the truth of each sent scan is queued until the client delivers that scan.
class LaserModel final : public lms200::RangeSource {
 public:
  struct ScanTruth {
    Time sweep_end;
    std::vector<Hit> hits;
  };

  LaserModel(const Run& run, std::size_t ri)
      : run_{run}, ri_{ri}, rng_{run.seed, run.team.spec(ri).id, RngStream::range_noise}, dirs_{beam_directions(run.team.spec(ri))} {}

  void measure(const lms200::SweepTiming& sweep, std::span<lms200::BeamReading> beams) override {
    ScanTruth truth;
    truth.sweep_end = sweep.sweep_end;
    const std::uint16_t n = sweep.variant.beams();
    truth.hits.resize(n);
    const bool configured = sweep.variant == run_.team.spec(ri_).variant;
    for (std::uint16_t i = 0; i < n && i < beams.size(); ++i) {
      const std::int64_t beam_ns = sweep.sweep_end.ns() - sweep.variant.beam_age(i).count() - run_.t0_ns;
      Vec3 dir = configured ? dirs_[i] : Vec3{};
      if (!configured) {  // a scan before the variant was set: compute the direction on the fly
        const double a = sweep.variant.beam_angle_rad(i);
        dir = run_.team.spec(ri_).robot_from_laser.rotation.apply({std::cos(a), std::sin(a), 0.0});
      }
      const BeamTruth b = measure_beam(run_, ri_, beam_ns, dir, rng_, placed_);
      truth.hits[i] = b.hit;
      lms200::BeamReading& r = beams[i];
      r = {};
      if (b.word == kLmsCodeNotValid) r.invalid = lms200::BeamInvalid::not_valid;
      else if (b.word == kLmsCodeTooFar) r.invalid = lms200::BeamInvalid::over_range;
      else r.range_mm = b.word;
    }
    queue_.push_back(std::move(truth));
  }

  // The truth of the scan whose estimated sweep end is `stamp`: the latest measured scan that ended
  // no later than that (older ones were superseded or dropped on the way). The estimate is the
  // arrival truncated to µs minus the line time, so it may fall a microsecond before the true end;
  // scans are at least 13.3 ms apart, so a 2 ms allowance cannot pick the next one.
  [[nodiscard]] std::optional<ScanTruth> take(Time stamp) {
    std::optional<ScanTruth> found;
    while (!queue_.empty() && queue_.front().sweep_end <= stamp + 2ms) {
      found = std::move(queue_.front());
      queue_.pop_front();
    }
    return found;
  }

 private:
  const Run& run_;
  std::size_t ri_;
  Rng rng_;
  std::vector<Vec3> dirs_;
  std::vector<PlacedRobot> placed_;
  std::deque<ScanTruth> queue_;
};

RobotStats run_devices(Run& run, std::size_t ri, RobotCaptures& captures) {
  const RobotSpec& spec = run.team.spec(ri);
  const Motion& motion = run.team.motion(ri);
  const Pose2 registration = motion.pose_at(0.0);  // map_from_odom: odometry starts at 0 where the robot starts
  Dataset& ds = run.ds;
  RobotStats stats;
  stats.id = spec.id;

  // Links start on a whole microsecond so capture times (µs) and live times agree (receiver.hpp).
  const std::int64_t bringup_ns = seconds_to_ns(run.options.bringup_s) / 1000 * 1000;
  const Time link_start = Time::from_ns(run.t0_ns - bringup_ns);
  const Time end = Time::from_ns(run.t0_ns + run.duration_ns);
  captures.id = spec.id;
  captures.start_ns = link_start.ns();

  WheelModel wheels{run, ri, registration};
  arcos::PioneerEmulatorOptions po;
  po.subclass = spec.subclass;
  po.baud = spec.arcos_baud;
  po.sip_period = from_seconds(spec.sip_cycle_s);
  arcos::PioneerEmulator pioneer{po};
  pioneer.set_sip_source(&wheels);
  arcos::ArcosClient arcos_client{arcos_client_options(spec)};

  LaserModel laser{run, ri};
  lms200::LmsEmulatorOptions eo;
  lms200::LmsEmulator lms{eo, &laser};
  lms200::LmsClient lms_client{lms_client_options(spec)};

  RobotReceiver receiver{
      spec.robot_from_laser, registration, spec.arcos_baud,
      [&](const ReceivedScan& rs) {
        const ScanPoints& pts = *rs.points;
        const std::optional<LaserModel::ScanTruth> truth = laser.take(pts.stamp);
        // The data set covers t >= 0: scans of the bring-up, while the robot stands, are in the captures only.
        if (pts.stamp.ns() < run.t0_ns) return;
        ScanRecord rec;
        rec.robot = spec.id;
        rec.scan = static_cast<std::uint32_t>(stats.scans);
        rec.stamp_ns = pts.stamp.ns();
        rec.beams = pts.count;
        rec.pose = pts.map_from_robot;
        rec.origin = {pts.origin_x_mm * 1e-3, pts.origin_y_mm * 1e-3, pts.origin_z_mm * 1e-3};
        rec.true_pose = motion.pose_at(ns_to_seconds(pts.stamp.ns() - run.t0_ns));
        for (std::uint16_t i = 0; i < pts.count; ++i) {
          const ScanPoint& sp = pts.points[i];
          ++stats.beams;
          if (sp.flags & kPointUnplaced) {
            ++stats.invalid;
            continue;
          }
          const Hit hit = truth && i < truth->hits.size() ? truth->hits[i] : Hit{};
          const Vec3 p{sp.x_mm * 1e-3, sp.y_mm * 1e-3, sp.z_mm * 1e-3};
          ds.points.push_back(labelled(spec, rec.scan, sp.beam, p, hit, dataset_flags_from_wire(sp.flags)));
          ++rec.points;
          count_point(stats, ds.points.back());
        }
        ++stats.scans;
        ds.scans.push_back(rec);
        run.progressed(pts.count);
      },
      [&](const ReceivedSip& sip) {
        if (sip.stamp.ns() < run.t0_ns) return;
        ds.odom.push_back({spec.id, sip.stamp.ns(), registration * sip.odom_pose, sip.v_mps, sip.w_radps});
      }};
  receiver.attach(arcos_client, lms_client);

  serial::VirtualLinkOptions arcos_link_options;
  arcos_link_options.device = DeviceKind::arcos;
  arcos_link_options.start = link_start;
  serial::VirtualLink arcos_link{arcos_client, pioneer, arcos_link_options};
  serial::VirtualLinkOptions lms_link_options;
  lms_link_options.device = DeviceKind::lms200;
  lms_link_options.start = link_start;
  serial::VirtualLink lms_link{lms_client, lms, lms_link_options};

  lms.power_up(link_start);
  lms_client.start(link_start);
  // Both links advance together in small steps: a scan is projected once a SIP after its stamp is in.
  constexpr Duration kStep = 20ms;
  const Time t0 = Time::from_ns(run.t0_ns);
  bool checked_bringup = false;
  for (Time t = link_start; t < end;) {
    t = std::min(t + kStep, end);
    arcos_link.run_until(t);
    lms_link.run_until(t);
    if (!checked_bringup && t >= t0) {
      captures.arcos_connected = arcos_client.connected();
      captures.lms_streaming = lms_client.streaming();
      checked_bringup = true;
    }
  }
  // One more SIP cycle so that the last scans are interpolated, not extrapolated.
  arcos_link.run_until(end + from_seconds(spec.sip_cycle_s) + 50ms);
  receiver.flush();
  captures.arcos = arcos_link.take_capture();
  captures.lms200 = lms_link.take_capture();
  return stats;
}

}  // namespace

SimOutput simulate(const Scenario& scenario, const SimOptions& options) {
  const TeamWorld team{scenario};
  SimOutput out;
  Dataset& ds = out.dataset;
  const std::uint64_t seed = options.seed.value_or(scenario.seed);
  const double duration_s = options.duration_s.value_or(scenario.duration_s.value_or(team.finish_s()));
  Run run{team, seed, duration_s, seconds_to_ns(duration_s), scenario.start_time_ns, ds, options};
  ds.scenario = scenario.name;
  ds.seed = seed;
  ds.duration_s = duration_s;
  ds.room_m[0] = scenario.room_m.x;
  ds.room_m[1] = scenario.room_m.y;
  ds.room_m[2] = scenario.room_m.z;

  for (const RobotSpec& r : scenario.robots)
    run.total_beams += static_cast<double>(r.variant.beams()) * duration_s / to_seconds(lms_scan_period(r.variant, r.lms_baud));
  ds.points.reserve(static_cast<std::size_t>(run.total_beams));

  for (std::size_t ri = 0; ri < team.robot_count(); ++ri) {
    const RobotSpec& spec = team.spec(ri);
    DatasetRobot dr;
    dr.id = spec.id;
    dr.name = spec.name;
    dr.role = spec.role;
    dr.subclass = spec.subclass;
    for (int k = 0; k < 3; ++k) {
      dr.mount_xyz_m[k] = spec.mount_xyz_m[k];
      dr.mount_rpy_rad[k] = spec.mount_rpy_rad[k];
    }
    dr.fov_deg = spec.variant.fov_deg;
    dr.resolution_cdeg = spec.variant.resolution_cdeg;
    dr.lms_baud = spec.lms_baud;
    dr.registration = team.motion(ri).pose_at(0.0);
    dr.footprint_m[0] = team.body(ri).length_m;
    dr.footprint_m[1] = team.body(ri).width_m;
    dr.height_m = team.body(ri).height_m;
    ds.robots.push_back(dr);

    if (options.device_streams) {
      out.captures.emplace_back();
      out.stats.push_back(run_devices(run, ri, out.captures.back()));
    } else {
      out.stats.push_back(run_direct(run, ri));
    }
  }
  if (options.progress) options.progress(1.0);
  return out;
}

}  // namespace teamscan::sim
