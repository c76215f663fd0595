// The labelled data set folder: dataset.toml (toml++ to read, written by hand for exact, stable text),
// points.pcd (pcd.cpp) and the CSV files scans.csv, truth.csv, odom.csv. Layout: docs/formats.md.
#include "common/dataset/dataset.hpp"

#include <cerrno>
#include <charconv>
#include <cstdio>
#include <filesystem>
#include <limits>
#include <string_view>

#include <toml++/toml.h>

#include "common/capacities.hpp"
#include "common/dataset/pcd.hpp"
#include "common/error_message.hpp"

namespace teamscan {

const char* to_string(PointClass c) {
  switch (c) {
    case PointClass::none: return "none";
    case PointClass::floor: return "floor";
    case PointClass::wall: return "wall";
    case PointClass::ceiling: return "ceiling";
    case PointClass::furniture: return "furniture";
    case PointClass::robot: return "robot";
  }
  return "invalid";
}

namespace {

constexpr const char* kScansHeader =
    "robot,scan,stamp_ns,beams,points,origin_x_m,origin_y_m,origin_z_m,odom_x_m,odom_y_m,odom_theta_rad,"
    "true_x_m,true_y_m,true_theta_rad";
constexpr const char* kTrajectoryHeader = "robot,stamp_ns,x_m,y_m,theta_rad,v_mps,w_radps";
// Optional: each scan's stamp as its source wrote it (an imported log), one row per scans.csv row.
constexpr const char* kSourceStampsHeader = "robot,scan,source_stamp_us";

Error file_error(const char* file, const std::string& problem, long line = 0, int sys_errno = 0) {
  return make_error(std::string(file) + ": " + problem, sys_errno, line);
}

// Shortest text that reads back to the same double (std::to_chars round-trip guarantee).
std::string num(double v) {
  char buf[64];
  const auto r = std::to_chars(buf, buf + sizeof buf, v);
  return std::string(buf, r.ptr);
}
// TOML needs a float to look like one: "3" -> "3.0"; "nan", "inf", "1e+20" already do.
std::string toml_float(double v) {
  std::string s = num(v);
  if (s.find_first_of(".eEni") == std::string::npos) s += ".0";
  return s;
}
std::string toml_string(const std::string& s) {
  std::string out = "\"";
  for (const char c : s) {
    if (c == '"' || c == '\\') { out += '\\'; out += c; }
    else if (static_cast<unsigned char>(c) < 0x20) {
      char buf[8];
      std::snprintf(buf, sizeof buf, "\\u%04x", static_cast<unsigned>(static_cast<unsigned char>(c)));
      out += buf;
    } else out += c;
  }
  return out + "\"";
}
std::string toml_array(const double* v, int n) {
  std::string s = "[";
  for (int i = 0; i < n; ++i) s += (i ? ", " : "") + toml_float(v[i]);
  return s + "]";
}

Status write_text(const std::filesystem::path& path, const std::string& text) {
  std::FILE* f = std::fopen(path.c_str(), "wb");
  if (f == nullptr) return file_error(path.filename().c_str(), "cannot create", 0, errno);
  const bool wrote = std::fwrite(text.data(), 1, text.size(), f) == text.size();
  const int err = errno;
  if (std::fclose(f) != 0 || !wrote) return file_error(path.filename().c_str(), "write failed", 0, wrote ? errno : err);
  return ok_status();
}

std::string dataset_toml(const Dataset& d) {
  std::size_t ghosts = 0;
  for (const auto& p : d.points) ghosts += p.is_ghost() ? 1 : 0;
  std::string s;
  s += "# teamscan labelled data set (docs/formats.md). Units are in the key names.\n";
  s += "format = \"teamscan-dataset\"\nversion = 1\n";
  s += "scenario = " + toml_string(d.scenario) + "\n";
  // TOML integers are signed 64-bit: a seed above that is written as a decimal string.
  if (d.seed <= static_cast<std::uint64_t>(std::numeric_limits<std::int64_t>::max()))
    s += "seed = " + std::to_string(d.seed) + "\n";
  else
    s += "seed = \"" + std::to_string(d.seed) + "\"\n";
  s += "duration_s = " + toml_float(d.duration_s) + "\n";
  s += "room_m = " + toml_array(d.room_m, 3) + "\n";
  s += "\n[counts]\n";
  s += "points = " + std::to_string(d.points.size()) + "\n";
  s += "ghost_points = " + std::to_string(ghosts) + "\n";
  s += "scans = " + std::to_string(d.scans.size()) + "\n";
  s += "truth_samples = " + std::to_string(d.truth.size()) + "\n";
  s += "odom_samples = " + std::to_string(d.odom.size()) + "\n";
  for (const auto& r : d.robots) {
    s += "\n[[robots]]\n";
    s += "id = " + std::to_string(r.id) + "\n";
    s += "name = " + toml_string(r.name) + "\n";
    s += "role = " + toml_string(r.role) + "\n";
    s += "subclass = " + toml_string(r.subclass) + "\n";
    s += "mount_xyz_m = " + toml_array(r.mount_xyz_m, 3) + "\n";
    s += "mount_rpy_rad = " + toml_array(r.mount_rpy_rad, 3) + "\n";
    s += "fov_deg = " + std::to_string(r.fov_deg) + "\n";
    s += "resolution_cdeg = " + std::to_string(r.resolution_cdeg) + "\n";
    s += "lms_baud = " + std::to_string(r.lms_baud) + "\n";
    s += "registration = { x_m = " + toml_float(r.registration.x_m) + ", y_m = " + toml_float(r.registration.y_m) +
         ", theta_rad = " + toml_float(r.registration.theta_rad) + " }\n";
    s += "footprint_m = " + toml_array(r.footprint_m, 2) + "\n";
    s += "height_m = " + toml_float(r.height_m) + "\n";
  }
  return s;
}

std::string scans_csv(const std::vector<ScanRecord>& scans) {
  std::string s = std::string(kScansHeader) + "\n";
  for (const auto& r : scans) {
    s += std::to_string(r.robot) + ',' + std::to_string(r.scan) + ',' + std::to_string(r.stamp_ns) + ',' +
         std::to_string(r.beams) + ',' + std::to_string(r.points) + ',' + num(r.origin.x) + ',' + num(r.origin.y) + ',' +
         num(r.origin.z) + ',' + num(r.pose.x_m) + ',' + num(r.pose.y_m) + ',' + num(r.pose.theta_rad) + ',' +
         num(r.true_pose.x_m) + ',' + num(r.true_pose.y_m) + ',' + num(r.true_pose.theta_rad) + '\n';
  }
  return s;
}

bool has_source_stamps(const std::vector<ScanRecord>& scans) {
  for (const auto& r : scans)
    if (r.source_stamp_us != 0) return true;
  return false;
}

std::string source_stamps_csv(const std::vector<ScanRecord>& scans) {
  std::string s = std::string(kSourceStampsHeader) + "\n";
  for (const auto& r : scans) s += std::to_string(r.robot) + ',' + std::to_string(r.scan) + ',' + std::to_string(r.source_stamp_us) + '\n';
  return s;
}

std::string trajectory_csv(const std::vector<TrajectorySample>& samples) {
  std::string s = std::string(kTrajectoryHeader) + "\n";
  for (const auto& t : samples) {
    s += std::to_string(t.robot) + ',' + std::to_string(t.stamp_ns) + ',' + num(t.pose.x_m) + ',' + num(t.pose.y_m) + ',' +
         num(t.pose.theta_rad) + ',' + num(t.v_mps) + ',' + num(t.w_radps) + '\n';
  }
  return s;
}

// ---- reading ---------------------------------------------------------------------------------------

Result<std::string> read_text(const std::filesystem::path& path, const char* name) {
  const auto bytes = read_file_bytes(path.string());
  if (!bytes) return file_error(name, "cannot open", 0, bytes.error().sys_errno);
  return std::string(bytes->begin(), bytes->end());
}

template <class T>
bool parse_int(std::string_view s, T& v) {
  const auto r = std::from_chars(s.data(), s.data() + s.size(), v);
  return r.ec == std::errc{} && r.ptr == s.data() + s.size();
}
bool parse_double(std::string_view s, double& v) {
  const auto r = std::from_chars(s.data(), s.data() + s.size(), v);
  return r.ec == std::errc{} && r.ptr == s.data() + s.size() && !s.empty();
}

// Calls `row(cells, line_no)` for each data line after checking the header row. Blank lines are skipped.
template <class Row>
Status parse_csv(const std::string& text, const char* name, const char* header, std::size_t columns, Row row) {
  std::size_t pos = 0;
  long line_no = 0;
  std::vector<std::string_view> cells;
  while (pos < text.size()) {
    const std::size_t eol = text.find('\n', pos);
    const std::size_t next = eol == std::string::npos ? text.size() : eol + 1;
    std::string_view line(text.data() + pos, next - pos);
    pos = next;
    ++line_no;
    while (!line.empty() && (line.back() == '\n' || line.back() == '\r')) line.remove_suffix(1);
    if (line_no == 1) {
      if (line != header) return file_error(name, std::string("header row is not \"") + header + "\"", 1);
      continue;
    }
    if (line.empty()) continue;
    cells.clear();
    std::size_t start = 0;
    for (;;) {
      const std::size_t comma = line.find(',', start);
      cells.push_back(line.substr(start, comma == std::string_view::npos ? std::string_view::npos : comma - start));
      if (comma == std::string_view::npos) break;
      start = comma + 1;
    }
    if (cells.size() != columns)
      return file_error(name, "expected " + std::to_string(columns) + " columns, found " + std::to_string(cells.size()), line_no);
    if (!row(cells, line_no)) return file_error(name, "a value is malformed or out of range", line_no);
  }
  if (line_no == 0) return file_error(name, "empty file (no header row)", 1);
  return ok_status();
}

// A robot id as the fusion core takes it: checked here, where a data set enters, and not again.
bool valid_robot(std::uint8_t robot) { return robot >= 1 && robot <= kMaxRobots; }

Status parse_scans(const std::string& text, std::vector<ScanRecord>& out) {
  return parse_csv(text, "scans.csv", kScansHeader, 14, [&](const std::vector<std::string_view>& c, long) {
    ScanRecord r;
    const bool ok = parse_int(c[0], r.robot) && parse_int(c[1], r.scan) && parse_int(c[2], r.stamp_ns) &&
                    parse_int(c[3], r.beams) && parse_int(c[4], r.points) && parse_double(c[5], r.origin.x) &&
                    parse_double(c[6], r.origin.y) && parse_double(c[7], r.origin.z) && parse_double(c[8], r.pose.x_m) &&
                    parse_double(c[9], r.pose.y_m) && parse_double(c[10], r.pose.theta_rad) &&
                    parse_double(c[11], r.true_pose.x_m) && parse_double(c[12], r.true_pose.y_m) &&
                    parse_double(c[13], r.true_pose.theta_rad) && valid_robot(r.robot);
    if (ok) out.push_back(r);
    return ok;
  });
}

// Row i belongs to scans.csv row i (the same robot and scan, or the file is refused).
Status parse_source_stamps(const std::string& text, std::vector<ScanRecord>& scans) {
  std::size_t row = 0;
  const Status parsed = parse_csv(text, "source_stamps.csv", kSourceStampsHeader, 3, [&](const std::vector<std::string_view>& c, long) {
    std::uint8_t robot = 0;
    std::uint32_t scan = 0;
    std::int64_t stamp_us = 0;
    const bool ok = row < scans.size() && parse_int(c[0], robot) && parse_int(c[1], scan) && parse_int(c[2], stamp_us) &&
                    robot == scans[row].robot && scan == scans[row].scan;
    if (ok) scans[row++].source_stamp_us = stamp_us;
    return ok;
  });
  if (!parsed) return parsed;
  if (row != scans.size()) return file_error("source_stamps.csv", "fewer rows than scans.csv", static_cast<long>(row) + 1);
  return ok_status();
}

Status parse_trajectory(const std::string& text, const char* name, std::vector<TrajectorySample>& out) {
  return parse_csv(text, name, kTrajectoryHeader, 7, [&](const std::vector<std::string_view>& c, long) {
    TrajectorySample t;
    const bool ok = parse_int(c[0], t.robot) && parse_int(c[1], t.stamp_ns) && parse_double(c[2], t.pose.x_m) &&
                    parse_double(c[3], t.pose.y_m) && parse_double(c[4], t.pose.theta_rad) && parse_double(c[5], t.v_mps) &&
                    parse_double(c[6], t.w_radps) && valid_robot(t.robot);
    if (ok) out.push_back(t);
    return ok;
  });
}

// ---- dataset.toml ----------------------------------------------------------------------------------

constexpr const char* kToml = "dataset.toml";

long line_of(const toml::node& n) { return static_cast<long>(n.source().begin.line); }

Status get_float(const toml::table& t, const char* key, double& out, bool required, long table_line) {
  const toml::node* n = t.get(key);
  if (n == nullptr) return required ? file_error(kToml, std::string("missing key '") + key + "'", table_line) : ok_status();
  if (const auto v = n->value<double>()) {  // integers are accepted where a float is expected
    out = *v;
    return ok_status();
  }
  return file_error(kToml, std::string("'") + key + "' is not a number", line_of(*n));
}

template <class T>
Status get_uint(const toml::table& t, const char* key, T& out, bool required, long table_line) {
  const toml::node* n = t.get(key);
  if (n == nullptr) return required ? file_error(kToml, std::string("missing key '") + key + "'", table_line) : ok_status();
  const auto v = n->as_integer();
  if (v == nullptr || v->get() < 0 || static_cast<std::uint64_t>(v->get()) > std::numeric_limits<T>::max())
    return file_error(kToml, std::string("'") + key + "' is not an integer in range", line_of(*n));
  out = static_cast<T>(v->get());
  return ok_status();
}

Status get_string(const toml::table& t, const char* key, std::string& out, bool required, long table_line) {
  const toml::node* n = t.get(key);
  if (n == nullptr) return required ? file_error(kToml, std::string("missing key '") + key + "'", table_line) : ok_status();
  const auto v = n->as_string();
  if (v == nullptr) return file_error(kToml, std::string("'") + key + "' is not a string", line_of(*n));
  out = v->get();
  return ok_status();
}

Status get_floats(const toml::table& t, const char* key, double* out, std::size_t n_values, bool required, long table_line) {
  const toml::node* n = t.get(key);
  if (n == nullptr) return required ? file_error(kToml, std::string("missing key '") + key + "'", table_line) : ok_status();
  const auto a = n->as_array();
  if (a == nullptr || a->size() != n_values)
    return file_error(kToml, std::string("'") + key + "' is not an array of " + std::to_string(n_values) + " numbers", line_of(*n));
  for (std::size_t i = 0; i < n_values; ++i) {
    const auto v = (*a)[i].value<double>();
    if (!v) return file_error(kToml, std::string("'") + key + "' has an element that is not a number", line_of(*n));
    out[i] = *v;
  }
  return ok_status();
}

#define TEAMSCAN_TRY(expr)          \
  do {                              \
    auto status_ = (expr);          \
    if (!status_) return status_.error(); \
  } while (0)

struct Counts {
  std::uint64_t points = 0, ghost_points = 0, scans = 0, truth_samples = 0, odom_samples = 0;
  bool present = false;
  long line = 0;
};

Status parse_dataset_toml(const std::string& text, Dataset& d, Counts& counts) {
  toml::table root;
  try {
    root = toml::parse(text, std::string_view{kToml});
  } catch (const toml::parse_error& e) {
    return file_error(kToml, std::string("TOML syntax: ") + std::string(e.description()), static_cast<long>(e.source().begin.line));
  }
  if (const auto* f = root.get("format"); f != nullptr && f->value<std::string>() != std::string("teamscan-dataset"))
    return file_error(kToml, "'format' is not \"teamscan-dataset\"", line_of(*f));
  if (const auto* v = root.get("version"); v != nullptr && v->value<std::int64_t>() != std::int64_t{1})
    return file_error(kToml, "unsupported 'version' (this reader knows version 1)", line_of(*v));
  TEAMSCAN_TRY(get_string(root, "scenario", d.scenario, true, 1));
  if (const auto* s = root.get("seed"); s == nullptr) {
    return file_error(kToml, "missing key 'seed'", 1);
  } else if (const auto* str = s->as_string()) {
    if (!parse_int(std::string_view(str->get()), d.seed)) return file_error(kToml, "'seed' is not an unsigned integer", line_of(*s));
  } else {
    TEAMSCAN_TRY(get_uint(root, "seed", d.seed, true, 1));
  }
  TEAMSCAN_TRY(get_float(root, "duration_s", d.duration_s, true, 1));
  TEAMSCAN_TRY(get_floats(root, "room_m", d.room_m, 3, true, 1));
  if (const auto* c = root.get("counts")) {
    const auto* t = c->as_table();
    if (t == nullptr) return file_error(kToml, "'counts' is not a table", line_of(*c));
    counts.present = true;
    counts.line = line_of(*c);
    TEAMSCAN_TRY(get_uint(*t, "points", counts.points, true, counts.line));
    TEAMSCAN_TRY(get_uint(*t, "ghost_points", counts.ghost_points, true, counts.line));
    TEAMSCAN_TRY(get_uint(*t, "scans", counts.scans, true, counts.line));
    TEAMSCAN_TRY(get_uint(*t, "truth_samples", counts.truth_samples, true, counts.line));
    TEAMSCAN_TRY(get_uint(*t, "odom_samples", counts.odom_samples, true, counts.line));
  }
  if (const auto* rs = root.get("robots")) {
    const auto* arr = rs->as_array();
    if (arr == nullptr) return file_error(kToml, "'robots' is not an array of tables ([[robots]])", line_of(*rs));
    for (const auto& node : *arr) {
      const auto* t = node.as_table();
      if (t == nullptr) return file_error(kToml, "'robots' has an element that is not a table", line_of(node));
      const long line = line_of(node);
      DatasetRobot r;
      TEAMSCAN_TRY(get_uint(*t, "id", r.id, true, line));
      if (r.id < 1 || r.id > 32) return file_error(kToml, "robot 'id' is not 1..32", line);
      TEAMSCAN_TRY(get_string(*t, "name", r.name, false, line));
      TEAMSCAN_TRY(get_string(*t, "role", r.role, false, line));
      TEAMSCAN_TRY(get_string(*t, "subclass", r.subclass, false, line));
      TEAMSCAN_TRY(get_floats(*t, "mount_xyz_m", r.mount_xyz_m, 3, true, line));
      TEAMSCAN_TRY(get_floats(*t, "mount_rpy_rad", r.mount_rpy_rad, 3, true, line));
      TEAMSCAN_TRY(get_uint(*t, "fov_deg", r.fov_deg, false, line));
      TEAMSCAN_TRY(get_uint(*t, "resolution_cdeg", r.resolution_cdeg, false, line));
      TEAMSCAN_TRY(get_uint(*t, "lms_baud", r.lms_baud, false, line));
      if (const auto* reg = t->get("registration")) {
        const auto* rt = reg->as_table();
        if (rt == nullptr) return file_error(kToml, "'registration' is not a table {x_m, y_m, theta_rad}", line_of(*reg));
        TEAMSCAN_TRY(get_float(*rt, "x_m", r.registration.x_m, true, line_of(*reg)));
        TEAMSCAN_TRY(get_float(*rt, "y_m", r.registration.y_m, true, line_of(*reg)));
        TEAMSCAN_TRY(get_float(*rt, "theta_rad", r.registration.theta_rad, true, line_of(*reg)));
      }
      TEAMSCAN_TRY(get_floats(*t, "footprint_m", r.footprint_m, 2, false, line));
      TEAMSCAN_TRY(get_float(*t, "height_m", r.height_m, false, line));
      d.robots.push_back(r);
    }
  }
  return ok_status();
}

}  // namespace

Status write_dataset(const std::string& dir, const Dataset& dataset) {
  namespace fs = std::filesystem;
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec) return make_error(dir + ": cannot create data set folder", ec.value());
  const fs::path root{dir};
  TEAMSCAN_TRY(write_text(root / "dataset.toml", dataset_toml(dataset)));
  if (auto s = write_labelled_pcd((root / "points.pcd").string(), dataset.points); !s)
    return with_context("points.pcd", s.error());
  TEAMSCAN_TRY(write_text(root / "scans.csv", scans_csv(dataset.scans)));
  TEAMSCAN_TRY(write_text(root / "truth.csv", trajectory_csv(dataset.truth)));
  TEAMSCAN_TRY(write_text(root / "odom.csv", trajectory_csv(dataset.odom)));
  if (has_source_stamps(dataset.scans)) TEAMSCAN_TRY(write_text(root / "source_stamps.csv", source_stamps_csv(dataset.scans)));
  return ok_status();
}

Result<Dataset> read_dataset(const std::string& dir) {
  namespace fs = std::filesystem;
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) return make_error(dir + ": not a data set folder (no such directory)", ENOENT);
  const fs::path root{dir};
  Dataset d;
  Counts counts;
  {
    const auto text = read_text(root / "dataset.toml", "dataset.toml");
    if (!text) return text.error();
    TEAMSCAN_TRY(parse_dataset_toml(*text, d, counts));
  }
  {
    auto points = read_labelled_pcd((root / "points.pcd").string());
    if (!points) return with_context("points.pcd", points.error());
    d.points = std::move(*points);
    for (const LabelledPoint& p : d.points)
      if (!valid_robot(p.robot)) return file_error("points.pcd", "a point's robot id is not 1.." + std::to_string(kMaxRobots));
  }
  {
    const auto text = read_text(root / "scans.csv", "scans.csv");
    if (!text) return text.error();
    TEAMSCAN_TRY(parse_scans(*text, d.scans));
  }
  if (fs::exists(root / "source_stamps.csv", ec)) {
    const auto text = read_text(root / "source_stamps.csv", "source_stamps.csv");
    if (!text) return text.error();
    TEAMSCAN_TRY(parse_source_stamps(*text, d.scans));
  }
  {
    const auto text = read_text(root / "truth.csv", "truth.csv");
    if (!text) return text.error();
    TEAMSCAN_TRY(parse_trajectory(*text, "truth.csv", d.truth));
  }
  {
    const auto text = read_text(root / "odom.csv", "odom.csv");
    if (!text) return text.error();
    TEAMSCAN_TRY(parse_trajectory(*text, "odom.csv", d.odom));
  }
  // The counts catch a file cut short (a crash while writing) that still parses.
  if (counts.present) {
    std::uint64_t ghosts = 0;
    for (const auto& p : d.points) ghosts += p.is_ghost() ? 1 : 0;
    if (counts.points != d.points.size() || counts.ghost_points != ghosts)
      return file_error(kToml, "[counts] points/ghost_points differ from points.pcd", counts.line);
    if (counts.scans != d.scans.size()) return file_error(kToml, "[counts] scans differs from scans.csv", counts.line);
    if (counts.truth_samples != d.truth.size()) return file_error(kToml, "[counts] truth_samples differs from truth.csv", counts.line);
    if (counts.odom_samples != d.odom.size()) return file_error(kToml, "[counts] odom_samples differs from odom.csv", counts.line);
  }
  return d;
}

}  // namespace teamscan
