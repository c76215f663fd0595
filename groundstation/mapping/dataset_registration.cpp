// Offline registration of a data set (dataset_registration.hpp).
#include "groundstation/mapping/dataset_registration.hpp"

#include <algorithm>
#include <cmath>
#include <map>
#include <tuple>

#include "common/units.hpp"
#include "groundstation/mapping/filter.hpp"
#include "groundstation/mapping/tracked_filter.hpp"

namespace teamscan::mapping {
namespace {

ErrorStats stats_of(std::vector<double>& v) {
  ErrorStats s;
  s.count = v.size();
  if (v.empty()) return s;
  std::sort(v.begin(), v.end());
  auto at = [&](double q) { return v[std::min(v.size() - 1, static_cast<std::size_t>(q * static_cast<double>(v.size() - 1) + 0.5))]; };
  s.p50 = at(0.5);
  s.p99 = at(0.99);
  s.max = v.back();
  return s;
}

bool has_truth(const Dataset& d) { return !d.truth.empty(); }

}  // namespace

RevisitConsistency revisit_consistency(const Dataset& d, double min_age_s, double radius_m) {
  RevisitConsistency out;
  std::map<std::pair<std::uint8_t, std::uint32_t>, std::int64_t> stamp_of;
  for (const ScanRecord& s : d.scans) stamp_of[{s.robot, s.scan}] = s.stamp_ns;
  // Points in time order; a 2-D grid of radius-sized cells holding what has been seen so far.
  struct Seen {
    float x, y;
    std::int64_t stamp_ns;
  };
  std::vector<std::pair<std::int64_t, std::size_t>> order;
  order.reserve(d.points.size());
  for (std::size_t i = 0; i < d.points.size(); ++i) {
    const auto it = stamp_of.find({d.points[i].robot, d.points[i].scan});
    if (it != stamp_of.end() && d.points[i].z >= 0.06f) order.push_back({it->second, i});
  }
  std::stable_sort(order.begin(), order.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
  std::map<std::pair<int, int>, std::vector<Seen>> grid;
  const double cell_m = radius_m / 2;
  auto cell = [&](double v) { return static_cast<int>(std::floor(v / cell_m)); };
  const auto min_age_ns = static_cast<std::int64_t>(min_age_s * 1e9);
  std::vector<double> distances;
  for (const auto& [stamp, i] : order) {
    const LabelledPoint& p = d.points[i];
    const int cx = cell(p.x), cy = cell(p.y);
    double best2 = radius_m * radius_m;
    bool revisit = false;
    for (int dx = -2; dx <= 2; ++dx) {
      for (int dy = -2; dy <= 2; ++dy) {
        const auto it = grid.find({cx + dx, cy + dy});
        if (it == grid.end()) continue;
        for (const Seen& s : it->second) {
          if (s.stamp_ns > stamp - min_age_ns) continue;
          const double ex = double(s.x) - p.x, ey = double(s.y) - p.y, e2 = ex * ex + ey * ey;
          if (e2 <= best2) {
            best2 = e2;
            revisit = true;
          }
        }
      }
    }
    ++out.points;
    if (revisit) distances.push_back(std::sqrt(best2));
    std::vector<Seen>& here = grid[{cx, cy}];
    if (here.size() < 64) here.push_back({p.x, p.y, stamp});  // the earliest passes of each cell
  }
  out.revisit_points = distances.size();
  if (!distances.empty()) {
    std::sort(distances.begin(), distances.end());
    out.median_m = distances[distances.size() / 2];
    out.p90_m = distances[std::min(distances.size() - 1, distances.size() * 9 / 10)];
  }
  return out;
}

void measure_errors(const Dataset& d, ErrorStats& pose_m, ErrorStats& pose_deg, ErrorStats& point_m) {
  if (!has_truth(d)) return;
  std::vector<double> t, r, p;
  t.reserve(d.scans.size());
  r.reserve(d.scans.size());
  for (const ScanRecord& s : d.scans) {
    t.push_back(std::hypot(s.pose.x_m - s.true_pose.x_m, s.pose.y_m - s.true_pose.y_m));
    r.push_back(std::abs(rad_to_deg(normalize_angle(s.pose.theta_rad - s.true_pose.theta_rad))));
  }
  p.reserve(d.points.size());
  for (const LabelledPoint& q : d.points) {
    if (q.is_ghost() || q.label == PointClass::none) continue;
    p.push_back(std::sqrt(double(q.x - q.tx) * double(q.x - q.tx) + double(q.y - q.ty) * double(q.y - q.ty) +
                          double(q.z - q.tz) * double(q.z - q.tz)));
  }
  pose_m = stats_of(t);
  pose_deg = stats_of(r);
  point_m = stats_of(p);
}

RegistrationReport register_dataset(Dataset& d, const TrackerOptions& tracker_options, const DatasetRegistrationOptions& options) {
  RegistrationReport report;
  report.enabled = true;
  report.have_truth = has_truth(d);
  measure_errors(d, report.pose_m_before, report.pose_deg_before, report.point_m_before);
  report.consistency_before = revisit_consistency(d);

  // Points by scan, scans in time order (as prepare_dataset orders them).
  std::map<std::pair<std::uint8_t, std::uint32_t>, std::vector<std::size_t>> by_scan;
  for (std::size_t i = 0; i < d.points.size(); ++i) by_scan[{d.points[i].robot, d.points[i].scan}].push_back(i);
  std::vector<std::size_t> order(d.scans.size());
  for (std::size_t i = 0; i < order.size(); ++i) order[i] = i;
  std::stable_sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) {
    return std::tie(d.scans[a].stamp_ns, d.scans[a].robot, d.scans[a].scan) < std::tie(d.scans[b].stamp_ns, d.scans[b].robot, d.scans[b].scan);
  });
  // Odometry in time order: fed to the tracker (corrected) up to each scan, and corrected itself.
  std::vector<std::size_t> odom(d.odom.size());
  for (std::size_t i = 0; i < odom.size(); ++i) odom[i] = i;
  std::stable_sort(odom.begin(), odom.end(), [&](std::size_t a, std::size_t b) {
    return std::tie(d.odom[a].stamp_ns, d.odom[a].robot) < std::tie(d.odom[b].stamp_ns, d.odom[b].robot);
  });

  // Horizontal 2-D lasers (an imported CARMEN log): every point at the mount's height, walls seen
  // edge-on (SurfaceOptions::planar_scans).
  registration::RegistrationOptions ro = options.registration;
  bool planar = !d.robots.empty();
  for (const DatasetRobot& r : d.robots) planar = planar && r.mount_rpy_rad[0] == 0.0 && r.mount_rpy_rad[1] == 0.0;
  if (planar) ro.surface.planar_scans = true;
  registration::Registration reg{ro};
  TeamTracker tracker{tracker_options};
  std::map<std::uint8_t, Pose2> current;  // each robot's correction so far
  std::size_t next_odom = 0;
  std::vector<Vec3> pts;
  std::vector<std::uint8_t> usable;
  std::vector<MapPoint> map_points;
  for (std::size_t si : order) {
    ScanRecord& s = d.scans[si];
    while (next_odom < odom.size() && d.odom[odom[next_odom]].stamp_ns <= s.stamp_ns) {
      TrajectorySample& o = d.odom[odom[next_odom++]];
      o.pose = current[o.robot] * o.pose;
      tracker.add_pose(o.robot, o.stamp_ns, o.pose, o.v_mps);
    }
    const TeamState team = tracker.predict(s.stamp_ns);
    std::vector<BodyBox> boxes;
    for (const RobotEstimate& e : team.robots)
      if (e.valid && e.robot != s.robot) boxes.push_back(body_box(e, options.body));
    const Pose2 c = current[s.robot];
    const auto it = by_scan.find({s.robot, s.scan});
    pts.clear();
    usable.clear();
    if (it != by_scan.end()) {
      for (std::size_t i : it->second) {
        const LabelledPoint& p = d.points[i];
        pts.push_back({p.x, p.y, p.z});
        bool ok = (p.flags & (point_flags::kInvalid | point_flags::kDirectionFiltered)) == 0;
        if (ok && !boxes.empty()) {
          const Vec3 q = registration::corrected(c, pts.back());
          const MapPoint mp{static_cast<float>(q.x), static_cast<float>(q.y), static_cast<float>(q.z)};
          for (BodyBox& b : boxes) {
            b.sensor_m = registration::corrected(c, s.origin);
            if (box_contains(b, mp, 0.0)) {
              ok = false;
              break;
            }
          }
        }
        if (!ok) ++report.masked_points;
        usable.push_back(ok ? 1 : 0);
      }
    }
    const Pose2 corr = reg.add_scan(s.robot, s.stamp_ns, s.pose, pts, usable).map_from_odom;
    current[s.robot] = corr;
    // The scan as the fused map gets it: corrected points, pose and origin.
    if (it != by_scan.end()) {
      for (std::size_t k = 0; k < it->second.size(); ++k) {
        LabelledPoint& p = d.points[it->second[k]];
        const Vec3 q = registration::corrected(corr, pts[k]);
        p.x = static_cast<float>(q.x);
        p.y = static_cast<float>(q.y);
      }
    }
    s.pose = corr * s.pose;
    s.origin = registration::corrected(corr, s.origin);
  }
  while (next_odom < odom.size()) {
    TrajectorySample& o = d.odom[odom[next_odom++]];
    o.pose = current[o.robot] * o.pose;
  }
  for (const DatasetRobot& r : d.robots)
    if (const registration::RobotCorrection* c = reg.correction(r.id)) report.robots.push_back(*c);
  measure_errors(d, report.pose_m_after, report.pose_deg_after, report.point_m_after);
  report.consistency_after = revisit_consistency(d);
  return report;
}

}  // namespace teamscan::mapping
