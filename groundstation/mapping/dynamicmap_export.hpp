// Export of a labelled data set in the KTH DynamicMap benchmark layout (ANCHORS.md §1.1, §2.2):
// <out>/pcd/NNNNNN.pcd, one frame per scan in time order, points in the world (map) frame and the
// sensor pose in the VIEWPOINT header; <out>/gt_cloud.pcd with intensity 0 static / 1 dynamic (ghost).
#pragma once

#include <cstdint>
#include <span>
#include <string>

#include "common/dataset/dataset.hpp"
#include "common/result.hpp"
#include "groundstation/mapping/voxel_map.hpp"

namespace teamscan::mapping {

// Sensor pose for a VIEWPOINT line: translation and unit quaternion (w, x, y, z).
struct Viewpoint {
  double tx = 0, ty = 0, tz = 0;
  double qw = 1, qx = 0, qy = 0, qz = 0;
};

// The laser's pose in the map frame for a scan: robot pose (map frame) ∘ the robot's laser mount.
[[nodiscard]] Viewpoint scan_viewpoint(const ScanRecord& scan, const DatasetRobot* robot);

// Binary PCD v0.7 with float fields x y z (and intensity when `intensity` is not empty).
[[nodiscard]] Status write_pcd_xyzi(const std::string& path, std::span<const MapPoint> points,
                                    std::span<const float> intensity, const Viewpoint& viewpoint);

struct ExportSummary {
  std::uint64_t frames = 0;
  std::uint64_t points = 0;
  std::uint64_t dynamic_points = 0;
};

[[nodiscard]] Result<ExportSummary> export_dynamicmap(const Dataset& dataset, const std::string& out_dir);

}  // namespace teamscan::mapping
