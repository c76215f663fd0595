// TOML scenario loader (scenario.hpp). Every key is checked: unknown keys, wrong types and values
// out of range give an error naming the key, e.g. "lap2.toml: robot[2].laser.resolution_deg: …".
#include "sim/scenario.hpp"

#include <cmath>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>

#include <toml++/toml.h>

#include "common/data_paths.hpp"

namespace teamscan::sim {
namespace {

// Reads typed values from one TOML table and remembers the first error with its key path.
class Reader {
 public:
  Reader(const toml::table& table, std::string path, std::string* error)
      : table_{table}, path_{std::move(path)}, error_{error} {}

  [[nodiscard]] std::string key_path(std::string_view key) const {
    return path_.empty() ? std::string{key} : path_ + "." + std::string{key};
  }
  void fail(std::string_view key, const std::string& message) const {
    if (error_->empty()) *error_ = key_path(key) + ": " + message;
  }
  [[nodiscard]] bool failed() const { return !error_->empty(); }

  // Every key must be one of `allowed`.
  void only(std::initializer_list<std::string_view> allowed) const {
    const std::set<std::string_view> set{allowed};
    for (const auto& [k, v] : table_) {
      if (!set.count(k.str())) fail(k.str(), "unknown key");
    }
  }

  [[nodiscard]] bool has(std::string_view key) const { return table_.contains(key); }

  double number(std::string_view key, double fallback, double min, double max) const {
    const toml::node* n = table_.get(key);
    if (!n) return fallback;
    std::optional<double> v = n->value<double>();  // integers convert too
    if (!v || !std::isfinite(*v)) {
      fail(key, "expected a number");
      return fallback;
    }
    if (*v < min || *v > max) {
      std::ostringstream s;
      s << "value " << *v << " out of range [" << min << ", " << max << "]";
      fail(key, s.str());
      return fallback;
    }
    return *v;
  }

  std::int64_t integer(std::string_view key, std::int64_t fallback, std::int64_t min, std::int64_t max) const {
    const toml::node* n = table_.get(key);
    if (!n) return fallback;
    if (!n->is_integer()) {
      fail(key, "expected an integer");
      return fallback;
    }
    const std::int64_t v = n->as_integer()->get();
    if (v < min || v > max) {
      fail(key, "value " + std::to_string(v) + " out of range [" + std::to_string(min) + ", " + std::to_string(max) + "]");
      return fallback;
    }
    return v;
  }

  std::string string(std::string_view key, const std::string& fallback, std::initializer_list<std::string_view> choices = {}) const {
    const toml::node* n = table_.get(key);
    if (!n) return fallback;
    if (!n->is_string()) {
      fail(key, "expected a string");
      return fallback;
    }
    std::string v{n->as_string()->get()};
    if (choices.size() > 0) {
      bool found = false;
      std::string list;
      for (std::string_view c : choices) {
        found = found || c == v;
        list += (list.empty() ? "" : ", ") + std::string{c};
      }
      if (!found) {
        fail(key, "\"" + v + "\" is not one of " + list);
        return fallback;
      }
    }
    return v;
  }

  bool boolean(std::string_view key, bool fallback) const {
    const toml::node* n = table_.get(key);
    if (!n) return fallback;
    if (!n->is_boolean()) {
      fail(key, "expected true or false");
      return fallback;
    }
    return n->as_boolean()->get();
  }

  // A fixed-length array of numbers.
  std::vector<double> numbers(std::string_view key, std::vector<double> fallback, std::size_t count) const {
    const toml::node* n = table_.get(key);
    if (!n) return fallback;
    const toml::array* a = n->as_array();
    if (!a || a->size() != count) {
      fail(key, "expected an array of " + std::to_string(count) + " numbers");
      return fallback;
    }
    std::vector<double> out;
    for (const toml::node& e : *a) {
      std::optional<double> v = e.value<double>();
      if (!v || !std::isfinite(*v)) {
        fail(key, "expected an array of " + std::to_string(count) + " numbers");
        return fallback;
      }
      out.push_back(*v);
    }
    return out;
  }

  [[nodiscard]] const toml::table* subtable(std::string_view key) const {
    const toml::node* n = table_.get(key);
    if (!n) return nullptr;
    if (!n->is_table()) {
      fail(key, "expected a table");
      return nullptr;
    }
    return n->as_table();
  }

  [[nodiscard]] const toml::table& table() const { return table_; }
  [[nodiscard]] std::string* error() const { return error_; }

 private:
  const toml::table& table_;
  std::string path_;
  std::string* error_;
};

constexpr double kRoomMax = 10.0;  // the paper's 10 × 10 × 10 m space (PAPER_NOTES.md)

void read_track(const Reader& r, TrackSpec& t) {
  r.only({"kind", "center_m", "yaw_deg", "direction", "semi_axes_m", "half_length_m", "width_m", "points_m", "closed", "spline"});
  const std::string kind = r.string("kind", "oval", {"oval", "figure8", "waypoints"});
  t.kind = kind == "figure8" ? Track::Kind::figure8 : kind == "waypoints" ? Track::Kind::waypoints : Track::Kind::oval;
  const auto c = r.numbers("center_m", {0, 0}, 2);
  t.center_m = {c[0], c[1]};
  t.yaw_rad = deg_to_rad(r.number("yaw_deg", 0, -360, 360));
  t.ccw = r.string("direction", "ccw", {"ccw", "cw"}) == "ccw";
  const auto axes = r.numbers("semi_axes_m", {3.0, 1.6}, 2);
  t.semi_x_m = axes[0];
  t.semi_y_m = axes[1];
  if (t.kind == Track::Kind::oval && (axes[0] <= 0.1 || axes[1] <= 0.1 || axes[0] > kRoomMax || axes[1] > kRoomMax))
    r.fail("semi_axes_m", "semi-axes must lie in (0.1, 10] m");
  t.half_length_m = r.number("half_length_m", 3.0, 0.2, kRoomMax);
  t.width_m = r.number("width_m", 3.0, 0.2, kRoomMax);
  t.closed = r.boolean("closed", true);
  t.spline = r.string("spline", "uniform", {"uniform", "centripetal"}) == "centripetal" ? Track::Spline::centripetal : Track::Spline::uniform;
  if (const toml::node* n = r.table().get("points_m")) {
    const toml::array* a = n->as_array();
    bool ok = a != nullptr && a->size() >= 2;
    if (ok) {
      for (const toml::node& e : *a) {
        const toml::array* p = e.as_array();
        if (!p || p->size() != 2 || !p->get(0)->value<double>() || !p->get(1)->value<double>()) {
          ok = false;
          break;
        }
        t.waypoints_m.push_back({*p->get(0)->value<double>(), *p->get(1)->value<double>()});
      }
    }
    if (!ok) r.fail("points_m", "expected an array of at least two [x, y] pairs");
  }
  if (t.kind == Track::Kind::waypoints && t.waypoints_m.size() < 2 && !r.failed())
    r.fail("points_m", "a waypoints track needs at least two points");
}

void read_robot(const Reader& r, RobotSpec& robot, std::size_t index) {
  r.only({"id", "name", "role", "subclass", "speed_mps", "accel_mps2", "max_turn_rate_deg_s", "laps", "start_offset_m", "start_phase", "start_s", "pauses",
          "arcos_baud", "sip_cycle_ms", "scan_phase_ms", "track", "laser", "odometry"});
  robot.id = static_cast<std::uint8_t>(r.integer("id", static_cast<std::int64_t>(index + 1), 1, 32));
  robot.name = r.string("name", "robot" + std::to_string(robot.id));
  robot.role = r.string("role", "down-laser");
  robot.subclass = r.string("subclass", "p3at-sh", {"p3at", "p3at-sh"});
  robot.speed_mps = r.number("speed_mps", 0.3, 0.0, 1.2);  // MaxVelocity 1200 mm/s (§1.11)
  // ARIA's p3at TransAccel is 300 mm/s²; 0 gives instant starts and stops.
  robot.accel_mps2 = r.number("accel_mps2", 0.3, 0.0, 10.0);
  // The P3-AT turns at most 140°/s (its operations manual); 0 lets a track turn it at any rate.
  robot.max_turn_rate_deg_s = r.number("max_turn_rate_deg_s", 140.0, 0.0, 1000.0);
  robot.laps = r.number("laps", 2.0, 0.0, 1000.0);
  robot.start_offset_m = r.number("start_offset_m", 0.0, -1e4, 1e4);
  if (r.has("start_phase")) {
    if (r.has("start_offset_m")) r.fail("start_phase", "give either start_phase or start_offset_m, not both");
    robot.start_phase = r.number("start_phase", 0.0, -1.0, 1.0);
  }
  robot.start_s = r.number("start_s", 0.0, 0.0, 1e5);
  robot.arcos_baud = static_cast<std::uint32_t>(r.integer("arcos_baud", 38400, 9600, 115200));
  if (robot.arcos_baud != 9600 && robot.arcos_baud != 19200 && robot.arcos_baud != 38400 && robot.arcos_baud != 57600 &&
      robot.arcos_baud != 115200)
    r.fail("arcos_baud", "must be 9600, 19200, 38400, 57600 or 115200 (HOSTBAUD, PROTOCOLS.md §1.1)");
  robot.sip_cycle_s = r.number("sip_cycle_ms", 100.0, 10.0, 1000.0) * 1e-3;
  robot.scan_phase_s = r.number("scan_phase_ms", 0.0, 0.0, 1000.0) * 1e-3;

  if (const toml::node* n = r.table().get("pauses")) {
    const toml::array* a = n->as_array();
    if (!a) {
      r.fail("pauses", "expected an array of { at_s, for_s } tables");
    } else {
      std::size_t i = 0;
      for (const toml::node& e : *a) {
        const toml::table* pt = e.as_table();
        const std::string sub = r.key_path("pauses") + "[" + std::to_string(i++) + "]";
        if (!pt) {
          r.fail("pauses", "expected an array of { at_s, for_s } tables");
          break;
        }
        Reader pr{*pt, sub, r.error()};
        pr.only({"at_s", "for_s"});
        if (!pr.has("at_s") || !pr.has("for_s")) pr.fail(pr.has("at_s") ? "for_s" : "at_s", "missing");
        robot.pauses.push_back({pr.number("at_s", 0, 0, 1e5), pr.number("for_s", 0, 0, 1e5)});
      }
    }
  }

  if (const toml::table* t = r.subtable("track")) read_track(Reader{*t, r.key_path("track"), r.error()}, robot.track);
  else if (!r.failed()) r.fail("track", "missing (every robot needs a track)");

  const bool up = robot.role == "up-laser";
  robot.mount_rpy_rad[1] = deg_to_rad(up ? -20.0 : 15.0);
  if (const toml::table* t = r.subtable("laser")) {
    Reader lr{*t, r.key_path("laser"), r.error()};
    lr.only({"mount_xyz_m", "mount_rpy_deg", "fov_deg", "resolution_deg", "baud", "range_noise_mm"});
    const auto xyz = lr.numbers("mount_xyz_m", {0.125, 0.0, 0.462}, 3);
    for (int i = 0; i < 3; ++i) robot.mount_xyz_m[i] = xyz[static_cast<std::size_t>(i)];
    const auto rpy = lr.numbers("mount_rpy_deg", {0.0, up ? -20.0 : 15.0, 0.0}, 3);
    for (int i = 0; i < 3; ++i) robot.mount_rpy_rad[i] = deg_to_rad(rpy[static_cast<std::size_t>(i)]);
    const auto fov = lr.integer("fov_deg", 180, 100, 180);
    if (fov != 100 && fov != 180) lr.fail("fov_deg", "must be 100 or 180 (PROTOCOLS.md §2.5)");
    const double res = lr.number("resolution_deg", 1.0, 0.25, 1.0);
    if (res != 1.0 && res != 0.5 && res != 0.25) lr.fail("resolution_deg", "must be 1, 0.5 or 0.25 (PROTOCOLS.md §2.5)");
    if (fov == 180 && res == 0.25) lr.fail("resolution_deg", "180° at 0.25° is not a variant of the LMS-200 (PROTOCOLS.md §2.5)");
    robot.variant.fov_deg = static_cast<std::uint16_t>(fov);
    robot.variant.resolution_cdeg = static_cast<std::uint16_t>(std::lround(res * 100));
    robot.lms_baud = static_cast<std::uint32_t>(lr.integer("baud", 500000, 9600, 500000));
    if (robot.lms_baud != 9600 && robot.lms_baud != 19200 && robot.lms_baud != 38400 && robot.lms_baud != 500000)
      lr.fail("baud", "must be 9600, 19200, 38400 or 500000 (PROTOCOLS.md §2.1)");
    robot.range_noise_mm = lr.number("range_noise_mm", 5.0, 0.0, 1000.0);
  }
  robot.robot_from_laser = Pose3::from_xyz_rpy(robot.mount_xyz_m[0], robot.mount_xyz_m[1], robot.mount_xyz_m[2],
                                               robot.mount_rpy_rad[0], robot.mount_rpy_rad[1], robot.mount_rpy_rad[2]);
  if (const toml::table* t = r.subtable("odometry")) {
    Reader orr{*t, r.key_path("odometry"), r.error()};
    orr.only({"slip_sigma", "heading_sigma", "drift_deg_per_m", "slip_percent", "turn_slip_percent",
              "heading_walk_deg_per_sqrt_m"});
    robot.odometry.slip_sigma = orr.number("slip_sigma", 0.0, 0.0, 1.0);
    robot.odometry.heading_sigma = orr.number("heading_sigma", 0.0, 0.0, 1.0);
    robot.odometry.drift_rad_per_m = deg_to_rad(orr.number("drift_deg_per_m", 0.0, -90.0, 90.0));
    robot.odometry.slip = 0.01 * orr.number("slip_percent", 0.0, -50.0, 50.0);
    robot.odometry.turn_slip = 0.01 * orr.number("turn_slip_percent", 0.0, -50.0, 50.0);
    robot.odometry.heading_walk_rad_per_sqrt_m = deg_to_rad(orr.number("heading_walk_deg_per_sqrt_m", 0.0, 0.0, 10.0));
  }
}

}  // namespace

ScenarioLoad parse_scenario(const std::string& toml_text, const std::string& source_name) {
  ScenarioLoad out;
  toml::table root;
  try {
    root = toml::parse(toml_text, source_name);
  } catch (const toml::parse_error& e) {
    std::ostringstream s;
    s << source_name << ":" << e.source().begin.line << ":" << e.source().begin.column << ": " << e.description();
    out.error = s.str();
    return out;
  }
  std::string error;
  Scenario sc;
  Reader r{root, "", &error};
  r.only({"name", "seed", "duration_s", "start_time_ns", "room", "furniture", "robot"});
  sc.name = r.string("name", std::filesystem::path(source_name).stem().string());
  sc.seed = static_cast<std::uint64_t>(r.integer("seed", 1, 0, INT64_MAX));
  if (r.has("duration_s")) sc.duration_s = r.number("duration_s", 0, 0.001, 1e5);
  sc.start_time_ns = r.integer("start_time_ns", sc.start_time_ns, 0, INT64_MAX / 2);
  if (const toml::table* t = r.subtable("room")) {
    Reader rr{*t, "room", &error};
    rr.only({"size_m"});
    const auto s = rr.numbers("size_m", {10.0, 8.0, 3.0}, 3);
    for (double v : s)
      if (v < 1.0 || v > kRoomMax) rr.fail("size_m", "each size must lie in [1, 10] m (the paper's 10 × 10 × 10 m space)");
    sc.room_m = {s[0], s[1], s[2]};
  }
  if (const toml::node* n = root.get("furniture")) {
    const toml::array* a = n->as_array();
    if (!a) r.fail("furniture", "expected an array of tables ([[furniture]])");
    for (std::size_t i = 0; a && i < a->size(); ++i) {
      const toml::table* t = a->get(i)->as_table();
      const std::string path = "furniture[" + std::to_string(i) + "]";
      if (!t) {
        r.fail("furniture", "expected an array of tables ([[furniture]])");
        break;
      }
      Reader fr{*t, path, &error};
      fr.only({"kind", "center_m", "size_m", "yaw_deg", "top_thickness_m", "leg_m"});
      FurnitureSpec f;
      f.kind = fr.string("kind", "box", {"box", "table"}) == "table" ? FurnitureSpec::Kind::table : FurnitureSpec::Kind::box;
      if (!fr.has("center_m")) fr.fail("center_m", "missing");
      if (!fr.has("size_m")) fr.fail("size_m", "missing");
      const auto c = fr.numbers("center_m", {0, 0}, 2);
      const auto s = fr.numbers("size_m", {1, 1, 1}, 3);
      for (double v : s)
        if (v <= 0.01 || v > kRoomMax) fr.fail("size_m", "each size must lie in (0.01, 10] m");
      f.center_m = {c[0], c[1]};
      f.size_m = {s[0], s[1], s[2]};
      f.yaw_rad = deg_to_rad(fr.number("yaw_deg", 0, -360, 360));
      f.top_thickness_m = fr.number("top_thickness_m", 0.03, 0.005, 0.5);
      f.leg_m = fr.number("leg_m", 0.05, 0.01, 0.5);
      if (f.kind == FurnitureSpec::Kind::table && f.top_thickness_m >= f.size_m.z)
        fr.fail("top_thickness_m", "must be less than the table's height size_m[2]");
      sc.furniture.push_back(f);
    }
  }
  if (const toml::node* n = root.get("robot")) {
    const toml::array* a = n->as_array();
    if (!a) r.fail("robot", "expected an array of tables ([[robot]])");
    for (std::size_t i = 0; a && i < a->size(); ++i) {
      const toml::table* t = a->get(i)->as_table();
      if (!t) {
        r.fail("robot", "expected an array of tables ([[robot]])");
        break;
      }
      RobotSpec robot;
      read_robot(Reader{*t, "robot[" + std::to_string(i) + "]", &error}, robot, i);
      sc.robots.push_back(std::move(robot));
    }
  }
  if (error.empty() && sc.robots.empty()) error = "robot: missing (a scenario needs at least one [[robot]])";
  std::set<int> ids;
  for (std::size_t i = 0; error.empty() && i < sc.robots.size(); ++i) {
    if (!ids.insert(sc.robots[i].id).second) error = "robot[" + std::to_string(i) + "].id: duplicate robot id";
  }
  if (!error.empty()) {
    out.error = source_name + ": " + error;
    return out;
  }
  out.scenario = std::move(sc);
  return out;
}

ScenarioLoad load_scenario_file(const std::string& path) {
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec)) {
    ScenarioLoad out;
    out.error = path + ": a directory, not a scenario file";
    return out;
  }
  std::ifstream in{path, std::ios::binary};
  if (!in) {
    ScenarioLoad out;
    out.error = path + ": cannot open the scenario file";
    return out;
  }
  std::ostringstream text;
  text << in.rdbuf();
  return parse_scenario(text.str(), path);
}

std::vector<std::string> builtin_scenario_names() { return {"lap2", "fig8", "team3", "loops2-drift"}; }

ScenarioLoad resolve_scenario(const std::string& name_or_path) {
  namespace fs = std::filesystem;
  std::error_code ec;
  // A bare name is a scenario's unless a file of that name is here: a directory of that name (a data
  // set written where the simulator runs, `--out lap2`) does not hide the scenario.
  if (name_or_path.find('/') != std::string::npos || name_or_path.ends_with(".toml") || fs::is_regular_file(name_or_path, ec))
    return load_scenario_file(name_or_path);
  const std::string file = name_or_path + ".toml";
  const DataFile found = find_data_file("scenarios/" + file, "sim/scenarios/" + file);
  if (!found.path.empty()) return load_scenario_file(found.path);
  ScenarioLoad out;
  std::string names;
  for (const auto& n : builtin_scenario_names()) names += (names.empty() ? "" : ", ") + n;
  out.error = name_or_path + ": no such scenario file or built-in scenario (built-in: " + names + "; looked in " +
              found.searched + ")";
  return out;
}

}  // namespace teamscan::sim
