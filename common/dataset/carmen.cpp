// CARMEN log reader (carmen.hpp).
#include "common/dataset/carmen.hpp"

#include <charconv>
#include <cmath>

namespace teamscan {
namespace {

bool number(std::string_view tok, double& out) {
  const char* end = tok.data() + tok.size();
  auto [p, ec] = std::from_chars(tok.data(), end, out);
  return ec == std::errc{} && p == end && std::isfinite(out);
}

std::vector<std::string_view> split(std::string_view line) {
  std::vector<std::string_view> out;
  std::size_t i = 0;
  while (i < line.size()) {
    while (i < line.size() && (line[i] == ' ' || line[i] == '\t' || line[i] == '\r')) ++i;
    std::size_t j = i;
    while (j < line.size() && line[j] != ' ' && line[j] != '\t' && line[j] != '\r') ++j;
    if (j > i) out.push_back(line.substr(i, j - i));
    i = j;
  }
  return out;
}

}  // namespace

CarmenLog parse_carmen(std::string_view text) {
  CarmenLog log;
  std::size_t pos = 0;
  while (pos < text.size()) {
    std::size_t nl = text.find('\n', pos);
    if (nl == std::string_view::npos) nl = text.size();
    const std::string_view line = text.substr(pos, nl - pos);
    pos = nl + 1;
    ++log.lines;
    auto fail = [&](const char* why) {
      ++log.malformed;
      if (log.first_error.empty()) log.first_error = "line " + std::to_string(log.lines) + ": " + why;
    };
    const std::vector<std::string_view> t = split(line);
    if (t.empty() || t[0].front() == '#') {
      ++log.comments;
      continue;
    }
    if (t[0] == "FLASER") {
      double n = 0;
      if (t.size() < 2 || !number(t[1], n) || n < 1 || n > 2000 || n != std::floor(n)) {
        fail("FLASER: bad beam count");
        continue;
      }
      const auto beams = static_cast<std::size_t>(n);
      // FLASER n r1..rn x y th odom_x odom_y odom_th timestamp host logger_timestamp
      if (t.size() < 2 + beams + 6 + 1) {
        fail("FLASER: too few fields");
        continue;
      }
      CarmenLaser l;
      l.ranges_m.reserve(beams);
      bool ok = true;
      for (std::size_t i = 0; i < beams && ok; ++i) {
        double r = 0;
        ok = number(t[2 + i], r) && r >= 0;
        l.ranges_m.push_back(static_cast<float>(r));
      }
      double v[6] = {};
      for (int k = 0; k < 6 && ok; ++k) ok = number(t[2 + beams + static_cast<std::size_t>(k)], v[k]);
      double stamp = 0;
      ok = ok && number(t[2 + beams + 6], stamp);
      if (!ok) {
        fail("FLASER: a field is not a number");
        continue;
      }
      l.pose = {v[3], v[4], normalize_angle(v[5])};  // the odometry fields
      l.stamp_s = stamp;
      log.lasers.push_back(std::move(l));
    } else if (t[0] == "ODOM") {
      // ODOM x y theta tv rv accel timestamp host logger_timestamp
      double v[7] = {};
      bool ok = t.size() >= 8;
      for (int k = 0; k < 7 && ok; ++k) ok = number(t[1 + static_cast<std::size_t>(k)], v[k]);
      if (!ok) {
        fail("ODOM: too few fields or not a number");
        continue;
      }
      log.odom.push_back({{v[0], v[1], normalize_angle(v[2])}, v[3], v[4], v[6]});
    } else {
      ++log.other_messages;
    }
  }
  return log;
}

Result<Dataset> carmen_to_dataset(const CarmenLog& log, const CarmenImportOptions& o) {
  if (log.lasers.empty()) return Error{"no FLASER line"};
  Dataset d;
  d.scenario = o.name;
  DatasetRobot r;
  r.id = 1;
  r.name = "robot1";
  r.role = "horizontal-laser";
  r.subclass = "unknown";
  r.mount_xyz_m[2] = o.mount_height_m;
  r.fov_deg = 180;
  const std::size_t beams = log.lasers.front().ranges_m.size();
  r.resolution_cdeg = static_cast<std::uint16_t>(beams > 1 ? std::lround(18000.0 / static_cast<double>(beams)) : 100);
  d.robots.push_back(r);
  const double t0 = log.lasers.front().stamp_s;
  double last_stamp = -1e300;
  double extent = 0;
  for (std::size_t s = 0; s < log.lasers.size(); ++s) {
    const CarmenLaser& l = log.lasers[s];
    if (l.stamp_s < last_stamp) return Error{"FLASER timestamps go backwards (detail: scan index)", 0, static_cast<long>(s)};
    last_stamp = l.stamp_s;
    ScanRecord rec;
    rec.robot = 1;
    rec.scan = static_cast<std::uint32_t>(s);
    rec.stamp_ns = static_cast<std::int64_t>(std::llround((l.stamp_s - t0) * 1e9));
    rec.beams = static_cast<std::uint16_t>(l.ranges_m.size());
    rec.pose = l.pose;
    rec.origin = {l.pose.x_m, l.pose.y_m, o.mount_height_m};
    const std::size_t n = l.ranges_m.size();
    // Beam i points at −90° + i · 180°/(n − 1) … the CARMEN convention for a 180° FLASER (right to left).
    for (std::size_t i = 0; i < n; ++i) {
      const double range = l.ranges_m[i];
      if (range < o.min_range_m || range >= o.max_range_m) continue;
      const double a = l.pose.theta_rad - kPi / 2 + (n > 1 ? kPi * static_cast<double>(i) / static_cast<double>(n - 1) : 0.0);
      LabelledPoint p;
      p.x = static_cast<float>(l.pose.x_m + range * std::cos(a));
      p.y = static_cast<float>(l.pose.y_m + range * std::sin(a));
      p.z = static_cast<float>(o.mount_height_m);
      p.robot = 1;
      p.scan = rec.scan;
      p.beam = static_cast<std::uint16_t>(i);
      d.points.push_back(p);
      ++rec.points;
    }
    d.scans.push_back(rec);
    if (log.odom.empty()) d.odom.push_back({1, rec.stamp_ns, l.pose, 0.0, 0.0});
    extent = std::max(extent, std::max(std::abs(l.pose.x_m), std::abs(l.pose.y_m)));
  }
  for (const CarmenOdom& od : log.odom)
    d.odom.push_back({1, static_cast<std::int64_t>(std::llround((od.stamp_s - t0) * 1e9)), od.pose, od.v_mps, od.w_radps});
  d.duration_s = static_cast<double>(d.scans.back().stamp_ns) * 1e-9;
  d.room_m[0] = d.room_m[1] = 2 * extent + 20;
  d.room_m[2] = 3.0;
  return d;
}

}  // namespace teamscan
