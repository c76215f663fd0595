// PCD v0.7 reading and writing (the Point Cloud Library's format). The writer produces binary PCD that
// PCL reads; the reader accepts ascii, binary and binary_compressed (LZF) files with any fields.
// The format and every field of the data set's points.pcd are documented in docs/formats.md.
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
  double viewpoint[7] = {0, 0, 0, 1, 0, 0, 0};  // sensor pose from the header: tx ty tz qw qx qy qz
  [[nodiscard]] std::size_t size() const { return xyz.size() / 3; }
  // Index of a field, or -1.
  [[nodiscard]] int field(const std::string& name) const;
};

// One FIELDS entry of a PCD header with its SIZE, TYPE ('F', 'I' or 'U') and COUNT.
struct PcdField {
  std::string name;
  std::uint32_t size = 4;
  char type = 'F';
  std::uint32_t count = 1;
};

enum class PcdData : std::uint8_t { ascii, binary, binary_compressed };

// A parsed PCD header. `data_offset` is the byte offset of the first data byte (after the DATA line).
struct PcdHeader {
  std::vector<PcdField> fields;
  std::uint64_t width = 0, height = 0, points = 0;
  double viewpoint[7] = {0, 0, 0, 1, 0, 0, 0};  // tx ty tz qw qx qy qz
  PcdData data = PcdData::ascii;
  std::size_t data_offset = 0;
  [[nodiscard]] std::uint64_t point_size_bytes() const;  // sum of size*count
};

// Parses a header from the start of `bytes`. Errors carry the 1-based header line in `detail`.
[[nodiscard]] Result<PcdHeader> parse_pcd_header(std::span<const std::uint8_t> bytes);
// Parses a whole PCD held in memory (pure: no file, no clock). Errors: malformed header (detail = line),
// truncated data, size mismatch, bad compressed block (detail = byte offset or point index).
[[nodiscard]] Result<PcdCloud> parse_pcd(std::span<const std::uint8_t> bytes);
[[nodiscard]] Result<PcdCloud> read_pcd(const std::string& path);

// LZF decompression (liblzf format, as PCL's binary_compressed uses). Returns the number of bytes
// written, or an Error if the input is malformed or does not fit `out`.
[[nodiscard]] Result<std::size_t> lzf_decompress(std::span<const std::uint8_t> in, std::span<std::uint8_t> out);

// The data set's points.pcd (fields x y z robot scan beam label hit_robot flags tx ty tz), binary.
[[nodiscard]] Status write_labelled_pcd(const std::string& path, std::span<const LabelledPoint> points);
// The same bytes in memory (deterministic: a pure function of the points).
[[nodiscard]] std::vector<std::uint8_t> encode_labelled_pcd(std::span<const LabelledPoint> points);
// Reads points.pcd. The fast path is our own binary layout; any other PCD that has the twelve fields
// (any type, any DATA kind) is read through the generic reader.
[[nodiscard]] Result<std::vector<LabelledPoint>> read_labelled_pcd(const std::string& path);
[[nodiscard]] Result<std::vector<LabelledPoint>> parse_labelled_pcd(std::span<const std::uint8_t> bytes);
// A plain xyz cloud (e.g. the fused model), binary PCD.
[[nodiscard]] Status write_xyz_pcd(const std::string& path, std::span<const float> xyz);
[[nodiscard]] std::vector<std::uint8_t> encode_xyz_pcd(std::span<const float> xyz);

// A general PCD writer (e.g. a fused model with a `keep` field, one frame per file with the sensor pose
// in VIEWPOINT for the KTH DynamicMap benchmark layout). `fields`/`columns` of `cloud` are the data (x, y
// and z must be among them; `xyz` is not used); `layout` gives each field's TYPE and SIZE in the same
// order (empty = every field F 4). Integer values are rounded to nearest and must fit their type.
// `data` may be ascii or binary (binary_compressed writing is not offered: every reader takes binary).
[[nodiscard]] Result<std::vector<std::uint8_t>> encode_pcd(const PcdCloud& cloud, const std::vector<PcdField>& layout,
                                                           PcdData data = PcdData::binary);
[[nodiscard]] Status write_pcd(const std::string& path, const PcdCloud& cloud, const std::vector<PcdField>& layout,
                               PcdData data = PcdData::binary);

// Reads a whole file into memory; Error{"cannot open file", errno} on failure.
[[nodiscard]] Result<std::vector<std::uint8_t>> read_file_bytes(const std::string& path);

}  // namespace teamscan
