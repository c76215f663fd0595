// KTH DynamicMap benchmark export (ANCHORS.md §1.1 "Data format", §2.2 harness input).
#include "groundstation/mapping/dynamicmap_export.hpp"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <tuple>
#include <vector>

#include "common/error_message.hpp"

namespace teamscan::mapping {

Viewpoint scan_viewpoint(const ScanRecord& scan, const DatasetRobot* robot) {
  Pose3 robot_from_laser;
  if (robot) {
    robot_from_laser = Pose3::from_xyz_rpy(robot->mount_xyz_m[0], robot->mount_xyz_m[1], robot->mount_xyz_m[2],
                                           robot->mount_rpy_rad[0], robot->mount_rpy_rad[1], robot->mount_rpy_rad[2]);
  }
  const Pose3 map_from_laser = Pose3::from_pose2(scan.pose) * robot_from_laser;
  const auto& m = map_from_laser.rotation.m;
  // Rotation matrix → unit quaternion (Shepperd's method: branch on the largest diagonal term).
  Viewpoint v;
  const double trace = m[0][0] + m[1][1] + m[2][2];
  if (trace > 0) {
    const double s = 2.0 * std::sqrt(trace + 1.0);
    v.qw = 0.25 * s;
    v.qx = (m[2][1] - m[1][2]) / s;
    v.qy = (m[0][2] - m[2][0]) / s;
    v.qz = (m[1][0] - m[0][1]) / s;
  } else if (m[0][0] > m[1][1] && m[0][0] > m[2][2]) {
    const double s = 2.0 * std::sqrt(1.0 + m[0][0] - m[1][1] - m[2][2]);
    v.qw = (m[2][1] - m[1][2]) / s;
    v.qx = 0.25 * s;
    v.qy = (m[0][1] + m[1][0]) / s;
    v.qz = (m[0][2] + m[2][0]) / s;
  } else if (m[1][1] > m[2][2]) {
    const double s = 2.0 * std::sqrt(1.0 + m[1][1] - m[0][0] - m[2][2]);
    v.qw = (m[0][2] - m[2][0]) / s;
    v.qx = (m[0][1] + m[1][0]) / s;
    v.qy = 0.25 * s;
    v.qz = (m[1][2] + m[2][1]) / s;
  } else {
    const double s = 2.0 * std::sqrt(1.0 + m[2][2] - m[0][0] - m[1][1]);
    v.qw = (m[1][0] - m[0][1]) / s;
    v.qx = (m[0][2] + m[2][0]) / s;
    v.qy = (m[1][2] + m[2][1]) / s;
    v.qz = 0.25 * s;
  }
  if (v.qw < 0) {  // one canonical sign
    v.qw = -v.qw;
    v.qx = -v.qx;
    v.qy = -v.qy;
    v.qz = -v.qz;
  }
  // The recorded sensor origin is the translation (it already includes the mount).
  v.tx = scan.origin.x;
  v.ty = scan.origin.y;
  v.tz = scan.origin.z;
  return v;
}

Status write_pcd_xyzi(const std::string& path, std::span<const MapPoint> points, std::span<const float> intensity,
                      const Viewpoint& vp) {
  const bool with_i = !intensity.empty();
  if (with_i && intensity.size() != points.size()) return Error{"intensity count differs from point count"};
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  if (!out) return make_error(path + ": cannot open for writing", errno);
  char header[1024];
  std::snprintf(header, sizeof header,
                "# .PCD v0.7 - Point Cloud Data file format\nVERSION 0.7\nFIELDS x y z%s\nSIZE 4 4 4%s\n"
                "TYPE F F F%s\nCOUNT 1 1 1%s\nWIDTH %zu\nHEIGHT 1\nVIEWPOINT %.9g %.9g %.9g %.9g %.9g %.9g %.9g\n"
                "POINTS %zu\nDATA binary\n",
                with_i ? " intensity" : "", with_i ? " 4" : "", with_i ? " F" : "", with_i ? " 1" : "", points.size(),
                vp.tx, vp.ty, vp.tz, vp.qw, vp.qx, vp.qy, vp.qz, points.size());
  out << header;
  std::vector<float> row;
  row.reserve(points.size() * (with_i ? 4 : 3));
  for (std::size_t i = 0; i < points.size(); ++i) {
    row.push_back(points[i].x);
    row.push_back(points[i].y);
    row.push_back(points[i].z);
    if (with_i) row.push_back(intensity[i]);
  }
  out.write(reinterpret_cast<const char*>(row.data()), static_cast<std::streamsize>(row.size() * sizeof(float)));
  if (!out) return make_error(path + ": write failed", errno);
  return ok_status();
}

Result<ExportSummary> export_dynamicmap(const Dataset& dataset, const std::string& out_dir) {
  std::error_code ec;
  std::filesystem::create_directories(std::filesystem::path(out_dir) / "pcd", ec);
  if (ec) return make_error(out_dir + "/pcd: cannot create the folder", ec.value());

  std::map<std::pair<std::uint8_t, std::uint32_t>, std::vector<std::size_t>> by_scan;
  for (std::size_t i = 0; i < dataset.points.size(); ++i)
    by_scan[{dataset.points[i].robot, dataset.points[i].scan}].push_back(i);
  std::vector<const ScanRecord*> scans;
  for (const ScanRecord& s : dataset.scans) scans.push_back(&s);
  std::stable_sort(scans.begin(), scans.end(), [](const ScanRecord* a, const ScanRecord* b) {
    return std::tie(a->stamp_ns, a->robot, a->scan) < std::tie(b->stamp_ns, b->robot, b->scan);
  });

  ExportSummary summary;
  std::vector<MapPoint> frame;
  for (const ScanRecord* s : scans) {
    auto it = by_scan.find({s->robot, s->scan});
    if (it == by_scan.end() || it->second.empty()) continue;  // a scan without points is no frame
    const DatasetRobot* robot = nullptr;
    for (const DatasetRobot& r : dataset.robots)
      if (r.id == s->robot) robot = &r;
    frame.clear();
    for (std::size_t i : it->second) frame.push_back({dataset.points[i].x, dataset.points[i].y, dataset.points[i].z});
    char name[32];
    std::snprintf(name, sizeof name, "%06llu.pcd", static_cast<unsigned long long>(summary.frames));
    Status st = write_pcd_xyzi((std::filesystem::path(out_dir) / "pcd" / name).string(), frame, {}, scan_viewpoint(*s, robot));
    if (!st) return st.error();
    ++summary.frames;
  }

  std::vector<MapPoint> all;
  std::vector<float> label;
  all.reserve(dataset.points.size());
  label.reserve(dataset.points.size());
  for (const LabelledPoint& p : dataset.points) {
    all.push_back({p.x, p.y, p.z});
    label.push_back(p.is_ghost() ? 1.0f : 0.0f);  // benchmark: 0 static, 1 dynamic
    if (p.is_ghost()) ++summary.dynamic_points;
  }
  summary.points = all.size();
  Status st = write_pcd_xyzi((std::filesystem::path(out_dir) / "gt_cloud.pcd").string(), all, label, Viewpoint{});
  if (!st) return st.error();
  return summary;
}

}  // namespace teamscan::mapping
