// TUM trajectory text (tum.hpp).
#include "groundstation/trajectory/tum.hpp"

#include <charconv>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>

namespace teamscan::trajectory {
namespace {

std::string num(double v) {
  char buf[64];
  const auto r = std::to_chars(buf, buf + sizeof buf, v);
  return std::string(buf, r.ptr);
}

}  // namespace

std::int64_t scan_stamp_us(const ScanRecord& scan) {
  if (scan.source_stamp_us != 0) return scan.source_stamp_us;
  // Round half away from zero on the nanoseconds.
  return scan.stamp_ns >= 0 ? (scan.stamp_ns + 500) / 1000 : -((-scan.stamp_ns + 500) / 1000);
}

std::string tum_line(const StampedPose& p) {
  const std::int64_t whole = p.stamp_us / 1'000'000;
  const std::int64_t frac = p.stamp_us % 1'000'000;
  char stamp[48];
  if (p.stamp_us < 0)
    std::snprintf(stamp, sizeof stamp, "-%lld.%06lld", static_cast<long long>(-whole), static_cast<long long>(-frac));
  else
    std::snprintf(stamp, sizeof stamp, "%lld.%06lld", static_cast<long long>(whole), static_cast<long long>(frac));
  const double half = 0.5 * p.pose.theta_rad;
  return std::string(stamp) + ' ' + num(p.pose.x_m) + ' ' + num(p.pose.y_m) + " 0 0 0 " + num(std::sin(half)) + ' ' +
         num(std::cos(half)) + '\n';
}

std::string tum_text(const std::vector<StampedPose>& poses) {
  std::string s;
  for (const StampedPose& p : poses) s += tum_line(p);
  return s;
}

Status write_tum_per_robot(const std::string& dir, const Dataset& dataset, const std::vector<Pose2>& poses,
                           const std::vector<std::uint8_t>& decided) {
  if (poses.size() != dataset.scans.size()) return Error{"trajectory: one pose per scan needed"};
  std::map<std::uint8_t, std::vector<StampedPose>> by_robot;
  for (const DatasetRobot& r : dataset.robots) by_robot[r.id];
  for (std::size_t i = 0; i < dataset.scans.size(); ++i) {
    if (!decided.empty() && (i >= decided.size() || decided[i] == 0)) continue;
    by_robot[dataset.scans[i].robot].push_back({scan_stamp_us(dataset.scans[i]), poses[i]});
  }
  return write_tum_files(dir, by_robot);
}

Status write_tum_files(const std::string& dir, const std::map<std::uint8_t, std::vector<StampedPose>>& by_robot, const std::string& suffix) {
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  if (ec) return Error{"trajectory: cannot create the output folder", ec.value()};
  for (const auto& [robot, samples] : by_robot) {
    const std::string path = dir + "/robot" + std::to_string(robot) + suffix + ".tum";
    {
      std::ofstream out(path + ".tmp", std::ios::trunc | std::ios::binary);
      out << tum_text(samples);
      out.flush();
      if (!out) return Error{"trajectory: cannot write a robot<N>.tum file", errno};
    }
    std::filesystem::rename(path + ".tmp", path, ec);
    if (ec) return Error{"trajectory: cannot rename a robot<N>.tum file into place", ec.value()};
  }
  return ok_status();
}

TumAppender::~TumAppender() {
  for (std::FILE*& f : files_)
    if (f != nullptr) std::fclose(f);
}

bool TumAppender::add(std::uint8_t robot, const StampedPose& pose) {
  std::FILE*& f = files_[robot];
  if (f == nullptr) f = std::fopen((dir_ + "/robot" + std::to_string(robot) + ".tum").c_str(), "a");
  if (f == nullptr) {
    ++failures_;
    return false;
  }
  const std::string line = tum_line(pose);
  return std::fwrite(line.data(), 1, line.size(), f) == line.size();
}

void TumAppender::flush() {
  for (std::FILE* f : files_)
    if (f != nullptr) std::fflush(f);
}

}  // namespace teamscan::trajectory
