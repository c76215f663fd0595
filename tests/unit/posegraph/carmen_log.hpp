// A real CARMEN log of tests/data/real (the Intel Research Lab's intel.clf.xz, MIT CSAIL's
// mit-csail.clf.xz) as PlanarSlam takes it: each scan's stamps, odometry and returns in the robot frame,
// the beams placed as `teamscan import carmen` places them. Shared by posegraph_test and
// posegraph_intel_bench.
#pragma once

#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

#include "common/dataset/carmen.hpp"
#include "common/dataset/log_text.hpp"
#include "common/pose.hpp"
#include "groundstation/posegraph/slam.hpp"
#include "groundstation/trajectory/relations.hpp"
#include "tests/support/real_data.hpp"

namespace teamscan::posegraph::test {

struct CarmenLogScans {
  std::vector<std::int64_t> stamps_us;      // the source's (they step back)
  std::vector<std::int64_t> processing_ns;  // as `import carmen` processes them (carmen_processing_clock)
  std::vector<Pose2> odometry;
  std::vector<std::vector<Vec2>> points;
};

// How FLASER beams are placed: end to end over 180° (as `import carmen` by default), 180°/n apart from
// −90° (`--flaser-step-fov-over-n`), or 180°/n apart centred on the robot's heading.
enum class FlaserBeams { end_to_end, fov_over_n, fov_over_n_centred };

inline CarmenLogScans carmen_log(const std::string& file, std::size_t max_scans, FlaserBeams beams) {
  CarmenLogScans log;
  const Result<std::string> text = read_log_text(teamscan::test::real_data_path(file));
  if (!text) return log;
  const CarmenLog carmen = parse_carmen(text.value());
  const CarmenProcessingClock clock = carmen_processing_clock(carmen);
  for (std::size_t s = 0; s < carmen.lasers.size() && s < max_scans; ++s) {
    const CarmenLaser& l = carmen.lasers[s];
    // As `teamscan import carmen` places them: FLASER beams span 180° end to end; ROBOTLASER1 its own.
    const std::size_t n = l.ranges_m.size();
    const bool flaser = l.angle_step_rad == 0.0;
    const double nd = static_cast<double>(n);
    double start = l.start_angle_rad, step = l.angle_step_rad;
    if (flaser) {
      step = beams == FlaserBeams::end_to_end ? (n > 1 ? kPi / (nd - 1.0) : 0.0) : kPi / nd;
      start = beams == FlaserBeams::fov_over_n_centred ? -0.5 * step * (nd - 1.0) : -kPi / 2;
    }
    std::vector<Vec2> pts;
    for (std::size_t i = 0; i < n; ++i) {
      const double a = start + step * static_cast<double>(i), r = l.ranges_m[i];
      if (r >= 0.05 && r < 50.0) pts.push_back(l.robot_from_laser.apply({r * std::cos(a), r * std::sin(a)}));
    }
    log.stamps_us.push_back(l.stamp_us);
    log.processing_ns.push_back((clock.laser_us[s] - clock.first_us) * 1000);
    log.odometry.push_back(l.pose);
    log.points.push_back(std::move(pts));
  }
  return log;
}

inline CarmenLogScans intel_log(std::size_t max_scans, FlaserBeams beams = FlaserBeams::end_to_end) {
  return carmen_log("intel.clf.xz", max_scans, beams);
}

// PlanarSlam over the log's scans (one robot, the import's processing stamps): every scan's pose after
// the last optimisation.
inline std::vector<Pose2> slam_poses(const CarmenLogScans& log, const SlamOptions& options, SlamStats* stats = nullptr) {
  PlanarSlam slam(options);
  std::vector<std::size_t> nodes;
  for (std::size_t i = 0; i < log.points.size(); ++i) nodes.push_back(slam.add_scan(1, log.processing_ns[i], log.odometry[i], log.points[i]));
  slam.finish();
  std::vector<Pose2> poses;
  for (std::size_t n : nodes) poses.push_back(slam.pose(n));
  if (stats) *stats = slam.stats();
  return poses;
}

// A relations file of tests/data/real; empty if it cannot be read.
inline std::vector<trajectory::Relation> real_relations(const std::string& file) {
  const Result<std::string> text = read_log_text(teamscan::test::real_data_path(file));
  if (!text) return {};
  return trajectory::parse_relations(text.value()).relations;
}

// The relations metric of `poses` (one per scan of `log`, named by the scans' source stamps).
inline trajectory::RelationErrors relation_errors_of(const CarmenLogScans& log, const std::vector<Pose2>& poses,
                                                     const std::vector<trajectory::Relation>& relations) {
  std::vector<trajectory::StampedPose> t;
  for (std::size_t i = 0; i < poses.size() && i < log.stamps_us.size(); ++i) t.push_back({log.stamps_us[i], poses[i]});
  return trajectory::relation_errors(relations, t);
}

}  // namespace teamscan::posegraph::test
