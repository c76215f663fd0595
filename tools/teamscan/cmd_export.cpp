// `teamscan export DIR --format dynamicmap --out DIR2`: writes a labelled data set in the KTH
// DynamicMap benchmark layout (ANCHORS.md §1.1) so that benchmark's tools run on our data.
// `teamscan export SESSION --format mcap --out F.mcap`: a ground station's session as an MCAP file of
// ROS 2 messages that Foxglove opens (tools/mcap_export, docs/formats.md "MCAP export").
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include "common/dataset/dataset.hpp"
#include "groundstation/mapping/dynamicmap_export.hpp"
#include "tools/mcap_export/session_mcap.hpp"
#include "tools/teamscan/subcommand.hpp"

namespace teamscan::tool {
namespace {

struct ExportArgs {
  std::string dir;
  std::string format = "dynamicmap";
  std::string out;
  std::vector<std::string> robot_configs;
};

std::string describe(const Error& e) {
  std::string s = e.what;
  if (e.detail != 0) s += " (line " + std::to_string(e.detail) + ")";
  return s;
}


int run_mcap_export(const ExportArgs& a) {
  mcap_export::SessionExportOptions options;
  options.robot_configs = a.robot_configs;
  std::string message;
  auto summary = mcap_export::export_session_mcap(a.dir, a.out, options, message);
  if (!summary) {
    std::fprintf(stderr, "teamscan export: %s\n", message.c_str());
    return 1;
  }
  const mcap_export::SessionExportSummary& s = summary.value();
  std::printf("wrote %s: %llu scans, %llu poses, %llu tracks, %llu status samples, %llu /tf, %llu laser frames on "
              "/tf_static, fused model %llu points; %llu messages in %u chunks, %llu bytes\n",
              a.out.c_str(), static_cast<unsigned long long>(s.scans), static_cast<unsigned long long>(s.poses),
              static_cast<unsigned long long>(s.tracks), static_cast<unsigned long long>(s.statuses),
              static_cast<unsigned long long>(s.tf_messages),
              static_cast<unsigned long long>(s.laser_frames), static_cast<unsigned long long>(s.model_points),
              static_cast<unsigned long long>(s.messages), s.chunks, static_cast<unsigned long long>(s.bytes));
  if (s.refused_scans + s.refused_poses > 0) {
    std::printf("not exported: %llu scans and %llu poses the station refused at receipt (rejected.csv)\n",
                static_cast<unsigned long long>(s.refused_scans), static_cast<unsigned long long>(s.refused_poses));
  }
  if (s.damaged_scan_records + s.bad_lines > 0 || s.scans_torn_tail) {
    std::fprintf(stderr, "teamscan export: warning: skipped %llu damaged scans.bin records and %llu unreadable CSV lines%s\n",
                 static_cast<unsigned long long>(s.damaged_scan_records), static_cast<unsigned long long>(s.bad_lines),
                 s.scans_torn_tail ? "; scans.bin ends inside a record" : "");
  }
  if (s.laser_frames == 0) {
    std::fprintf(stderr, "teamscan export: note: no robotN/laser frames (give each robot's onboard config with --robot-config)\n");
  }
  return 0;
}

int run_export(const ExportArgs& a) {
  if (a.format == "mcap") return run_mcap_export(a);
  Result<Dataset> dataset = read_dataset(a.dir);
  if (!dataset) {
    std::fprintf(stderr, "teamscan export: %s: %s\n", a.dir.c_str(), describe(dataset.error()).c_str());
    return 1;
  }
  auto summary = mapping::export_dynamicmap(dataset.value(), a.out);
  if (!summary) {
    std::fprintf(stderr, "teamscan export: %s: %s\n", a.out.c_str(), summary.error().what);
    return 1;
  }
  std::printf("wrote %llu frames (%s/pcd/NNNNNN.pcd) and %s/gt_cloud.pcd: %llu points, %llu dynamic (ghost)\n",
              static_cast<unsigned long long>(summary.value().frames), a.out.c_str(), a.out.c_str(),
              static_cast<unsigned long long>(summary.value().points),
              static_cast<unsigned long long>(summary.value().dynamic_points));
  return 0;
}

const SubcommandRegistration kExport{{"export", "Export a labelled data set or a ground-station session to another tool's format", [](CLI::App& app) {
  auto a = std::make_shared<ExportArgs>();
  app.add_option("DIR", a->dir, "Data set folder written by `teamscan sim` (dynamicmap), or a ground station's session folder (mcap)")
      ->required();
  app.add_option("--format", a->format,
                 "dynamicmap: KTH DynamicMap benchmark (pcd/NNNNNN.pcd per scan in the world frame with the sensor "
                 "pose as VIEWPOINT; gt_cloud.pcd with intensity 0 static / 1 dynamic); mcap: the session's scans, poses, "
                 "tracks, status, frame tree and fused model as ROS 2 messages in one MCAP file (Foxglove)")
      ->check(CLI::IsMember({"dynamicmap", "mcap"}))
      ->capture_default_str();
  app.add_option("--out", a->out, "Output folder (dynamicmap) or file (mcap)")->required();
  app.add_option("--robot-config", a->robot_configs,
                 "mcap: a robot's teamscan-onboard config, whose [mount] places robotN/laser on /tf_static (repeat per robot)");
  return [a] { return run_export(*a); };
}}};

}  // namespace
}  // namespace teamscan::tool
