// A synthetic room for the matcher tests: the walls of a 8 × 6 m room with a pillar, sampled every
// 2 cm, and a scan of it (the returns seen from a pose, every beam to its first wall).
#pragma once

#include <cmath>
#include <vector>

#include "common/pose.hpp"

namespace teamscan::posegraph::test {

struct Segment {
  Vec2 a, b;
};

inline std::vector<Segment> room() {
  return {{{0, 0}, {8, 0}}, {{8, 0}, {8, 6}}, {{8, 6}, {0, 6}}, {{0, 6}, {0, 0}},
          {{3, 2}, {3.5, 2}}, {{3.5, 2}, {3.5, 2.6}}, {{3.5, 2.6}, {3, 2.6}}, {{3, 2.6}, {3, 2}}, {{6, 4}, {7, 5}}};
}

// 360 beams, 1° apart, from `map_from_robot`: returns in the robot frame.
inline std::vector<Vec2> scan(const Pose2& map_from_robot) {
  std::vector<Vec2> out;
  const std::vector<Segment> walls = room();
  for (int i = 0; i < 360; ++i) {
    const double a = map_from_robot.theta_rad + i * kPi / 180.0;
    const Vec2 o{map_from_robot.x_m, map_from_robot.y_m}, d{std::cos(a), std::sin(a)};
    double best = 1e9;
    for (const Segment& s : walls) {
      const Vec2 e = s.b - s.a;
      const double den = d.x * e.y - d.y * e.x;
      if (std::abs(den) < 1e-12) continue;
      const Vec2 w = s.a - o;
      const double t = (w.x * e.y - w.y * e.x) / den, u = (w.x * d.y - w.y * d.x) / den;
      if (t > 0 && u >= 0 && u <= 1) best = std::min(best, t);
    }
    if (best < 1e8) {
      const Vec2 hit{o.x + best * d.x, o.y + best * d.y};
      out.push_back(map_from_robot.inverse().apply(hit));
    }
  }
  return out;
}

}  // namespace teamscan::posegraph::test
