// `teamscan import carmen FILE.clf --out DIR`: a CARMEN log (one robot, a horizontal laser, real
// odometry; FLASER, ROBOTLASER1 and ODOM lines) as a data set without truth (common/dataset/carmen.hpp)
// for `eval` and registration; every scan keeps its exact source stamp (source_stamps.csv).
#include <cstdio>
#include <memory>
#include <string>

#include "common/dataset/carmen.hpp"
#include "common/dataset/log_text.hpp"
#include "tools/teamscan/subcommand.hpp"

namespace teamscan::tool {
namespace {

struct ImportArgs {
  std::string format;
  std::string file;
  std::string out;
  CarmenImportOptions options;
};

int run_import(const ImportArgs& a) {
  const Result<std::string> text = read_log_text(a.file);
  if (!text) {
    std::fprintf(stderr, "teamscan import: cannot read %s: %s\n", a.file.c_str(), text.error().what);
    return 1;
  }
  const CarmenLog log = parse_carmen(text.value());
  std::fprintf(stderr, "teamscan import: %s: %llu lines, %zu laser (FLASER, ROBOTLASER1), %zu ODOM, %llu other messages, %llu malformed%s%s\n",
               a.file.c_str(), static_cast<unsigned long long>(log.lines), log.lasers.size(), log.odom.size(),
               static_cast<unsigned long long>(log.other_messages), static_cast<unsigned long long>(log.malformed),
               log.first_error.empty() ? "" : " (first: ", log.first_error.empty() ? "" : (log.first_error + ")").c_str());
  ImportArgs b = a;
  if (b.options.name == "carmen") {
    const std::size_t slash = a.file.find_last_of('/');
    b.options.name = a.file.substr(slash == std::string::npos ? 0 : slash + 1);
  }
  Result<Dataset> d = carmen_to_dataset(log, b.options);
  if (!d) {
    std::fprintf(stderr, "teamscan import: %s: %s\n", a.file.c_str(), d.error().what);
    return 1;
  }
  if (Status s = write_dataset(a.out, d.value()); !s) {
    std::fprintf(stderr, "teamscan import: %s: %s\n", a.out.c_str(), s.error().what);
    return 1;
  }
  std::printf("wrote %s: %zu scans, %zu points, %zu odometry samples, %.1f s (no truth)\n", a.out.c_str(), d.value().scans.size(),
              d.value().points.size(), d.value().odom.size(), d.value().duration_s);
  return 0;
}

const SubcommandRegistration kImport{{"import", "Turn a recorded log into a data set without truth (carmen)", [](CLI::App& app) {
  auto a = std::make_shared<ImportArgs>();
  app.add_option("FORMAT", a->format, "carmen: CARMEN .clf/.log (FLASER or ROBOTLASER1, and ODOM lines)")->required()->check(CLI::IsMember({"carmen"}));
  app.add_option("FILE", a->file, "The log file (plain text or .xz)")->required()->check(CLI::ExistingFile);
  app.add_option("--out", a->out, "Output data set folder")->required();
  app.add_option("--mount-height", a->options.mount_height_m, "Laser height above the floor (m)")->capture_default_str();
  app.add_option("--max-range", a->options.max_range_m, "Ranges at or beyond this are no return (m)")->capture_default_str();
  app.add_option("--name", a->options.name, "Data set name (default: the file name)");
  app.add_flag("--flaser-step-fov-over-n", a->options.flaser_step_is_fov_over_n,
               "FLASER beams 180°/n apart from -90° (default: 180°/(n-1), the n beams span the field end to end)");
  return [a] { return run_import(*a); };
}}};

}  // namespace
}  // namespace teamscan::tool
