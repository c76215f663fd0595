// `teamscan export SESSION --format mcap`: a ground station's session folder (scans.bin, poses.csv,
// status.csv, fused.pcd) as one MCAP file of ROS 2 messages (CDR, ros2msg schemas) that Foxglove opens:
// every stored scan, pose and status sample at its receive time, each robot's Kalman track after each
// pose (the team state), the REP-105 frame tree and the final fused model. Frames: map -> robotN/odom (the correction
// each scan carried) -> robotN/base_link (odometry) -> robotN/laser (the mount, on /tf_static, from the robots'
// configs).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "common/mcap/writer.hpp"
#include "common/result.hpp"

namespace teamscan::mcap_export {

struct SessionExportOptions {
  // Onboard configs (teamscan-onboard TOML) whose [mount] gives robotN/base_link -> robotN/laser; a
  // robot without one has no laser frame in the export.
  std::vector<std::string> robot_configs;
  std::string model_file = "fused.pcd";  // the fused model in the session folder (absent: no model message)
  mcap::WriterOptions writer;
};

struct SessionExportSummary {
  std::uint64_t scans = 0;          // /robotN/scan messages: every intact scans.bin record not refused at receipt
  std::uint64_t poses = 0;          // /robotN/odom messages: every poses.csv line not refused at receipt
  std::uint64_t statuses = 0;       // /robotN/status messages: every status.csv line
  std::uint64_t tracks = 0;         // /robotN/track messages: the Kalman track after each pose (team state)
  std::uint64_t tf_messages = 0;    // /tf: one per pose (map -> odom, odom -> base_link)
  std::uint64_t laser_frames = 0;   // transforms on /tf_static
  std::uint64_t model_points = 0;   // points of the /teamscan/map_cloud message (0: no model)
  std::uint64_t refused_scans = 0;  // stored but marked refused at receipt: not exported
  std::uint64_t refused_poses = 0;
  std::uint64_t damaged_scan_records = 0;  // bad CRC or length in scans.bin: skipped
  std::uint64_t bad_lines = 0;             // unparseable lines of poses.csv or status.csv: skipped
  bool scans_torn_tail = false;            // scans.bin ends inside a record (a crash mid-write)
  std::uint64_t messages = 0;
  std::uint32_t chunks = 0;
  std::uint64_t bytes = 0;
};

// Writes `out_path`. On failure (not a session folder, scans.bin without a teamscan header, a config or
// the model that cannot be read, the output not writable) `message` says what and where, and no output
// file is left behind. Damaged records inside the files are skipped and counted, not fatal.
[[nodiscard]] Result<SessionExportSummary> export_session_mcap(const std::string& session_dir,
                                                               const std::string& out_path,
                                                               const SessionExportOptions& options,
                                                               std::string& message);

}  // namespace teamscan::mcap_export
