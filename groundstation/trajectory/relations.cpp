// The relations metric (relations.hpp).
#include "groundstation/trajectory/relations.hpp"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdlib>
#include <unordered_map>

#include "common/dataset/carmen.hpp"
#include "common/units.hpp"

namespace teamscan::trajectory {
namespace {

bool number(std::string_view tok, double& out) {
  const char* end = tok.data() + tok.size();
  auto [p, ec] = std::from_chars(tok.data(), end, out);
  return ec == std::errc{} && p == end && std::isfinite(out);
}

// A stamp `seconds.micro` as exact µs: at most six decimals (relation files write six, MIT CSAIL's
// five), so a stamp is never rounded onto another scan's. `unit_us`: the unit of its last decimal.
bool stamp_us(std::string_view tok, std::int64_t& out, std::int64_t& unit_us) {
  const std::size_t dot = tok.find('.');
  const std::size_t decimals = dot == std::string_view::npos ? 0 : tok.size() - dot - 1;
  if (decimals > 6) return false;
  unit_us = 1;
  for (std::size_t k = decimals; k < 6; ++k) unit_us *= 10;
  return !tok.empty() && tok.front() != '-' && tok.front() != '+' && parse_carmen_stamp_us(tok, out);
}

}  // namespace

RelationsFile parse_relations(std::string_view text) {
  RelationsFile f;
  std::size_t pos = 0;
  while (pos < text.size()) {
    std::size_t nl = text.find('\n', pos);
    if (nl == std::string_view::npos) nl = text.size();
    const std::string_view line = text.substr(pos, nl - pos);
    pos = nl + 1;
    ++f.lines;
    const std::vector<std::string_view> t = split_carmen_fields(line);
    if (t.empty() || t[0].front() == '#') {
      ++f.comments;
      continue;
    }
    Relation r;
    double v[6] = {};
    bool ok = t.size() == 8 && stamp_us(t[0], r.t1_us, r.t1_unit_us) && stamp_us(t[1], r.t2_us, r.t2_unit_us);
    for (int k = 0; k < 6 && ok; ++k) ok = number(t[2 + static_cast<std::size_t>(k)], v[k]);
    if (!ok) {
      ++f.malformed;
      if (f.first_error.empty()) f.first_error = "line " + std::to_string(f.lines) + ": expected t1 t2 x y z roll pitch yaw";
      continue;
    }
    r.t1_from_t2 = {v[0], v[1], normalize_angle(v[5])};
    f.relations.push_back(r);
  }
  return f;
}

RelationErrors relation_errors(const std::vector<Relation>& relations, const std::vector<StampedPose>& trajectory) {
  std::unordered_map<std::int64_t, Pose2> at;
  at.reserve(trajectory.size());
  for (const StampedPose& p : trajectory) at.emplace(p.stamp_us, p.pose);
  std::vector<std::int64_t> stamps;  // sorted, for the rounded stamps
  stamps.reserve(at.size());
  for (const auto& [stamp, pose] : at) stamps.push_back(stamp);
  std::sort(stamps.begin(), stamps.end());
  // The pose a stamp names: its own, else (a rounded stamp) the nearest within half its unit.
  const auto find = [&](std::int64_t t, std::int64_t unit_us, bool& rounded) -> const Pose2* {
    if (const auto it = at.find(t); it != at.end()) return &it->second;
    if (unit_us <= 1) return nullptr;
    const std::int64_t half = unit_us / 2;
    auto it = std::lower_bound(stamps.begin(), stamps.end(), t - half);
    const Pose2* best = nullptr;
    std::int64_t best_off = half + 1;
    for (; it != stamps.end() && *it <= t + half; ++it)
      if (std::llabs(*it - t) < best_off) {
        best_off = std::llabs(*it - t);
        best = &at.at(*it);
      }
    rounded = rounded || best;
    return best;
  };
  RelationErrors e;
  e.relations = relations.size();
  double t_sum = 0, t_sq = 0, r_sum = 0, r_sq = 0;
  for (const Relation& r : relations) {
    bool rounded = false;
    const Pose2* a = find(r.t1_us, r.t1_unit_us, rounded);
    const Pose2* b = find(r.t2_us, r.t2_unit_us, rounded);
    if (!a || !b) continue;
    if (rounded) ++e.rounded;
    const Pose2 error = r.t1_from_t2.inverse() * (a->inverse() * *b);
    const double t = std::hypot(error.x_m, error.y_m);
    const double rot = std::abs(normalize_angle(error.theta_rad)) * 180.0 / kPi;
    ++e.used;
    t_sum += t;
    t_sq += t * t;
    r_sum += rot;
    r_sq += rot * rot;
    e.translation_max_m = std::max(e.translation_max_m, t);
    e.rotation_max_deg = std::max(e.rotation_max_deg, rot);
  }
  if (e.used == 0) return e;
  const double n = static_cast<double>(e.used);
  e.translation_mean_m = t_sum / n;
  e.translation_squared_mean_m2 = t_sq / n;
  e.translation_std_m = std::sqrt(std::max(0.0, t_sq / n - e.translation_mean_m * e.translation_mean_m));
  e.rotation_mean_deg = r_sum / n;
  e.rotation_squared_mean_deg2 = r_sq / n;
  e.rotation_std_deg = std::sqrt(std::max(0.0, r_sq / n - e.rotation_mean_deg * e.rotation_mean_deg));
  return e;
}

}  // namespace teamscan::trajectory
