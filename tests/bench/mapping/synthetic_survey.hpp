// A small, self-contained lap2-like survey for benchmarks and tests until `teamscan sim` data sets
// exist: robots drive an oval in a hollow box room (optionally with a table), each with a tilted
// 181-beam laser ray-cast against the room, the table and the teammates' bodies (labelled ghosts).
// Not the simulator: no device timing, no odometry drift; only geometry with labels.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <optional>
#include <random>
#include <string>

#include "common/dataset/dataset.hpp"
#include "common/laser_geometry.hpp"

namespace teamscan::bench {

struct SurveyOptions {
  double room_m = 10.0;       // square room side
  double height_m = 2.5;
  int robots = 2;
  double duration_s = 30.0;
  double scan_hz = 10.0;
  double speed_mps = 0.4;
  bool table = true;
  double range_noise_m = 0.005;
  std::uint64_t seed = 1;
};

namespace detail {
// Slab test for an axis-aligned box [lo, hi]: entry and exit distances along the ray.
inline bool ray_box(const Vec3& o, const Vec3& d, const Vec3& lo, const Vec3& hi, double& t_in, double& t_out) {
  t_in = -std::numeric_limits<double>::infinity();
  t_out = std::numeric_limits<double>::infinity();
  const double oo[3] = {o.x, o.y, o.z}, dd[3] = {d.x, d.y, d.z}, l[3] = {lo.x, lo.y, lo.z}, h[3] = {hi.x, hi.y, hi.z};
  for (int a = 0; a < 3; ++a) {
    if (std::abs(dd[a]) < 1e-12) {
      if (oo[a] < l[a] || oo[a] > h[a]) return false;
      continue;
    }
    double t0 = (l[a] - oo[a]) / dd[a], t1 = (h[a] - oo[a]) / dd[a];
    if (t0 > t1) std::swap(t0, t1);
    t_in = std::max(t_in, t0);
    t_out = std::min(t_out, t1);
  }
  return t_in <= t_out;
}
}  // namespace detail

// Pose of robot k at time t on the oval (centre of the room, semi-axes 0.3 L and 0.2 L), robots
// spread evenly along it (two robots: half an oval apart, like the paper's Lap2).
inline Pose2 oval_pose(const SurveyOptions& o, int k, double t_s, double* v_mps = nullptr, double* w_radps = nullptr) {
  const double a = 0.3 * o.room_m, b = 0.2 * o.room_m, c = 0.5 * o.room_m;
  const double perimeter = kPi * (3 * (a + b) - std::sqrt((3 * a + b) * (a + 3 * b)));
  const double omega = 2 * kPi * o.speed_mps / perimeter;
  const double phi = omega * t_s + 2 * kPi * k / o.robots;
  const double dx = -a * std::sin(phi) * omega, dy = b * std::cos(phi) * omega;
  if (v_mps) *v_mps = std::hypot(dx, dy);
  if (w_radps) {
    const double ddx = -a * std::cos(phi) * omega * omega, ddy = -b * std::sin(phi) * omega * omega;
    *w_radps = (dx * ddy - dy * ddx) / (dx * dx + dy * dy);
  }
  return {c + a * std::cos(phi), c + b * std::sin(phi), std::atan2(dy, dx)};
}

inline Dataset synthetic_survey(const SurveyOptions& o) {
  Dataset d;
  d.scenario = "synthetic-oval-" + std::to_string(static_cast<int>(o.room_m)) + "m";
  d.seed = o.seed;
  d.duration_s = o.duration_s;
  d.room_m[0] = d.room_m[1] = o.room_m;
  d.room_m[2] = o.height_m;
  for (int k = 0; k < o.robots; ++k) {
    DatasetRobot r;
    r.id = static_cast<std::uint8_t>(k + 1);
    r.name = "robot" + std::to_string(k + 1);
    r.role = k % 2 == 0 ? "down-laser" : "up-laser";
    r.mount_xyz_m[0] = 0.1;
    r.mount_xyz_m[2] = 0.45;
    r.mount_rpy_rad[1] = k % 2 == 0 ? 0.35 : -0.35;  // positive pitch: nose down
    d.robots.push_back(r);
  }
  std::mt19937_64 rng(o.seed);
  std::normal_distribution<double> noise(0.0, o.range_noise_m);
  const LaserVariant laser{180, 100};
  const auto steps = static_cast<int>(o.duration_s * o.scan_hz);
  const Vec3 room_lo{0, 0, 0}, room_hi{o.room_m, o.room_m, o.height_m};
  // A table: a 1.2 × 0.8 m top, 3 cm thick at 0.72 m, in a corner of the room.
  const Vec3 table_lo{0.08 * o.room_m, 0.08 * o.room_m, 0.72}, table_hi{0.08 * o.room_m + 1.2, 0.08 * o.room_m + 0.8, 0.75};
  for (int s = 0; s < steps; ++s) {
    const double t = s / o.scan_hz;
    const auto stamp = static_cast<std::int64_t>(t * 1e9);
    std::vector<Pose2> poses;
    for (int k = 0; k < o.robots; ++k) {
      double v = 0, w = 0;
      poses.push_back(oval_pose(o, k, t, &v, &w));
      d.odom.push_back({static_cast<std::uint8_t>(k + 1), stamp, poses.back(), v, w});
    }
    for (int k = 0; k < o.robots; ++k) {
      const DatasetRobot& robot = d.robots[static_cast<std::size_t>(k)];
      const Pose3 map_from_laser =
          teamscan::map_from_laser(poses[static_cast<std::size_t>(k)],
                                   Pose3::from_xyz_rpy(robot.mount_xyz_m[0], robot.mount_xyz_m[1], robot.mount_xyz_m[2],
                                                       robot.mount_rpy_rad[0], robot.mount_rpy_rad[1], robot.mount_rpy_rad[2]));
      ScanRecord rec;
      rec.robot = robot.id;
      rec.scan = static_cast<std::uint32_t>(s);
      rec.stamp_ns = stamp;
      rec.beams = laser.beams();
      rec.pose = rec.true_pose = poses[static_cast<std::size_t>(k)];
      rec.origin = map_from_laser.translation;
      const Vec3 o3 = rec.origin;
      for (std::uint16_t i = 0; i < laser.beams(); ++i) {
        const Vec3 dir = map_from_laser.rotation.apply(beam_in_laser(laser.beam_angle_rad(i), 1.0));
        double best = std::numeric_limits<double>::infinity();
        PointClass label = PointClass::none;
        std::uint8_t hit = 0;
        double t_in = 0, t_out = 0;
        if (detail::ray_box(o3, dir, room_lo, room_hi, t_in, t_out) && t_out > 0) {
          best = t_out;
          const Vec3 p = o3 + t_out * dir;
          label = p.z <= 1e-6 ? PointClass::floor : p.z >= o.height_m - 1e-6 ? PointClass::ceiling : PointClass::wall;
        }
        if (o.table && detail::ray_box(o3, dir, table_lo, table_hi, t_in, t_out) && t_in > 0 && t_in < best) {
          best = t_in;
          label = PointClass::furniture;
        }
        for (int j = 0; j < o.robots; ++j) {
          if (j == k) continue;
          // The teammate's body in its own frame: 0.626 × 0.505 × 0.5 m box on the floor.
          const Pose2& pj = poses[static_cast<std::size_t>(j)];
          const double c = std::cos(pj.theta_rad), sn = std::sin(pj.theta_rad);
          const Vec3 lo{-0.313, -0.2525, 0.0}, hi{0.313, 0.2525, 0.5};
          const Vec3 ol{c * (o3.x - pj.x_m) + sn * (o3.y - pj.y_m), -sn * (o3.x - pj.x_m) + c * (o3.y - pj.y_m), o3.z};
          const Vec3 dl{c * dir.x + sn * dir.y, -sn * dir.x + c * dir.y, dir.z};
          if (detail::ray_box(ol, dl, lo, hi, t_in, t_out) && t_in > 0 && t_in < best) {
            best = t_in;
            label = PointClass::robot;
            hit = static_cast<std::uint8_t>(j + 1);
          }
        }
        if (!(best < 8.0)) continue;  // LMS-200 range used here: 8 m
        const Vec3 truth = o3 + best * dir;
        const Vec3 p = o3 + (best + noise(rng)) * dir;
        LabelledPoint lp;
        lp.x = static_cast<float>(p.x);
        lp.y = static_cast<float>(p.y);
        lp.z = static_cast<float>(p.z);
        lp.tx = static_cast<float>(truth.x);
        lp.ty = static_cast<float>(truth.y);
        lp.tz = static_cast<float>(truth.z);
        lp.robot = robot.id;
        lp.scan = rec.scan;
        lp.beam = i;
        lp.label = label;
        lp.hit_robot = hit;
        d.points.push_back(lp);
        ++rec.points;
      }
      d.scans.push_back(rec);
    }
  }
  d.truth = d.odom;
  return d;
}

// The data set a benchmark runs on: TEAMSCAN_BENCH_DATASET=DIR (a `teamscan sim` output such as lap2),
// else (or if DIR cannot be read, said on stderr by `who`) the synthetic survey of `duration_s`.
inline Dataset bench_dataset_or_survey(const char* who, double duration_s) {
  if (const char* dir = std::getenv("TEAMSCAN_BENCH_DATASET")) {
    auto read = read_dataset(dir);
    if (read) return std::move(read.value());
    std::fprintf(stderr, "%s: %s: %s; using the synthetic survey\n", who, dir, read.error().what);
  }
  SurveyOptions o;
  o.duration_s = duration_s;
  return synthetic_survey(o);
}

}  // namespace teamscan::bench
