// Test fixture: gives one robot of a data set a drifting odometry, so the registration has something to
// correct. Its poses, scan origins and points move from the truth by a growing (x, y, yaw) per second
// of stamp (1.2 cm/s, −0.8 cm/s, 0.14°/s) about (3, 3) m, the centre of a 6 m synthetic survey room.
// Used by station_fusion_test (the core's identity with the registration on, the correction's loop to
// the robot).
#pragma once

#include <cstdint>
#include <map>

#include "common/dataset/dataset.hpp"
#include "common/pose.hpp"

namespace teamscan::test {

// The drift at `stamp_ns` after the survey's start (`start_ns`): odometry-map from true map.
inline Pose2 odometry_drift(std::int64_t stamp_ns, std::int64_t start_ns = 0) {
  const double t = static_cast<double>(stamp_ns - start_ns) * 1e-9;
  const Pose2 about{3.0, 3.0, 0.0};
  return about * Pose2{0.012 * t, -0.008 * t, 0.0025 * t} * about.inverse();
}

// Applies odometry_drift to `robot`'s poses, scan origins and points in `d`.
inline void add_odometry_drift(Dataset& d, std::uint8_t robot, std::int64_t start_ns = 0) {
  std::map<std::uint32_t, std::int64_t> stamp_of;
  for (ScanRecord& r : d.scans) {
    if (r.robot != robot) continue;
    stamp_of[r.scan] = r.stamp_ns;
    const Pose2 m = odometry_drift(r.stamp_ns, start_ns);
    r.pose = m * r.pose;
    const Vec2 o2 = m.apply({r.origin.x, r.origin.y});
    r.origin = {o2.x, o2.y, r.origin.z};
  }
  for (LabelledPoint& p : d.points) {
    if (p.robot != robot) continue;
    const Vec2 q = odometry_drift(stamp_of[p.scan], start_ns).apply({p.x, p.y});
    p.x = static_cast<float>(q.x);
    p.y = static_cast<float>(q.y);
  }
  for (TrajectorySample& s : d.odom)
    if (s.robot == robot) s.pose = odometry_drift(s.stamp_ns, start_ns) * s.pose;
}

}  // namespace teamscan::test
