// The team-survey simulator (simulator.hpp).
#include "sim/simulator.hpp"

#include <algorithm>
#include <cmath>

namespace teamscan::sim {
namespace {

Track build_track(const TrackSpec& t) {
  switch (t.kind) {
    case Track::Kind::oval: return Track::oval(t.center_m, t.semi_x_m, t.semi_y_m, t.yaw_rad, t.ccw);
    case Track::Kind::figure8: return Track::figure8(t.center_m, t.half_length_m, t.width_m, t.yaw_rad, t.ccw);
    case Track::Kind::waypoints: return Track::waypoints(t.waypoints_m, t.closed);
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
    motions_.emplace_back(std::move(track), r.speed_mps, offset, distance, r.start_s, r.pauses);
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

Pose2 OdometryHistory::at(std::int64_t stamp_ns) const {
  if (samples_.empty()) return {};
  if (stamp_ns <= samples_.front().stamp_ns) return samples_.front().pose;
  if (stamp_ns >= samples_.back().stamp_ns) return samples_.back().pose;
  const auto it = std::upper_bound(samples_.begin(), samples_.end(), stamp_ns,
                                   [](std::int64_t t, const Sample& s) { return t < s.stamp_ns; });
  const Sample& b = *it;
  const Sample& a = *(it - 1);
  const double s = static_cast<double>(stamp_ns - a.stamp_ns) / static_cast<double>(b.stamp_ns - a.stamp_ns);
  return interpolate(a.pose, b.pose, s);
}

Vec3 beam_point_in_map(const Pose2& map_from_odom, const Pose2& odom_pose, const Pose3& robot_from_laser, double angle_rad,
                       std::uint16_t range_mm) {
  const Pose3 laser = map_from_laser(map_from_odom * odom_pose, robot_from_laser);
  return laser.apply(beam_in_laser(angle_rad, static_cast<double>(range_mm) * 1e-3));
}

SimOutput simulate(const Scenario& scenario, const SimOptions& options) {
  const TeamWorld team{scenario};
  const std::uint64_t seed = options.seed.value_or(scenario.seed);
  const double duration_s = options.duration_s.value_or(scenario.duration_s.value_or(team.finish_s()));
  const std::int64_t duration_ns = seconds_to_ns(duration_s);
  const std::int64_t t0_ns = scenario.start_time_ns;

  SimOutput out;
  Dataset& ds = out.dataset;
  ds.scenario = scenario.name;
  ds.seed = seed;
  ds.duration_s = duration_s;
  ds.room_m[0] = scenario.room_m.x;
  ds.room_m[1] = scenario.room_m.y;
  ds.room_m[2] = scenario.room_m.z;

  // Total work for progress: beams over all robots.
  double total_beams = 0;
  for (const RobotSpec& r : scenario.robots)
    total_beams += static_cast<double>(r.variant.beams()) * duration_s / to_seconds(lms_scan_period(r.variant, r.lms_baud));
  double done_beams = 0, last_report = -1;

  std::vector<PlacedRobot> placed;
  ds.points.reserve(static_cast<std::size_t>(total_beams));
  for (std::size_t ri = 0; ri < team.robot_count(); ++ri) {
    const RobotSpec& spec = team.spec(ri);
    const Motion& motion = team.motion(ri);
    const Pose2 registration = motion.pose_at(0.0);  // map_from_odom: odometry starts at 0 where the robot starts

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
    dr.registration = registration;
    dr.footprint_m[0] = team.body(ri).length_m;
    dr.footprint_m[1] = team.body(ri).width_m;
    dr.height_m = team.body(ri).height_m;
    ds.robots.push_back(dr);

    // --- Odometry: one SIP per cycle from t = 0 until past the last beam (§1.7: 100 ms). ---
    const PioneerParams params = pioneer_params(spec.subclass);
    PioneerOdometry firmware{params, spec.odometry, Rng{seed, spec.id, RngStream::odometry}, registration};
    OdometryDecoder client{params};
    OdometryHistory history;
    const std::int64_t sip_ns = seconds_to_ns(spec.sip_cycle_s);
    for (std::int64_t t_ns = 0;; t_ns += sip_ns) {
      const double t_s = ns_to_seconds(t_ns);
      const Pose2 truth = motion.pose_at(t_s);
      const SipOdometry sip = firmware.step(truth, t_ns == 0 ? 0.0 : spec.sip_cycle_s);
      const Pose2 odom = client.decode(sip);
      history.push(t_ns, odom);
      ds.truth.push_back({spec.id, t0_ns + t_ns, truth, motion.speed_at(t_s), motion.yaw_rate_at(t_s)});
      ds.odom.push_back({spec.id, t0_ns + t_ns, registration * odom, client.forward_velocity_mps(sip), client.yaw_rate_radps(sip)});
      if (t_ns > duration_ns) break;
    }

    // --- Scans: every beam cast at its own time (laser_geometry.hpp beam_age). ---
    RobotStats stats;
    stats.id = spec.id;
    Rng range_rng{seed, spec.id, RngStream::range_noise};
    const LaserVariant variant = spec.variant;
    const std::uint16_t beams = variant.beams();
    std::vector<Vec3> beam_dirs(beams);  // beam directions in the robot frame, for the ray cast
    for (std::uint16_t i = 0; i < beams; ++i) {
      const double a = variant.beam_angle_rad(i);
      beam_dirs[i] = spec.robot_from_laser.rotation.apply({std::cos(a), std::sin(a), 0.0});
    }
    const std::int64_t period_ns = lms_scan_period(variant, spec.lms_baud).count();
    std::int64_t stamp_ns = seconds_to_ns(spec.scan_phase_s) + variant.sweep_duration().count();
    for (std::uint32_t scan = 0; stamp_ns <= duration_ns; ++scan, stamp_ns += period_ns) {
      ScanRecord rec;
      rec.robot = spec.id;
      rec.scan = scan;
      rec.stamp_ns = t0_ns + stamp_ns;
      rec.beams = beams;
      const Pose2 odom_at_stamp = history.at(stamp_ns);
      rec.pose = registration * odom_at_stamp;
      rec.origin = map_from_laser(rec.pose, spec.robot_from_laser).translation;
      rec.true_pose = motion.pose_at(ns_to_seconds(stamp_ns));
      for (std::uint16_t i = 0; i < beams; ++i) {
        const std::int64_t beam_ns = stamp_ns - variant.beam_age(i).count();
        const double beam_s = ns_to_seconds(beam_ns);
        team.place(beam_s, placed);
        const double angle = variant.beam_angle_rad(i);
        const Ray ray = team.beam_ray(ri, placed[ri].map_from_robot, beam_dirs[i]);
        const Hit hit = team.world().cast(ray, placed, spec.id);
        const std::uint16_t word = lms_value_word(hit.hit, hit.range_m, spec.range_noise_mm, range_rng);
        // --- Client side from here: only the value word and the decoded odometry. ---
        const DecodedRange range = decode_lms_value(word);
        ++stats.beams;
        if (!range.valid) {
          ++stats.invalid;
          continue;
        }
        const Vec3 p = beam_point_in_map(registration, history.at(beam_ns), spec.robot_from_laser, angle, range.range_mm);
        LabelledPoint lp;
        lp.x = static_cast<float>(p.x);
        lp.y = static_cast<float>(p.y);
        lp.z = static_cast<float>(p.z);
        lp.robot = spec.id;
        lp.scan = scan;
        lp.beam = i;
        lp.label = hit.label;
        lp.hit_robot = hit.hit_robot;
        lp.flags = range.flags;
        lp.tx = static_cast<float>(hit.point_m.x);
        lp.ty = static_cast<float>(hit.point_m.y);
        lp.tz = static_cast<float>(hit.point_m.z);
        ds.points.push_back(lp);
        ++rec.points;
        ++stats.points;
        if (lp.is_ghost()) {
          ++stats.ghosts;
          ++stats.ghosts_by_robot[std::min<std::size_t>(hit.hit_robot, kMaxRobots)];
        }
      }
      ++stats.scans;
      ds.scans.push_back(rec);
      done_beams += beams;
      if (options.progress && total_beams > 0 && done_beams / total_beams - last_report >= 0.01) {
        last_report = done_beams / total_beams;
        options.progress(std::min(1.0, last_report));
      }
    }
    out.stats.push_back(stats);
  }
  if (options.progress) options.progress(1.0);
  return out;
}

}  // namespace teamscan::sim
