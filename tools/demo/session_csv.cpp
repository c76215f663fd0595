// Session CSV files read by column name (session_csv.hpp).
#include "tools/demo/session_csv.hpp"

#include <charconv>
#include <fstream>
#include <iterator>
#include <sstream>

namespace teamscan::demo {
namespace {

std::vector<std::string> split(const std::string& line) {
  std::vector<std::string> f;
  std::size_t start = 0;
  for (;;) {
    const std::size_t comma = line.find(',', start);
    f.push_back(line.substr(start, comma == std::string::npos ? std::string::npos : comma - start));
    if (comma == std::string::npos) break;
    start = comma + 1;
  }
  if (!f.empty() && !f.back().empty() && f.back().back() == '\r') f.back().pop_back();
  return f;
}

}  // namespace

CsvTable CsvTable::parse(const std::string& text) {
  CsvTable t;
  std::istringstream in(text);
  bool have_header = false;
  for (std::string line; std::getline(in, line);) {
    if (line.empty() || line == "\r") continue;
    std::vector<std::string> f = split(line);
    if (!have_header) {
      t.header_ = std::move(f);
      have_header = true;
    } else if (f.size() != t.header_.size()) {
      ++t.bad_rows_;
    } else {
      t.rows_.push_back(std::move(f));
    }
  }
  return t;
}

Result<CsvTable> CsvTable::read(const std::string& path) {
  std::ifstream in(path);
  if (!in) return Error{"cannot open the CSV file"};
  std::stringstream ss;
  ss << in.rdbuf();
  return parse(ss.str());
}

std::optional<std::size_t> CsvTable::column(const std::string& name) const {
  for (std::size_t i = 0; i < header_.size(); ++i)
    if (header_[i] == name) return i;
  return std::nullopt;
}

bool CsvTable::has_columns(std::initializer_list<const char*> names) const {
  for (const char* n : names)
    if (!column(n)) return false;
  return true;
}

std::optional<std::int64_t> CsvTable::integer(std::size_t row, std::size_t col) const {
  const std::string& s = rows_[row][col];
  std::int64_t v = 0;
  const auto [end, ec] = std::from_chars(s.data(), s.data() + s.size(), v);
  if (ec != std::errc{} || end != s.data() + s.size() || s.empty()) return std::nullopt;
  return v;
}

std::optional<double> CsvTable::number(std::size_t row, std::size_t col) const {
  const std::string& s = rows_[row][col];
  double v = 0;
  const auto [end, ec] = std::from_chars(s.data(), s.data() + s.size(), v);
  if (ec != std::errc{} || end != s.data() + s.size() || s.empty()) return std::nullopt;
  return v;
}

namespace {

// The columns `names` of `t`, in order; N if all are there, else the index of the first one missing.
template <std::size_t N>
std::size_t columns(const CsvTable& t, const char* const (&names)[N], std::size_t (&out)[N]) {
  for (std::size_t k = 0; k < N; ++k) {
    const auto c = t.column(names[k]);
    if (!c) return k;
    out[k] = *c;
  }
  return N;
}

// Every field of row `r` at `cols` as an integer; false if one does not parse.
template <std::size_t N>
bool integers(const CsvTable& t, std::size_t r, const std::size_t (&cols)[N], std::int64_t (&out)[N]) {
  for (std::size_t k = 0; k < N; ++k) {
    const auto v = t.integer(r, cols[k]);
    if (!v) return false;
    out[k] = *v;
  }
  return true;
}

}  // namespace

Result<std::vector<StatusRow>> read_status_csv(const std::string& path, std::size_t* bad_rows) {
  Result<CsvTable> table = CsvTable::read(path);
  if (!table) return table.error();
  const CsvTable& t = table.value();
  static const char* const kNames[] = {"robot_id",          "stamp_ns",          "lms_state",           "scans_published",
                                       "lms_reopens",       "points_team_stale", "corrections_applied", "corrections_rejected",
                                       "ring_unconfirmed",  "shadow_ms",         "last_shadow_ms",      "backfill_total",
                                       "backfill_remaining"};
  // Error texts are static (common/result.hpp): one per column, the missing one named.
  static const char* const kMissing[] = {
      "status.csv lacks the column robot_id",        "status.csv lacks the column stamp_ns",
      "status.csv lacks the column lms_state",       "status.csv lacks the column scans_published",
      "status.csv lacks the column lms_reopens",     "status.csv lacks the column points_team_stale",
      "status.csv lacks the column corrections_applied", "status.csv lacks the column corrections_rejected",
      "status.csv lacks the column ring_unconfirmed", "status.csv lacks the column shadow_ms",
      "status.csv lacks the column last_shadow_ms",  "status.csv lacks the column backfill_total",
      "status.csv lacks the column backfill_remaining"};
  constexpr std::size_t kColumns = std::size(kNames);
  std::size_t cols[kColumns];
  if (const std::size_t m = columns(t, kNames, cols); m < kColumns) return Error{kMissing[m]};
  std::vector<StatusRow> out;
  std::size_t bad = t.bad_rows();
  for (std::size_t r = 0; r < t.rows(); ++r) {
    std::int64_t v[kColumns];
    if (!integers(t, r, cols, v)) {
      ++bad;
      continue;
    }
    const auto u32 = [&](std::size_t k) { return static_cast<std::uint32_t>(v[k]); };
    out.push_back({u32(0), v[1], static_cast<unsigned>(v[2]), u32(3), u32(4), u32(5), static_cast<std::uint64_t>(v[6]),
                   static_cast<std::uint64_t>(v[7]), u32(8), u32(9), u32(10), u32(11), u32(12)});
  }
  if (bad_rows) *bad_rows = bad;
  return out;
}

Result<std::vector<PoseRow>> read_poses_csv(const std::string& path, std::size_t* bad_rows) {
  Result<CsvTable> table = CsvTable::read(path);
  if (!table) return table.error();
  const CsvTable& t = table.value();
  static const char* const kNames[] = {"robot_id", "seq",     "stamp_ns", "x_mm", "y_mm", "yaw_urad", "vx_mmps",
                                       "vy_mmps",  "yaw_rate_mradps"};
  static const char* const kMissing[] = {
      "poses.csv lacks the column robot_id", "poses.csv lacks the column seq",     "poses.csv lacks the column stamp_ns",
      "poses.csv lacks the column x_mm",     "poses.csv lacks the column y_mm",    "poses.csv lacks the column yaw_urad",
      "poses.csv lacks the column vx_mmps",  "poses.csv lacks the column vy_mmps", "poses.csv lacks the column yaw_rate_mradps"};
  constexpr std::size_t kColumns = std::size(kNames);
  std::size_t cols[kColumns];
  if (const std::size_t m = columns(t, kNames, cols); m < kColumns) return Error{kMissing[m]};
  std::vector<PoseRow> out;
  std::size_t bad = t.bad_rows();
  for (std::size_t r = 0; r < t.rows(); ++r) {
    std::int64_t v[kColumns];
    if (!integers(t, r, cols, v)) {
      ++bad;
      continue;
    }
    out.push_back({static_cast<std::uint32_t>(v[0]), static_cast<std::uint32_t>(v[1]), v[2],
                   static_cast<std::int32_t>(v[3]), static_cast<std::int32_t>(v[4]), static_cast<std::int32_t>(v[5]),
                   static_cast<std::int32_t>(v[6]), static_cast<std::int32_t>(v[7]), static_cast<std::int32_t>(v[8])});
  }
  if (bad_rows) *bad_rows = bad;
  return out;
}

}  // namespace teamscan::demo
