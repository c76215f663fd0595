// The labelled data set (DESIGN.md "Files"): a folder with dataset.toml, points.pcd, scans.csv,
// truth.csv and odom.csv. Written by `teamscan sim`, read by `teamscan eval`, `render`, `export`.
// The full format (every field, unit and column) is documented in docs/formats.md.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "common/point_flags.hpp"
#include "common/pose.hpp"
#include "common/result.hpp"

namespace teamscan {

// What a beam hit (simulator ground truth). Stored as the PCD field `label`.
enum class PointClass : std::uint8_t { none = 0, floor = 1, wall = 2, ceiling = 3, furniture = 4, robot = 5 };
[[nodiscard]] const char* to_string(PointClass c);

// One beam that produced a 3-D point. Map frame, metres.
struct LabelledPoint {
  float x = 0, y = 0, z = 0;         // measured point (geometry from the captured bytes + odometry pose)
  std::uint8_t robot = 0;            // robot id 1..32 that measured it
  std::uint32_t scan = 0;            // that robot's scan sequence number (from 0)
  std::uint16_t beam = 0;            // beam index within the scan
  PointClass label = PointClass::none;
  std::uint8_t hit_robot = 0;        // id of the robot that was hit when label == robot (a ghost), else 0
  std::uint16_t flags = 0;           // point_flags (common/point_flags.hpp)
  float tx = 0, ty = 0, tz = 0;      // true hit point (simulator truth)
  [[nodiscard]] bool is_ghost() const { return label == PointClass::robot; }
};

struct ScanRecord {
  std::uint8_t robot = 0;
  std::uint32_t scan = 0;
  std::int64_t stamp_ns = 0;         // end of the sweep (DESIGN.md)
  std::uint16_t beams = 0;           // beams in the telegram
  std::uint16_t points = 0;          // beams that produced a point
  Vec3 origin;                       // sensor origin in the map frame at the stamp (odometry pose)
  Pose2 pose;                        // odometry pose (map frame) at the stamp
  Pose2 true_pose;                   // true pose at the stamp
  // The scan's stamp exactly as its source wrote it (an imported log's: CARMEN's ipc_timestamp), µs
  // since the Unix epoch; 0 = none (stamp_ns is the source's). Stored in source_stamps.csv.
  std::int64_t source_stamp_us = 0;
};

struct TrajectorySample {
  std::uint8_t robot = 0;
  std::int64_t stamp_ns = 0;
  Pose2 pose;                        // map frame
  double v_mps = 0;                  // forward velocity
  double w_radps = 0;                // yaw rate
};

struct DatasetRobot {
  std::uint8_t id = 0;
  std::string name;                  // e.g. "robot1"
  std::string role;                  // "down-laser" | "up-laser" | free text
  std::string subclass;              // ARCOS subclass: "p3at" | "p3at-sh"
  double mount_xyz_m[3] = {0, 0, 0}; // laser mount in the robot frame
  double mount_rpy_rad[3] = {0, 0, 0};
  std::uint16_t fov_deg = 180;
  std::uint16_t resolution_cdeg = 100;
  std::uint32_t lms_baud = 500000;
  Pose2 registration;                // map_from_odom: where the robot's odometry frame sits in the map
  double footprint_m[2] = {0.626, 0.505};  // length, width
  double height_m = 0.5;
};

struct Dataset {
  std::string scenario;              // scenario name
  std::uint64_t seed = 0;
  double duration_s = 0;
  double room_m[3] = {0, 0, 0};      // room size x, y, z
  std::vector<DatasetRobot> robots;
  std::vector<LabelledPoint> points;
  std::vector<ScanRecord> scans;
  std::vector<TrajectorySample> truth;
  std::vector<TrajectorySample> odom;
};

// Writes every file of the data set into `dir` (created if missing). Deterministic bytes.
[[nodiscard]] Status write_dataset(const std::string& dir, const Dataset& dataset);
// Reads a data set folder; a missing or malformed file gives an Error naming it.
[[nodiscard]] Result<Dataset> read_dataset(const std::string& dir);

}  // namespace teamscan
