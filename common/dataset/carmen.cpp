// CARMEN log reader (carmen.hpp).
#include "common/dataset/carmen.hpp"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <limits>

namespace teamscan {
namespace {

bool number(std::string_view tok, double& out) {
  const char* end = tok.data() + tok.size();
  auto [p, ec] = std::from_chars(tok.data(), end, out);
  return ec == std::errc{} && p == end && std::isfinite(out);
}


// FLASER n r1..rn x y th odom_x odom_y odom_th ipc_timestamp host logger_timestamp
bool parse_flaser(const std::vector<std::string_view>& t, CarmenLaser& l, const char*& why) {
  double n = 0;
  if (t.size() < 2 || !number(t[1], n) || n < 1 || n > 2000 || n != std::floor(n)) {
    why = "FLASER: bad beam count";
    return false;
  }
  const auto beams = static_cast<std::size_t>(n);
  if (t.size() < 2 + beams + 6 + 1) {
    why = "FLASER: too few fields";
    return false;
  }
  l.ranges_m.reserve(beams);
  bool ok = true;
  for (std::size_t i = 0; i < beams && ok; ++i) {
    double r = 0;
    ok = number(t[2 + i], r) && r >= 0;
    l.ranges_m.push_back(static_cast<float>(r));
  }
  double v[6] = {};
  for (int k = 0; k < 6 && ok; ++k) ok = number(t[2 + beams + static_cast<std::size_t>(k)], v[k]);
  ok = ok && number(t[2 + beams + 6], l.stamp_s) && parse_carmen_stamp_us(t[2 + beams + 6], l.stamp_us);
  if (!ok) {
    why = "FLASER: a field is not a number";
    return false;
  }
  l.pose = {v[3], v[4], normalize_angle(v[5])};  // the odometry fields
  return true;
}

// ROBOTLASER1 type start_angle fov resolution max_range accuracy remission_mode n r1..rn m e1..em
//   laser_x laser_y laser_th robot_x robot_y robot_th tv rv forward_safety side_safety turn_axis
//   ipc_timestamp host logger_timestamp
bool parse_robotlaser1(const std::vector<std::string_view>& t, CarmenLaser& l, const char*& why) {
  double head[8] = {};
  bool ok = t.size() > 9;
  for (int k = 0; k < 8 && ok; ++k) ok = number(t[1 + static_cast<std::size_t>(k)], head[k]);
  const double n = head[7];
  if (!ok || n < 1 || n > 2000 || n != std::floor(n)) {
    why = "ROBOTLASER1: bad header or beam count";
    return false;
  }
  const auto beams = static_cast<std::size_t>(n);
  double m = 0;
  if (t.size() < 9 + beams + 1 || !number(t[9 + beams], m) || m < 0 || m > 2000 || m != std::floor(m)) {
    why = "ROBOTLASER1: bad remission count";
    return false;
  }
  const std::size_t tail = 9 + beams + 1 + static_cast<std::size_t>(m);  // the laser pose's first field
  if (t.size() < tail + 11 + 1) {
    why = "ROBOTLASER1: too few fields";
    return false;
  }
  l.ranges_m.reserve(beams);
  for (std::size_t i = 0; i < beams && ok; ++i) {
    double r = 0;
    ok = number(t[9 + i], r) && r >= 0;
    l.ranges_m.push_back(static_cast<float>(r));
  }
  double v[6] = {};
  for (int k = 0; k < 6 && ok; ++k) ok = number(t[tail + static_cast<std::size_t>(k)], v[k]);
  ok = ok && number(t[tail + 11], l.stamp_s) && parse_carmen_stamp_us(t[tail + 11], l.stamp_us);
  if (!ok) {
    why = "ROBOTLASER1: a field is not a number";
    return false;
  }
  const Pose2 map_from_laser{v[0], v[1], normalize_angle(v[2])};
  l.pose = {v[3], v[4], normalize_angle(v[5])};
  l.robot_from_laser = l.pose.inverse() * map_from_laser;
  l.start_angle_rad = head[1];
  l.angle_step_rad = head[3];
  l.max_range_m = head[4] > 0 ? head[4] : 0.0;
  return true;
}

}  // namespace

std::vector<std::string_view> split_carmen_fields(std::string_view line) {
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

bool parse_carmen_stamp_us(std::string_view text, std::int64_t& stamp_us) {
  bool negative = false;
  if (!text.empty() && (text.front() == '-' || text.front() == '+')) {
    negative = text.front() == '-';
    text.remove_prefix(1);
  }
  const std::size_t dot = text.find('.');
  const std::string_view whole = text.substr(0, dot);
  const std::string_view fraction = dot == std::string_view::npos ? std::string_view{} : text.substr(dot + 1);
  if (whole.empty() && fraction.empty()) return false;
  if (whole.size() > 12) return false;  // beyond year 33658: not a stamp, and keeps the sum in range
  std::int64_t us = 0;
  for (char c : whole) {
    if (c < '0' || c > '9') return false;
    us = us * 10 + (c - '0');
  }
  std::int64_t frac_us = 0;
  for (std::size_t i = 0; i < fraction.size(); ++i) {
    const char c = fraction[i];
    if (c < '0' || c > '9') return false;
    if (i < 6) frac_us = frac_us * 10 + (c - '0');
    else if (i == 6 && c >= '5') frac_us += 1;  // round half up on the seventh decimal
  }
  for (std::size_t i = fraction.size(); i < 6; ++i) frac_us *= 10;
  stamp_us = us * 1'000'000 + frac_us;
  if (negative) stamp_us = -stamp_us;
  return true;
}

CarmenLog parse_carmen(std::string_view text) {
  CarmenLog log;
  std::size_t pos = 0;
  std::size_t order = 0;
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
    const std::vector<std::string_view> t = split_carmen_fields(line);
    if (t.empty() || t[0].front() == '#') {
      ++log.comments;
      continue;
    }
    if (t[0] == "FLASER" || t[0] == "ROBOTLASER1") {
      CarmenLaser l;
      const char* why = "";
      if (!(t[0] == "FLASER" ? parse_flaser(t, l, why) : parse_robotlaser1(t, l, why))) {
        fail(why);
        continue;
      }
      l.file_order = order++;
      log.lasers.push_back(std::move(l));
    } else if (t[0] == "ODOM") {
      // ODOM x y theta tv rv accel ipc_timestamp host logger_timestamp
      double v[7] = {};
      bool ok = t.size() >= 8;
      for (int k = 0; k < 7 && ok; ++k) ok = number(t[1 + static_cast<std::size_t>(k)], v[k]);
      std::int64_t stamp_us = 0;
      ok = ok && parse_carmen_stamp_us(t[7], stamp_us);
      if (!ok) {
        fail("ODOM: too few fields or not a number");
        continue;
      }
      log.odom.push_back({{v[0], v[1], normalize_angle(v[2])}, v[3], v[4], v[6], stamp_us, order++});
    } else {
      ++log.other_messages;
    }
  }
  return log;
}

CarmenProcessingClock carmen_processing_clock(const CarmenLog& log) {
  struct Line {
    std::size_t order;
    bool laser;
    std::size_t index;
    std::int64_t stamp_us;
  };
  std::vector<Line> lines;
  lines.reserve(log.lasers.size() + log.odom.size());
  for (std::size_t i = 0; i < log.lasers.size(); ++i) lines.push_back({log.lasers[i].file_order, true, i, log.lasers[i].stamp_us});
  for (std::size_t i = 0; i < log.odom.size(); ++i) lines.push_back({log.odom[i].file_order, false, i, log.odom[i].stamp_us});
  std::stable_sort(lines.begin(), lines.end(), [](const Line& a, const Line& b) { return a.order < b.order; });
  CarmenProcessingClock c;
  c.laser_us.resize(log.lasers.size());
  c.odom_us.resize(log.odom.size());
  std::int64_t t = 0;
  for (std::size_t k = 0; k < lines.size(); ++k) {
    t = k == 0 ? lines[k].stamp_us : std::max(lines[k].stamp_us, t + 1);
    (lines[k].laser ? c.laser_us : c.odom_us)[lines[k].index] = t;
    if (k == 0) c.first_us = t;
  }
  c.last_us = t;
  return c;
}

Result<Dataset> carmen_to_dataset(const CarmenLog& log, const CarmenImportOptions& o) {
  if (log.lasers.empty()) return Error{"no FLASER or ROBOTLASER1 line"};
  const CarmenProcessingClock clock = carmen_processing_clock(log);
  // Every processing time lies in [first_us, last_us]; in nanoseconds from the first it must fit int64.
  if (clock.last_us - clock.first_us > std::numeric_limits<std::int64_t>::max() / 1000)
    return Error{"the log's stamps span more than 292 years: not one robot's log"};
  auto stamp_ns = [&](std::int64_t us) { return (us - clock.first_us) * 1000; };
  Dataset d;
  d.scenario = o.name;
  DatasetRobot r;
  r.id = 1;
  r.name = "robot1";
  r.role = "horizontal-laser";
  r.subclass = "unknown";
  const Pose2 mount = log.lasers.front().robot_from_laser;
  r.mount_xyz_m[0] = mount.x_m;
  r.mount_xyz_m[1] = mount.y_m;
  r.mount_xyz_m[2] = o.mount_height_m;
  r.mount_rpy_rad[2] = mount.theta_rad;
  r.fov_deg = 180;
  const std::size_t beams = log.lasers.front().ranges_m.size();
  r.resolution_cdeg = static_cast<std::uint16_t>(beams > 1 ? std::lround(18000.0 / static_cast<double>(beams)) : 100);
  d.robots.push_back(r);
  double extent = 0;
  for (std::size_t s = 0; s < log.lasers.size(); ++s) {
    const CarmenLaser& l = log.lasers[s];
    ScanRecord rec;
    rec.robot = 1;
    rec.scan = static_cast<std::uint32_t>(s);
    rec.stamp_ns = stamp_ns(clock.laser_us[s]);
    rec.source_stamp_us = l.stamp_us;
    rec.beams = static_cast<std::uint16_t>(l.ranges_m.size());
    rec.pose = l.pose;
    const Pose2 map_from_laser = l.pose * l.robot_from_laser;
    rec.origin = {map_from_laser.x_m, map_from_laser.y_m, o.mount_height_m};
    const std::size_t n = l.ranges_m.size();
    const double max_range_m = l.max_range_m > 0 ? std::min(o.max_range_m, l.max_range_m) : o.max_range_m;
    // FLASER: beam i at −90° + i · step, right to left, step by the import's convention; ROBOTLASER1:
    // the line's own start angle and resolution.
    double start = l.start_angle_rad, step = l.angle_step_rad;
    if (step == 0.0) {
      start = -kPi / 2;
      step = n > 1 ? kPi / static_cast<double>(o.flaser_step_is_fov_over_n ? n : n - 1) : 0.0;
    }
    for (std::size_t i = 0; i < n; ++i) {
      const double range = l.ranges_m[i];
      if (range < o.min_range_m || range >= max_range_m) continue;
      const double a = map_from_laser.theta_rad + start + step * static_cast<double>(i);
      LabelledPoint p;
      p.x = static_cast<float>(map_from_laser.x_m + range * std::cos(a));
      p.y = static_cast<float>(map_from_laser.y_m + range * std::sin(a));
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
  for (std::size_t i = 0; i < log.odom.size(); ++i) {
    const CarmenOdom& od = log.odom[i];
    d.odom.push_back({1, stamp_ns(clock.odom_us[i]), od.pose, od.v_mps, od.w_radps});
  }
  d.duration_s = static_cast<double>(clock.last_us - clock.first_us) * 1e-6;
  d.room_m[0] = d.room_m[1] = 2 * extent + 20;
  d.room_m[2] = 3.0;
  return d;
}

}  // namespace teamscan
