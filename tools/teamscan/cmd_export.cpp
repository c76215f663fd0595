// `teamscan export DIR --format dynamicmap --out DIR2`: writes a labelled data set in the KTH
// DynamicMap benchmark layout (ANCHORS.md §1.1) so that benchmark's tools run on our data.
#include <cstdio>
#include <memory>
#include <string>

#include "common/dataset/dataset.hpp"
#include "groundstation/mapping/dynamicmap_export.hpp"
#include "tools/teamscan/subcommand.hpp"

namespace teamscan::tool {
namespace {

struct ExportArgs {
  std::string dir;
  std::string format = "dynamicmap";
  std::string out;
};

std::string describe(const Error& e) {
  std::string s = e.what;
  if (e.detail != 0) s += " (line " + std::to_string(e.detail) + ")";
  return s;
}


int run_export(const ExportArgs& a) {
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

const SubcommandRegistration kExport{{"export", "Export a labelled data set to another tool's format", [](CLI::App& app) {
  auto a = std::make_shared<ExportArgs>();
  app.add_option("DIR", a->dir, "Data set folder written by `teamscan sim`")->required()->check(CLI::ExistingDirectory);
  app.add_option("--format", a->format,
                 "dynamicmap: KTH DynamicMap benchmark (pcd/NNNNNN.pcd per scan in the world frame with the sensor "
                 "pose as VIEWPOINT; gt_cloud.pcd with intensity 0 static / 1 dynamic)")
      ->check(CLI::IsMember({"dynamicmap"}))
      ->capture_default_str();
  app.add_option("--out", a->out, "Output folder")->required();
  return [a] { return run_export(*a); };
}}};

}  // namespace
}  // namespace teamscan::tool
