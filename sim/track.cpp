// Tracks as arc-length tables over analytic curves, and constant-speed motion with pauses (track.hpp).
#include "sim/track.hpp"

#include <algorithm>
#include <cmath>

namespace teamscan::sim {
namespace {

constexpr int kTableSamples = 8192;  // arc-length table resolution: ~2 mm per sample on a 15 m track

Vec2 catmull_rom(Vec2 p0, Vec2 p1, Vec2 p2, Vec2 p3, double t) {
  const double t2 = t * t, t3 = t2 * t;
  return 0.5 * (2.0 * p1 + t * (p2 - p0) + t2 * (2.0 * p0 - 5.0 * p1 + 4.0 * p2 - p3) +
                t3 * (-1.0 * p0 + 3.0 * p1 - 3.0 * p2 + p3));
}
Vec2 catmull_rom_d(Vec2 p0, Vec2 p1, Vec2 p2, Vec2 p3, double t) {
  const double t2 = t * t;
  return 0.5 * ((p2 - p0) + 2.0 * t * (2.0 * p0 - 5.0 * p1 + 4.0 * p2 - p3) + 3.0 * t2 * (-1.0 * p0 + 3.0 * p1 - 3.0 * p2 + p3));
}

// Centripetal Catmull–Rom on one segment as a cubic Hermite from p1 to p2: the tangents of the
// knot sequence spaced by the chords' square roots (Barry and Goldman's form), scaled to f in [0, 1].
void centripetal(Vec2 p0, Vec2 p1, Vec2 p2, Vec2 p3, double f, Vec2& point, Vec2& tangent) {
  constexpr double kMinSpan = 1e-9;
  const double d01 = std::max(std::sqrt((p1 - p0).norm()), kMinSpan), d12 = std::max(std::sqrt((p2 - p1).norm()), kMinSpan),
               d23 = std::max(std::sqrt((p3 - p2).norm()), kMinSpan);
  const Vec2 m1 = d12 * ((1.0 / d01) * (p1 - p0) - (1.0 / (d01 + d12)) * (p2 - p0) + (1.0 / d12) * (p2 - p1));
  const Vec2 m2 = d12 * ((1.0 / d12) * (p2 - p1) - (1.0 / (d12 + d23)) * (p3 - p1) + (1.0 / d23) * (p3 - p2));
  const double f2 = f * f, f3 = f2 * f;
  point = (2 * f3 - 3 * f2 + 1) * p1 + (f3 - 2 * f2 + f) * m1 + (-2 * f3 + 3 * f2) * p2 + (f3 - f2) * m2;
  tangent = (6 * f2 - 6 * f) * p1 + (3 * f2 - 4 * f + 1) * m1 + (-6 * f2 + 6 * f) * p2 + (3 * f2 - 2 * f) * m2;
}

}  // namespace

Track Track::oval(Vec2 center_m, double semi_x_m, double semi_y_m, double yaw_rad, bool ccw) {
  Track t;
  t.kind_ = Kind::oval;
  t.a_ = semi_x_m;
  t.b_ = semi_y_m;
  t.reverse_ = !ccw;
  t.map_from_track_ = {center_m.x, center_m.y, yaw_rad};
  t.build_table();
  return t;
}

Track Track::figure8(Vec2 center_m, double half_length_m, double width_m, double yaw_rad, bool ccw) {
  Track t;
  t.kind_ = Kind::figure8;
  t.a_ = half_length_m;
  t.b_ = width_m;
  t.reverse_ = !ccw;
  t.map_from_track_ = {center_m.x, center_m.y, yaw_rad};
  t.build_table();
  return t;
}

Track Track::waypoints(std::vector<Vec2> points_m, bool closed, Spline spline) {
  Track t;
  t.kind_ = Kind::waypoints;
  t.closed_ = closed;
  t.spline_ = spline;
  t.points_ = std::move(points_m);
  t.build_table();
  return t;
}

void Track::evaluate(double u, Vec2& point_m, Vec2& tangent_m) const {
  const double sign = reverse_ ? -1.0 : 1.0;
  if (reverse_) u = 1.0 - u;
  Vec2 p, d;
  switch (kind_) {
    case Kind::oval: {
      const double a = 2.0 * kPi * u, ca = std::cos(a), sa = std::sin(a);
      p = {a_ * ca, b_ * sa};
      d = {-a_ * sa, b_ * ca};
      break;
    }
    case Kind::figure8: {
      const double a = 2.0 * kPi * u, ca = std::cos(a), sa = std::sin(a);
      p = {a_ * sa, b_ * sa * ca};
      d = {a_ * ca, b_ * (ca * ca - sa * sa)};
      break;
    }
    case Kind::waypoints: {
      const int n = static_cast<int>(points_.size());
      const int segments = closed_ ? n : n - 1;
      const double x = std::clamp(u, 0.0, 1.0) * segments;
      const int seg = std::min(static_cast<int>(x), segments - 1);
      const double f = x - seg;
      auto at = [&](int i) {
        if (closed_) return points_[static_cast<std::size_t>(((i % n) + n) % n)];
        // Open: reflect the end points so the spline starts and ends on them with a natural tangent.
        if (i < 0) return 2.0 * points_[0] - points_[1];
        if (i >= n) return 2.0 * points_[static_cast<std::size_t>(n - 1)] - points_[static_cast<std::size_t>(n - 2)];
        return points_[static_cast<std::size_t>(i)];
      };
      const Vec2 p0 = at(seg - 1), p1 = at(seg), p2 = at(seg + 1), p3 = at(seg + 2);
      if (spline_ == Spline::centripetal) {
        centripetal(p0, p1, p2, p3, f, p, d);
      } else {
        p = catmull_rom(p0, p1, p2, p3, f);
        d = catmull_rom_d(p0, p1, p2, p3, f);
      }
      break;
    }
  }
  point_m = {map_from_track_.x_m + cos_yaw_ * p.x - sin_yaw_ * p.y, map_from_track_.y_m + sin_yaw_ * p.x + cos_yaw_ * p.y};
  tangent_m = sign * Vec2{cos_yaw_ * d.x - sin_yaw_ * d.y, sin_yaw_ * d.x + cos_yaw_ * d.y};
}

void Track::build_table() {
  cos_yaw_ = std::cos(map_from_track_.theta_rad);
  sin_yaw_ = std::sin(map_from_track_.theta_rad);
  cumulative_m_.assign(kTableSamples + 1, 0.0);
  Vec2 prev = point(0.0);
  for (int k = 1; k <= kTableSamples; ++k) {
    const Vec2 p = point(static_cast<double>(k) / kTableSamples);
    cumulative_m_[static_cast<std::size_t>(k)] = cumulative_m_[static_cast<std::size_t>(k - 1)] + (p - prev).norm();
    prev = p;
  }
}

Pose2 Track::pose_at(double s_m) const {
  const double length = length_m();
  if (closed_) {
    s_m = std::fmod(s_m, length);
    if (s_m < 0) s_m += length;
  } else {
    s_m = std::clamp(s_m, 0.0, length);
  }
  // Index k with cumulative[k] <= s < cumulative[k+1], then linear in u between samples.
  const auto it = std::upper_bound(cumulative_m_.begin(), cumulative_m_.end(), s_m);
  const std::size_t k = std::min<std::size_t>(static_cast<std::size_t>(std::max<std::ptrdiff_t>(it - cumulative_m_.begin() - 1, 0)),
                                              kTableSamples - 1);
  const double span = cumulative_m_[k + 1] - cumulative_m_[k];
  const double f = span > 0 ? (s_m - cumulative_m_[k]) / span : 0.0;
  const double u = (static_cast<double>(k) + f) / kTableSamples;
  Vec2 p, d;
  evaluate(u, p, d);
  if (d.x * d.x + d.y * d.y < 1e-24) d = point(std::min(u + 1e-6, 1.0)) - point(std::max(u - 1e-6, 0.0));
  return {p.x, p.y, std::atan2(d.y, d.x)};
}

Motion::Motion(Track track, double speed_mps, double start_offset_m, double distance_m, double start_s,
               std::vector<Pause> pauses, double accel_mps2, double max_yaw_rate_radps)
    : track_{std::move(track)},
      speed_mps_{speed_mps},
      start_offset_m_{start_offset_m},
      distance_m_{distance_m},
      start_s_{start_s},
      accel_mps2_{accel_mps2},
      pauses_{std::move(pauses)} {
  std::sort(pauses_.begin(), pauses_.end(), [](const Pause& a, const Pause& b) { return a.at_s < b.at_s; });
  finish_s_ = start_s_;
  if (speed_mps_ <= 0 || distance_m_ <= 0) return;
  // Drives between the pauses until the distance is done; the last drive is cut to what remains.
  double remaining = distance_m_;
  double from = start_s_;
  auto last_drive = [&](double from_s) {
    // Length L of a drive that covers `remaining`: trapezoid V·(L − τ) if long enough, else a
    // triangle a·L²/4 (τ = V / a; a = 0 means τ = 0).
    const double tau = accel_mps2_ > 0 ? speed_mps_ / accel_mps2_ : 0.0;
    const double length = remaining >= speed_mps_ * tau ? remaining / speed_mps_ + tau : 2.0 * std::sqrt(remaining / accel_mps2_);
    Drive d = make_drive(from_s, from_s + length);
    d.distance_m = remaining;  // exact, not the rounded area
    drives_.push_back(d);
    finish_s_ = d.to_s;
  };
  for (const Pause& p : pauses_) {
    const double pause_end = p.at_s + p.for_s;
    if (pause_end <= from) continue;
    if (p.at_s > from) {
      const Drive d = make_drive(from, p.at_s);
      if (d.distance_m >= remaining) {
        last_drive(from);
        stretch_for_turns(max_yaw_rate_radps);
        return;
      }
      drives_.push_back(d);
      remaining -= d.distance_m;
    }
    from = std::max(from, pause_end);
  }
  last_drive(from);
  stretch_for_turns(max_yaw_rate_radps);
}

Motion::Drive Motion::make_drive(double from_s, double to_s) const {
  Drive d;
  d.from_s = from_s;
  d.to_s = to_s;
  const double length = to_s - from_s;
  d.ramp_s = accel_mps2_ > 0 ? std::min(speed_mps_ / accel_mps2_, 0.5 * length) : 0.0;
  const double peak = accel_mps2_ > 0 ? accel_mps2_ * d.ramp_s : speed_mps_;
  d.distance_m = peak * (length - d.ramp_s);  // two ramps of area peak·ramp/2 plus the plateau
  return d;
}

double Motion::driven_in(const Drive& d, double t_s) const {
  const double u = std::clamp(t_s - d.from_s, 0.0, d.to_s - d.from_s);
  const double length = d.to_s - d.from_s, r = d.ramp_s;
  const double peak = accel_mps2_ > 0 ? accel_mps2_ * r : speed_mps_;
  double s;
  if (u <= r) {
    s = 0.5 * accel_mps2_ * u * u;
  } else if (u <= length - r) {
    s = 0.5 * peak * r + peak * (u - r);
  } else {
    const double left = length - u;
    s = peak * (length - r) - 0.5 * accel_mps2_ * left * left;
  }
  return std::min(s, d.distance_m);
}

double Motion::speed_in(const Drive& d, double t_s) const {
  const double u = t_s - d.from_s, length = d.to_s - d.from_s, r = d.ramp_s;
  if (u < 0 || u >= length) return 0.0;
  if (accel_mps2_ <= 0) return speed_mps_;
  if (u < r) return accel_mps2_ * u;
  if (u > length - r) return accel_mps2_ * (length - u);
  return accel_mps2_ * r;
}

double Motion::planned_distance_at(double t_s) const {
  double s = 0;
  for (const Drive& d : drives_) {
    if (t_s <= d.from_s) break;
    s += t_s >= d.to_s ? d.distance_m : driven_in(d, t_s);
  }
  return std::min(s, distance_m_);
}

bool Motion::moving_at(double t_s) const { return planned_speed_at(planned_time(t_s)) > 0.0; }

double Motion::planned_speed_at(double t_s) const {
  for (const Drive& d : drives_) {
    if (t_s >= d.from_s && t_s < d.to_s) return speed_in(d, t_s);
  }
  return 0.0;
}

double Motion::speed_at(double t_s) const { return planned_speed_at(planned_time(t_s)) * planned_clock_rate(t_s); }

double Motion::yaw_rate_at(double t_s) const {
  constexpr double kH = 1e-3;
  return normalize_angle(pose_at(t_s + kH).theta_rad - pose_at(t_s - kH).theta_rad) / (2.0 * kH);
}

double Motion::planned_yaw_rate_at(double planned_s) const {
  constexpr double kH = 1e-3;
  const double ahead = track_.pose_at(start_offset_m_ + planned_distance_at(planned_s + kH)).theta_rad;
  const double behind = track_.pose_at(start_offset_m_ + planned_distance_at(planned_s - kH)).theta_rad;
  return normalize_angle(ahead - behind) / (2.0 * kH);
}

void Motion::stretch_for_turns(double max_yaw_rate_radps) {
  if (max_yaw_rate_radps <= 0 || drives_.empty()) return;
  // The planned clock's rate: 1, or less where the planned motion turns faster than the limit.
  auto rate = [&](double planned_s) {
    const double w = std::abs(planned_yaw_rate_at(planned_s));
    return w > max_yaw_rate_radps ? max_yaw_rate_radps / w : 1.0;
  };
  // Real time in steps of a millisecond (midpoint rule), from the first drive to the planned finish;
  // 10 ms at a time while the rate is under the limit at both ends of the step.
  constexpr double kStep = 1e-3, kCoarseStep = 1e-2;
  const double planned_finish = finish_s_;
  double t = drives_.front().from_s, planned = t;
  bool inside = false;
  while (planned < planned_finish) {
    if (!inside && rate(planned) == 1.0 && rate(planned + kCoarseStep) == 1.0) {
      t += kCoarseStep;
      planned += kCoarseStep;
      continue;
    }
    const double r = rate(planned + 0.5 * kStep * rate(planned));
    if (r < 1.0) {
      stretch_.push_back({t, planned, true});
      inside = true;
    } else if (inside) {
      stretch_.push_back({t, planned, false});
      inside = false;
    }
    t += kStep;
    planned += kStep * r;
  }
  if (inside) stretch_.push_back({t, planned, false});
  if (!stretch_.empty()) finish_s_ = t - (planned - planned_finish);
}

Motion::StretchSpan Motion::stretch_at(double t_s) const {
  StretchSpan span;
  if (stretch_.empty() || t_s < stretch_.front().t_s) return span;
  const auto after = std::upper_bound(stretch_.begin(), stretch_.end(), t_s,
                                      [](double t, const StretchKnot& k) { return t < k.t_s; });
  span.from = &*(after - 1);
  if (span.from->stretched && after != stretch_.end()) span.to = &*after;
  return span;
}

double Motion::planned_time(double t_s) const {
  const StretchSpan s = stretch_at(t_s);
  if (s.from == nullptr) return t_s;
  if (s.to == nullptr) return s.from->planned_s + (t_s - s.from->t_s);
  const double f = (t_s - s.from->t_s) / (s.to->t_s - s.from->t_s);
  return s.from->planned_s + f * (s.to->planned_s - s.from->planned_s);
}

double Motion::planned_clock_rate(double t_s) const {
  const StretchSpan s = stretch_at(t_s);
  return s.to == nullptr ? 1.0 : (s.to->planned_s - s.from->planned_s) / (s.to->t_s - s.from->t_s);
}

}  // namespace teamscan::sim
