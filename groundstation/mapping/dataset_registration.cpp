// The registration's figures on a data set (dataset_registration.hpp).
#include "groundstation/mapping/dataset_registration.hpp"

#include <algorithm>
#include <cmath>
#include <map>
#include <tuple>

#include "common/units.hpp"

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

RevisitConsistency revisit_consistency(const Dataset& d, std::span<const MapPoint> placed, double min_age_s, double radius_m) {
  const bool moved = placed.size() == d.points.size();
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
    const float z = moved ? placed[i].z : d.points[i].z;
    if (it != stamp_of.end() && z >= 0.06f) order.push_back({it->second, i});
  }
  std::stable_sort(order.begin(), order.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
  std::map<std::pair<int, int>, std::vector<Seen>> grid;
  const double cell_m = radius_m / 2;
  auto cell = [&](double v) { return static_cast<int>(std::floor(v / cell_m)); };
  const auto min_age_ns = static_cast<std::int64_t>(min_age_s * 1e9);
  std::vector<double> distances;
  for (const auto& [stamp, i] : order) {
    const MapPoint p = moved ? placed[i] : MapPoint{d.points[i].x, d.points[i].y, d.points[i].z};
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
    if (revisit && best2 <= out.on_earlier_m * out.on_earlier_m) ++out.on_earlier_points;
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

void measure_errors(const Dataset& d, ErrorStats& pose_m, ErrorStats& pose_deg, ErrorStats& point_m,
                    std::span<const MapPoint> placed, std::span<const Pose2> scan_poses, std::span<const std::uint8_t> scan_decided) {
  if (!has_truth(d)) return;
  const bool moved_poses = scan_poses.size() == d.scans.size();
  const bool moved_points = placed.size() == d.points.size();
  std::vector<double> t, r, p;
  t.reserve(d.scans.size());
  r.reserve(d.scans.size());
  for (std::size_t i = 0; i < d.scans.size(); ++i) {
    const ScanRecord& s = d.scans[i];
    if (moved_poses && scan_decided.size() == d.scans.size() && !scan_decided[i]) continue;
    const Pose2& pose = moved_poses ? scan_poses[i] : s.pose;
    t.push_back(std::hypot(pose.x_m - s.true_pose.x_m, pose.y_m - s.true_pose.y_m));
    r.push_back(std::abs(rad_to_deg(normalize_angle(pose.theta_rad - s.true_pose.theta_rad))));
  }
  p.reserve(d.points.size());
  for (std::size_t i = 0; i < d.points.size(); ++i) {
    const LabelledPoint& q = d.points[i];
    if (q.is_ghost() || q.label == PointClass::none) continue;
    const double x = moved_points ? placed[i].x : q.x, y = moved_points ? placed[i].y : q.y, z = moved_points ? placed[i].z : q.z;
    p.push_back(std::sqrt((x - q.tx) * (x - q.tx) + (y - q.ty) * (y - q.ty) + (z - q.tz) * (z - q.tz)));
  }
  pose_m = stats_of(t);
  pose_deg = stats_of(r);
  point_m = stats_of(p);
}

}  // namespace teamscan::mapping
