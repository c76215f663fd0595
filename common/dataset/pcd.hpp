// PCD v0.7 reading and writing (the Point Cloud Library's format). The writer produces binary PCD that
// PCL reads; the reader accepts ascii, binary and binary_compressed (LZF) files with any fields.
#pragma once

#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "common/dataset/dataset.hpp"
#include "common/result.hpp"

namespace teamscan {

// A generic cloud as read from any PCD: xyz always (NaN points dropped), and every field as double.
struct PcdCloud {
  std::vector<std::string> fields;            // field names in file order
  std::vector<float> xyz;                     // 3 per point
  std::vector<std::vector<double>> columns;   // one per field, one value per point (first element of each field)
  std::uint64_t width = 0, height = 0;
  [[nodiscard]] std::size_t size() const { return xyz.size() / 3; }
  // Index of a field, or -1.
  [[nodiscard]] int field(const std::string& name) const;
};

[[nodiscard]] Result<PcdCloud> read_pcd(const std::string& path);

// The data set's points.pcd (fields x y z robot scan beam label hit_robot flags tx ty tz), binary.
[[nodiscard]] Status write_labelled_pcd(const std::string& path, std::span<const LabelledPoint> points);
[[nodiscard]] Result<std::vector<LabelledPoint>> read_labelled_pcd(const std::string& path);
// A plain xyz cloud (e.g. the fused model), binary PCD.
[[nodiscard]] Status write_xyz_pcd(const std::string& path, std::span<const float> xyz);

}  // namespace teamscan
