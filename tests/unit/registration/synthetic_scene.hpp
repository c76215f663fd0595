// Synthetic geometry for the registration tests: vertical rectangles (walls, furniture sides) and
// horizontal ones (floor, ceiling, table tops), sampled near a pose like a robot's recent points.
#pragma once

#include <cmath>
#include <cstdint>
#include <random>
#include <vector>

#include "common/pose.hpp"

namespace teamscan::registration::testing {

struct Wall {  // vertical: from a to b, z in [z0, z1]
  Vec2 a, b;
  double z0 = 0, z1 = 2.5;
};
struct Slab {  // horizontal at height z over [x0, x1] × [y0, y1]
  double x0, x1, y0, y1, z;
};

struct Scene {
  std::vector<Wall> walls;
  std::vector<Slab> slabs;

  // A room sx × sy × sz centred at the origin with floor and ceiling.
  static Scene room(double sx, double sy, double sz) {
    Scene s;
    const double x = sx / 2, y = sy / 2;
    s.walls = {{{-x, -y}, {x, -y}, 0, sz}, {{x, -y}, {x, y}, 0, sz}, {{x, y}, {-x, y}, 0, sz}, {{-x, y}, {-x, -y}, 0, sz}};
    s.slabs = {{-x, x, -y, y, 0.0}, {-x, x, -y, y, sz}};
    return s;
  }
  // A box (furniture) standing on the floor: four sides and a top.
  void box(double cx, double cy, double lx, double ly, double h) {
    const Vec2 a{cx - lx / 2, cy - ly / 2}, b{cx + lx / 2, cy - ly / 2}, c{cx + lx / 2, cy + ly / 2}, d{cx - lx / 2, cy + ly / 2};
    walls.push_back({a, b, 0, h});
    walls.push_back({b, c, 0, h});
    walls.push_back({c, d, 0, h});
    walls.push_back({d, a, 0, h});
    slabs.push_back({a.x, c.x, a.y, c.y, h});
  }

  // `n` points on the surfaces within `radius` (horizontal distance) of `at`, with Gaussian noise.
  std::vector<Vec3> sample(const Vec2& at, double radius, std::size_t n, std::mt19937_64& rng, double noise_m = 0.005) const {
    std::vector<Vec3> out;
    std::uniform_real_distribution<double> u(0.0, 1.0);
    std::normal_distribution<double> g(0.0, noise_m);
    std::size_t guard = 0;
    const std::size_t surfaces = walls.size() + slabs.size();
    while (out.size() < n && guard++ < n * 200) {
      const std::size_t k = static_cast<std::size_t>(u(rng) * static_cast<double>(surfaces)) % surfaces;
      Vec3 p;
      if (k < walls.size()) {
        const Wall& w = walls[k];
        const double t = u(rng);
        p = {w.a.x + t * (w.b.x - w.a.x), w.a.y + t * (w.b.y - w.a.y), w.z0 + u(rng) * (w.z1 - w.z0)};
      } else {
        const Slab& s = slabs[k - walls.size()];
        p = {s.x0 + u(rng) * (s.x1 - s.x0), s.y0 + u(rng) * (s.y1 - s.y0), s.z};
      }
      if (std::hypot(p.x - at.x, p.y - at.y) > radius) continue;
      out.push_back({p.x + g(rng), p.y + g(rng), p.z + g(rng)});
    }
    return out;
  }
};

// Points moved by the inverse of `map_from_odom`: where odometry that is off by it puts them.
inline std::vector<Vec3> into_odometry(const std::vector<Vec3>& map_points, const Pose2& map_from_odom) {
  const Pose2 inv = map_from_odom.inverse();
  std::vector<Vec3> out;
  out.reserve(map_points.size());
  for (const Vec3& p : map_points) {
    const Vec2 q = inv.apply({p.x, p.y});
    out.push_back({q.x, q.y, p.z});
  }
  return out;
}

}  // namespace teamscan::registration::testing
