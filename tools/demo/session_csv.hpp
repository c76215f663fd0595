// The ground station's session CSV files (poses.csv, status.csv; docs/formats.md) read by column NAME:
// the header line names the columns, so a column added or moved never shifts what a reader gets.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "common/result.hpp"

namespace teamscan::demo {

class CsvTable {
 public:
  // Reads `path`: the first line is the header; blank lines are skipped; a row with another number of
  // fields than the header is counted in bad_rows() and dropped.
  [[nodiscard]] static Result<CsvTable> read(const std::string& path);
  [[nodiscard]] static CsvTable parse(const std::string& text);

  [[nodiscard]] const std::vector<std::string>& header() const { return header_; }
  [[nodiscard]] std::size_t rows() const { return rows_.size(); }
  [[nodiscard]] std::size_t bad_rows() const { return bad_rows_; }
  // The index of column `name`, or nullopt.
  [[nodiscard]] std::optional<std::size_t> column(const std::string& name) const;
  // True when every name is a column.
  [[nodiscard]] bool has_columns(std::initializer_list<const char*> names) const;
  [[nodiscard]] const std::string& text(std::size_t row, std::size_t col) const { return rows_[row][col]; }
  // The field as a number; nullopt if it does not parse.
  [[nodiscard]] std::optional<std::int64_t> integer(std::size_t row, std::size_t col) const;
  [[nodiscard]] std::optional<double> number(std::size_t row, std::size_t col) const;

 private:
  std::vector<std::string> header_;
  std::vector<std::vector<std::string>> rows_;
  std::size_t bad_rows_ = 0;
};

// One robot's status as stored in status.csv (the fields the demo reports).
struct StatusRow {
  std::uint32_t robot_id = 0;
  std::int64_t stamp_ns = 0;
  unsigned lms_state = 0;
  std::uint32_t scans_published = 0;
  std::uint32_t lms_reopens = 0;
  std::uint32_t points_team_stale = 0;
  std::uint64_t corrections_applied = 0;   // its own odometry corrections taken from teamscan/team
  std::uint64_t corrections_rejected = 0;  // … and refused (an absurd step)
  // Store and forward (docs/onboard.md "The ring"): as the robot reported them.
  std::uint32_t ring_unconfirmed = 0, shadow_ms = 0, last_shadow_ms = 0, backfill_total = 0, backfill_remaining = 0;
};

// One pose as stored in poses.csv (wire units).
struct PoseRow {
  std::uint32_t robot_id = 0;
  std::uint32_t seq = 0;
  std::int64_t stamp_ns = 0;
  std::int32_t x_mm = 0, y_mm = 0, yaw_urad = 0;
  std::int32_t vx_mmps = 0, vy_mmps = 0, yaw_rate_mradps = 0;
};

// The rows of status.csv / poses.csv; an error names the missing column. Rows whose fields do not
// parse are skipped and counted in `bad_rows`.
[[nodiscard]] Result<std::vector<StatusRow>> read_status_csv(const std::string& path, std::size_t* bad_rows = nullptr);
[[nodiscard]] Result<std::vector<PoseRow>> read_poses_csv(const std::string& path, std::size_t* bad_rows = nullptr);

}  // namespace teamscan::demo
