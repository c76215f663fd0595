// Parsing and checking of the robot daemon's TOML config (config.hpp). toml++ is used header-only with
// exceptions off (the library built by Debian uses exceptions; this target has -fno-exceptions).
#define TOML_EXCEPTIONS 0
#define TOML_HEADER_ONLY 1
#include "onboard/core/config.hpp"

#include <toml++/toml.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <initializer_list>
#include <sstream>

#include "common/toml_reader.hpp"
#include "common/units.hpp"

namespace teamscan::onboard {

Pose3 LaserMount::robot_from_laser() const {
  return Pose3::from_xyz_rpy(x_m, y_m, z_m, deg_to_rad(roll_deg), deg_to_rad(pitch_deg), deg_to_rad(yaw_deg));
}

Pose2 OnboardConfig::map_from_odom() const {
  return {registration_x_m, registration_y_m, normalize_angle(deg_to_rad(registration_theta_deg))};
}

std::uint64_t RingConfig::slots() const {
  return static_cast<std::uint64_t>(std::ceil(capacity_s * kRingRecordsPerSecond));
}

std::uint32_t OnboardConfig::max_range_mm() const {
  return to_mm_as<std::uint32_t>(lms_max_range_m);
}

namespace {

bool one_of(std::int64_t v, std::initializer_list<std::int64_t> set) {
  return std::find(set.begin(), set.end(), v) != set.end();
}

std::string fmt_double(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%g", v);
  return buf;
}

}  // namespace

Result<OnboardConfig> parse_onboard_config(std::string_view toml_text, std::string& message) {
  // TOML forbids control characters other than tab and line ends; refuse them here, before toml++:
  // its 3.3 parser asserts (an assumption, in release builds) on a NUL inside a table header (found
  // by tests/fuzz/onboard).
  long line = 1;
  for (const char ch : toml_text) {
    const auto b = static_cast<unsigned char>(ch);
    if (b == '\n') ++line;
    if ((b < 0x20 && b != '\t' && b != '\n' && b != '\r') || b == 0x7F) {
      char hex[8];
      std::snprintf(hex, sizeof hex, "0x%02X", b);
      message = "TOML syntax error at line " + std::to_string(line) + ": control character " + hex + " is not allowed";
      return Error{"config: TOML syntax error", 0, line};
    }
  }
  // Table headers: toml++ 3.3 also asserts when '[' or '[[' is followed by something that can start no
  // key (e.g. "[!arcos]"); such a line is a syntax error anyway.
  line = 1;
  for (std::size_t i = 0; i < toml_text.size(); ++i) {
    const bool line_start = i == 0 || toml_text[i - 1] == '\n';
    if (toml_text[i] == '\n') ++line;
    if (!line_start) continue;
    std::size_t j = i;
    while (j < toml_text.size() && (toml_text[j] == ' ' || toml_text[j] == '\t')) ++j;
    if (j >= toml_text.size() || toml_text[j] != '[') continue;
    ++j;
    if (j < toml_text.size() && toml_text[j] == '[') ++j;
    while (j < toml_text.size() && (toml_text[j] == ' ' || toml_text[j] == '\t')) ++j;
    const char c = j < toml_text.size() ? toml_text[j] : '\n';
    const bool key_start = (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '_' ||
                           c == '-' || c == '"' || c == '\'';
    if (!key_start) {
      message = "TOML syntax error at line " + std::to_string(line) + ": a table header must start with a key";
      return Error{"config: TOML syntax error", 0, line};
    }
  }
  // toml++ 3.3 reaches an "unreachable" branch when it classifies some non-ASCII characters (found by
  // tests/fuzz/onboard), so it never sees one: non-ASCII bytes in comments (e.g. "°") become spaces in
  // a copy; anywhere else they are refused (every key and value of this schema is ASCII).
  std::string ascii{toml_text};
  line = 1;
  bool in_comment = false, in_basic = false, in_literal = false;
  for (std::size_t i = 0; i < ascii.size(); ++i) {
    const char ch = ascii[i];
    if (ch == '\n') {
      ++line;
      in_comment = false;
      continue;
    }
    if (static_cast<unsigned char>(ch) >= 0x80) {
      if (in_comment) {
        ascii[i] = ' ';
        continue;
      }
      message = "TOML syntax error at line " + std::to_string(line) + ": non-ASCII character outside a comment";
      return Error{"config: TOML syntax error", 0, line};
    }
    if (in_comment) continue;
    if (in_basic) {
      if (ch == '\\' && i + 1 < ascii.size() && (ascii[i + 1] == '"' || ascii[i + 1] == '\\')) ++i;  // \" \\ stay in
      else if (ch == '"') in_basic = false;
      continue;
    }
    if (in_literal) {
      if (ch == '\'') in_literal = false;
      continue;
    }
    if (ch == '#') in_comment = true;
    else if (ch == '"') in_basic = true;
    else if (ch == '\'') in_literal = true;
  }
  toml::parse_result parsed = toml::parse(std::string_view{ascii});
  if (!parsed) {
    const toml::parse_error& e = parsed.error();
    const long error_line = static_cast<long>(e.source().begin.line);
    message = "TOML syntax error at line " + std::to_string(error_line) + ": " + std::string(e.description());
    return Error{"config: TOML syntax error", 0, error_line};
  }
  const toml::table& root = parsed.table();
  TomlReader r{root, message};
  OnboardConfig c;

  r.top_level({"robot", "arcos", "lms", "mount", "registration", "filter", "dds", "status", "odometry", "ring"});

  // [robot]
  const toml::table* robot = r.section("robot", true);
  r.only(robot, "robot", {"id"});
  std::int64_t id = 0;
  if (r.integer(robot, "robot", "id", id, true) && (id < 1 || id > static_cast<std::int64_t>(kMaxRobots)))
    r.fail("robot.id", std::to_string(id) + " is outside 1..32", r.node(robot, "id"));
  c.robot_id = static_cast<std::uint32_t>(std::clamp<std::int64_t>(id, 0, 32));

  // [arcos]
  const toml::table* arcos = r.section("arcos", true);
  r.only(arcos, "arcos", {"device", "baud"});
  if (r.string(arcos, "arcos", "device", c.arcos_device, true) && c.arcos_device.empty())
    r.fail("arcos.device", "must not be empty", r.node(arcos, "device"));
  std::int64_t baud = c.arcos_baud;
  if (r.integer(arcos, "arcos", "baud", baud, false) && !one_of(baud, {9600, 19200, 38400, 57600, 115200}))
    r.fail("arcos.baud", std::to_string(baud) + " is not an ARCOS rate (9600, 19200, 38400, 57600, 115200)",
           r.node(arcos, "baud"));
  c.arcos_baud = static_cast<std::uint32_t>(std::clamp<std::int64_t>(baud, 0, 115200));

  // [lms]
  const toml::table* lms = r.section("lms", true);
  r.only(lms, "lms", {"device", "baud", "fov_deg", "resolution_deg", "units", "max_range_m"});
  if (r.string(lms, "lms", "device", c.lms_device, true) && c.lms_device.empty())
    r.fail("lms.device", "must not be empty", r.node(lms, "device"));
  baud = c.lms_baud;
  if (r.integer(lms, "lms", "baud", baud, false) && !one_of(baud, {9600, 19200, 38400, 500000}))
    r.fail("lms.baud", std::to_string(baud) + " is not an LMS rate (9600, 19200, 38400, 500000)", r.node(lms, "baud"));
  c.lms_baud = static_cast<std::uint32_t>(std::clamp<std::int64_t>(baud, 0, 500000));
  std::int64_t fov = c.lms_variant.fov_deg;
  if (r.integer(lms, "lms", "fov_deg", fov, false) && !one_of(fov, {100, 180}))
    r.fail("lms.fov_deg", std::to_string(fov) + " is not an LMS field of view (100, 180)", r.node(lms, "fov_deg"));
  double res_deg = c.lms_variant.resolution_cdeg / 100.0;
  if (r.number(lms, "lms", "resolution_deg", res_deg, false) && res_deg != 1.0 && res_deg != 0.5 && res_deg != 0.25)
    r.fail("lms.resolution_deg", fmt_double(res_deg) + " is not an LMS resolution (1, 0.5, 0.25)",
           r.node(lms, "resolution_deg"));
  if (!r.failed()) {
    c.lms_variant = LaserVariant{static_cast<std::uint16_t>(fov), static_cast<std::uint16_t>(std::lround(res_deg * 100))};
    if (c.lms_variant.beams() > kMaxBeams)
      r.fail("lms.resolution_deg", "0.25 needs fov_deg = 100 (the LMS has no 180°/0.25° variant)",
             r.node(lms, "resolution_deg"));
  }
  std::string units = "mm";
  if (r.string(lms, "lms", "units", units, false)) {
    if (units == "mm") c.lms_units = LmsUnits::mm;
    else if (units == "cm") c.lms_units = LmsUnits::cm;
    else r.fail("lms.units", "\"" + units + "\" is not \"mm\" or \"cm\"", r.node(lms, "units"));
  }
  c.lms_max_range_m = c.lms_units == LmsUnits::mm ? 8.0 : 80.0;
  if (r.number(lms, "lms", "max_range_m", c.lms_max_range_m, false)) {
    // PROTOCOLS.md 2.7: useful maxima 8.182 m in mm units, 81.82 m in cm units (measuring mode 0x00).
    const double limit = c.lms_units == LmsUnits::mm ? 8.182 : 81.82;
    if (!(c.lms_max_range_m > 0.0 && c.lms_max_range_m <= limit))
      r.fail("lms.max_range_m", fmt_double(c.lms_max_range_m) + " is outside (0, " + fmt_double(limit) + "] for units \"" +
                                    units + "\"", r.node(lms, "max_range_m"));
  }

  // [mount]
  const toml::table* mount = r.section("mount", true);
  r.only(mount, "mount", {"x_m", "y_m", "z_m", "roll_deg", "pitch_deg", "yaw_deg"});
  r.number(mount, "mount", "x_m", c.mount.x_m, true);
  r.number(mount, "mount", "y_m", c.mount.y_m, true);
  r.number(mount, "mount", "z_m", c.mount.z_m, true);
  r.number(mount, "mount", "roll_deg", c.mount.roll_deg, false);
  r.number(mount, "mount", "pitch_deg", c.mount.pitch_deg, true);
  r.number(mount, "mount", "yaw_deg", c.mount.yaw_deg, false);
  for (const auto& [key, v] : {std::pair{"x_m", c.mount.x_m}, std::pair{"y_m", c.mount.y_m}})
    if (std::abs(v) > 2.0) r.fail(std::string("mount.") + key, fmt_double(v) + " m is off the robot (|v| <= 2)", r.node(mount, key));
  if (!(c.mount.z_m >= 0.0 && c.mount.z_m <= 3.0))
    r.fail("mount.z_m", fmt_double(c.mount.z_m) + " m is outside [0, 3]", r.node(mount, "z_m"));
  for (const auto& [key, v] : {std::pair{"roll_deg", c.mount.roll_deg}, std::pair{"pitch_deg", c.mount.pitch_deg},
                               std::pair{"yaw_deg", c.mount.yaw_deg}})
    if (std::abs(v) > 180.0) r.fail(std::string("mount.") + key, fmt_double(v) + "° is outside [-180, 180]", r.node(mount, key));

  // [registration]
  const toml::table* reg = r.section("registration", false);
  r.only(reg, "registration", {"x_m", "y_m", "theta_deg"});
  r.number(reg, "registration", "x_m", c.registration_x_m, false);
  r.number(reg, "registration", "y_m", c.registration_y_m, false);
  r.number(reg, "registration", "theta_deg", c.registration_theta_deg, false);
  const double extent_m = cone::kDirectionFilterExtentMm * 1e-3;
  if (std::abs(c.registration_x_m) > extent_m || std::abs(c.registration_y_m) > extent_m)
    r.fail("registration", "outside the ±2097 m map extent", r.node(reg, "x_m"));

  // [filter]
  const toml::table* filter = r.section("filter", false);
  r.only(filter, "filter",
         {"enabled", "half_angle_deg", "range_gate", "range_gate_margin_m", "height_gate", "height_gate_margin_m",
          "body_radius_m", "height_m", "max_team_age_s", "stale_policy", "stale_growth_deg_per_s", "extrapolate_team"});
  r.boolean(filter, "filter", "enabled", c.filter_enabled);
  cone::DirectionFilterParams& f = c.filter;
  r.number(filter, "filter", "half_angle_deg", f.half_angle_deg, false);
  r.boolean(filter, "filter", "range_gate", f.range_gate);
  r.number(filter, "filter", "range_gate_margin_m", f.range_gate_margin_m, false);
  r.boolean(filter, "filter", "height_gate", f.height_gate);
  r.number(filter, "filter", "height_gate_margin_m", f.height_gate_margin_m, false);
  r.number(filter, "filter", "body_radius_m", f.default_body_radius_m, false);
  r.number(filter, "filter", "height_m", f.default_height_m, false);
  double age_s = to_seconds(f.max_team_age);
  if (r.number(filter, "filter", "max_team_age_s", age_s, false)) {
    if (!(age_s > 0.0 && age_s <= 60.0))
      r.fail("filter.max_team_age_s", fmt_double(age_s) + " is outside (0, 60]", r.node(filter, "max_team_age_s"));
    else
      f.max_team_age = from_seconds(age_s);
  }
  std::string policy = "widen";
  if (r.string(filter, "filter", "stale_policy", policy, false)) {
    if (policy == "widen") f.stale_policy = cone::StalePolicy::widen;
    else if (policy == "disable") f.stale_policy = cone::StalePolicy::disable;
    else r.fail("filter.stale_policy", "\"" + policy + "\" is not \"widen\" or \"disable\"", r.node(filter, "stale_policy"));
  }
  r.number(filter, "filter", "stale_growth_deg_per_s", f.stale_growth_deg_per_s, false);
  r.boolean(filter, "filter", "extrapolate_team", f.extrapolate_team);
  if (!r.failed()) {
    // DirectionFilter::create names the parameter as filter.<key>; point at its line.
    const Result<DirectionFilter> check = DirectionFilter::create(f, c.robot_id);
    if (!check.ok()) {
      const std::string what = check.error().what;
      const std::string key = what.substr(0, what.find(' '));
      const std::string sub = key.substr(key.find('.') + 1);
      r.fail(key, what.substr(what.find(' ') + 1), r.node(filter, sub.c_str()));
    }
  }

  // [dds]
  const toml::table* dds = r.section("dds", false);
  r.only(dds, "dds", {"domain", "publish", "scan_history_depth"});
  std::int64_t domain = 0;
  if (r.integer(dds, "dds", "domain", domain, false) && (domain < 0 || domain > 232))
    r.fail("dds.domain", std::to_string(domain) + " is outside 0..232", r.node(dds, "domain"));
  c.dds_domain = static_cast<std::uint32_t>(std::clamp<std::int64_t>(domain, 0, 232));
  std::string publish = "all";
  if (r.string(dds, "dds", "publish", publish, false)) {
    if (publish == "all") c.publish = PublishMode::all;
    else if (publish == "kept") c.publish = PublishMode::kept;
    else r.fail("dds.publish", "\"" + publish + "\" is not \"all\" or \"kept\"", r.node(dds, "publish"));
  }
  std::int64_t depth = c.scan_history_depth;
  if (r.integer(dds, "dds", "scan_history_depth", depth, false) && (depth < 1 || depth > 10000))
    r.fail("dds.scan_history_depth", std::to_string(depth) + " is outside 1..10000", r.node(dds, "scan_history_depth"));
  c.scan_history_depth = static_cast<std::uint32_t>(std::clamp<std::int64_t>(depth, 1, 10000));

  // [status]
  const toml::table* status = r.section("status", false);
  r.only(status, "status", {"period_s"});
  double period_s = to_seconds(c.status_period);
  if (r.number(status, "status", "period_s", period_s, false)) {
    if (!(period_s >= 0.05 && period_s <= 60.0))
      r.fail("status.period_s", fmt_double(period_s) + " is outside [0.05, 60]", r.node(status, "period_s"));
    else
      c.status_period = from_seconds(period_s);
  }

  // [odometry]
  const toml::table* odom = r.section("odometry", false);
  r.only(odom, "odometry", {"max_extrapolation_s", "max_hold_s"});
  double extrap_s = to_seconds(c.odometry_max_extrapolation);
  if (r.number(odom, "odometry", "max_extrapolation_s", extrap_s, false)) {
    if (!(extrap_s >= 0.0 && extrap_s <= 1.0))
      r.fail("odometry.max_extrapolation_s", fmt_double(extrap_s) + " is outside [0, 1]", r.node(odom, "max_extrapolation_s"));
    else
      c.odometry_max_extrapolation = from_seconds(extrap_s);
  }
  // How long a scan waits for the SIP that covers its stamp (docs/demo.md "Latency"); unset: as long as
  // the extrapolation limit allows (the behaviour before the key existed). More than that would only
  // publish beams without a pose.
  c.odometry_max_hold = c.odometry_max_extrapolation;
  double hold_s = to_seconds(c.odometry_max_hold);
  if (r.number(odom, "odometry", "max_hold_s", hold_s, false)) {
    if (!(hold_s >= 0.0 && hold_s <= to_seconds(c.odometry_max_extrapolation)))
      r.fail("odometry.max_hold_s",
             fmt_double(hold_s) + " is outside [0, odometry.max_extrapolation_s = " +
                 fmt_double(to_seconds(c.odometry_max_extrapolation)) + "]",
             r.node(odom, "max_hold_s"));
    else
      c.odometry_max_hold = from_seconds(hold_s);
  }

  // [ring]
  const toml::table* ring = r.section("ring", false);
  r.only(ring, "ring", {"path", "capacity_s", "flush_records", "flush_period_s", "backfill_rate_hz"});
  RingConfig& rc = c.ring;
  if (r.string(ring, "ring", "path", rc.path, false) && rc.path.empty())
    r.fail("ring.path", "must not be empty (leave the key out for no ring)", r.node(ring, "path"));
  if (r.number(ring, "ring", "capacity_s", rc.capacity_s, false) && !(rc.capacity_s >= 1.0 && rc.capacity_s <= 86400.0))
    r.fail("ring.capacity_s", fmt_double(rc.capacity_s) + " is outside [1, 86400]", r.node(ring, "capacity_s"));
  std::int64_t flush_records = rc.flush_records;
  if (r.integer(ring, "ring", "flush_records", flush_records, false) && (flush_records < 1 || flush_records > 100000))
    r.fail("ring.flush_records", std::to_string(flush_records) + " is outside 1..100000", r.node(ring, "flush_records"));
  rc.flush_records = static_cast<std::uint32_t>(std::clamp<std::int64_t>(flush_records, 1, 100000));
  double flush_s = to_seconds(rc.flush_period);
  if (r.number(ring, "ring", "flush_period_s", flush_s, false)) {
    if (!(flush_s >= 0.001 && flush_s <= 60.0))
      r.fail("ring.flush_period_s", fmt_double(flush_s) + " is outside [0.001, 60]", r.node(ring, "flush_period_s"));
    else
      rc.flush_period = from_seconds(flush_s);
  }
  if (r.number(ring, "ring", "backfill_rate_hz", rc.backfill_rate_hz, false) &&
      !(rc.backfill_rate_hz >= 1.0 && rc.backfill_rate_hz <= 10000.0))
    r.fail("ring.backfill_rate_hz", fmt_double(rc.backfill_rate_hz) + " is outside [1, 10000]", r.node(ring, "backfill_rate_hz"));

  // Consistency across sections.
  if (!r.failed() && c.arcos_device == c.lms_device)
    r.fail("lms.device", "is the same device as arcos.device (" + c.lms_device + ")", r.node(lms, "device"));

  if (r.failed()) return Error{"config: invalid", 0, r.line()};
  return c;
}

Result<OnboardConfig> load_onboard_config(const std::string& path, std::string& message) {
  std::ifstream in(path);
  if (!in) {
    message = path + ": cannot be read";
    return Error{"config: cannot read the file"};
  }
  std::stringstream buf;
  buf << in.rdbuf();
  const std::string text = buf.str();
  Result<OnboardConfig> r = parse_onboard_config(text, message);
  if (!r.ok()) message = path + ": " + message;
  return r;
}

std::string describe(const OnboardConfig& c) {
  char buf[1280];
  std::snprintf(buf, sizeof buf,
                "robot %u; arcos %s @ %u; lms %s @ %u, %u°/%.2f°, %s, max %.2f m; mount (%.3f, %.3f, %.3f) m "
                "rpy (%.1f, %.1f, %.1f)°; registration (%.3f, %.3f) m %.1f°; filter %s ha %.1f° range gate %s "
                "height gate %s, team age %.2f s, stale %s; dds domain %u, publish %s, history %u; status %.2f s; "
                "odometry extrapolation %.3f s, hold %.3f s; ring %s (%.0f s = %llu records, flush every %u records "
                "or %.3f s, back-fill %.0f Hz)",
                c.robot_id, c.arcos_device.c_str(), c.arcos_baud, c.lms_device.c_str(), c.lms_baud, c.lms_variant.fov_deg,
                c.lms_variant.resolution_cdeg / 100.0, c.lms_units == LmsUnits::mm ? "mm" : "cm", c.lms_max_range_m,
                c.mount.x_m, c.mount.y_m, c.mount.z_m, c.mount.roll_deg, c.mount.pitch_deg, c.mount.yaw_deg,
                c.registration_x_m, c.registration_y_m, c.registration_theta_deg, c.filter_enabled ? "on" : "off",
                c.filter.half_angle_deg, c.filter.range_gate ? "on" : "off", c.filter.height_gate ? "on" : "off",
                to_seconds(c.filter.max_team_age), c.filter.stale_policy == cone::StalePolicy::widen ? "widen" : "disable",
                c.dds_domain, c.publish == PublishMode::all ? "all" : "kept", c.scan_history_depth,
                to_seconds(c.status_period), to_seconds(c.odometry_max_extrapolation), to_seconds(c.odometry_max_hold),
                c.ring.enabled() ? c.ring.path.c_str() : "off", c.ring.capacity_s,
                static_cast<unsigned long long>(c.ring.slots()), c.ring.flush_records, to_seconds(c.ring.flush_period),
                c.ring.backfill_rate_hz);
  return buf;
}

}  // namespace teamscan::onboard
