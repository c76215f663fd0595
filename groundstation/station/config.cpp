// TOML parsing of the ground-station config with toml++; each error names its key.
#include "groundstation/station/config.hpp"

#include <fstream>
#include <functional>
#include <sstream>

#include <toml++/toml.h>

namespace teamscan::station {
namespace {

class Reader {
 public:
  Reader(const toml::table& root, ConfigError& error) : root_{root}, error_{error} {}

  // Reads a number at a dotted path into `out` if present; checks lo < v <= hi (or lo <= v if closed).
  bool number(const char* path, double& out, double lo, double hi, bool lo_closed = false) {
    const toml::node_view<const toml::node> n = root_.at_path(path);
    if (!n) return true;
    std::optional<double> v = n.value<double>();
    if (!v || !(n.is_number())) return fail(path, "must be a number");
    if (!(lo_closed ? *v >= lo : *v > lo) || *v > hi) {
      std::ostringstream m;
      m << "must be in " << (lo_closed ? "[" : "(") << lo << ", " << hi << "], got " << *v;
      return fail(path, m.str());
    }
    out = *v;
    return true;
  }

  bool integer(const char* path, std::int64_t& out, std::int64_t lo, std::int64_t hi) {
    const toml::node_view<const toml::node> n = root_.at_path(path);
    if (!n) return true;
    if (!n.is_integer()) return fail(path, "must be an integer");
    const std::int64_t v = *n.value<std::int64_t>();
    if (v < lo || v > hi) {
      return fail(path, "must be in [" + std::to_string(lo) + ", " + std::to_string(hi) + "], got " + std::to_string(v));
    }
    out = v;
    return true;
  }

  bool string(const char* path, std::string& out) {
    const toml::node_view<const toml::node> n = root_.at_path(path);
    if (!n) return true;
    if (!n.is_string()) return fail(path, "must be a string");
    out = *n.value<std::string>();
    if (out.empty()) return fail(path, "must not be empty");
    return true;
  }

  bool boolean(const char* path, bool& out) {
    const toml::node_view<const toml::node> n = root_.at_path(path);
    if (!n) return true;
    if (!n.is_boolean()) return fail(path, "must be true or false");
    out = *n.value<bool>();
    return true;
  }

  bool fail(const char* path, const std::string& what) {
    error_.message = std::string(path) + ": " + what;
    return false;
  }

 private:
  const toml::table& root_;
  ConfigError& error_;
};

bool known_keys(const toml::table& root, ConfigError& error) {
  // A misspelt key would otherwise be ignored silently and its default used.
  static const char* const kKnown[] = {
      "station", "station.session_root", "station.sync_interval_s", "station.status_interval_s",
      "dds", "dds.domain_id", "dds.scan_history_depth", "dds.take_batch",
      "team", "team.publish_rate_hz", "team.liveliness_lease_s", "team.silence_timeout_s",
      "team.body", "team.body.length_m", "team.body.width_m", "team.body.height_m",
      "team.last_pose", "team.last_pose.sigma0_m", "team.last_pose.sigma_velocity_mps",
      "team.last_pose.max_extrapolation_s", "team.source", "team.kalman", "team.kalman.accel_noise_mps2",
      "team.kalman.position_noise_m", "team.kalman.velocity_noise_mps", "team.kalman.lost_after_s", "team.kalman.drift_m_per_m",
      "team.kalman.drift_deg_per_m", "team.kalman.drift_deg_per_deg",
      "fusion", "fusion.enabled", "fusion.method", "fusion.resolution_m", "fusion.half_angle_deg",
      "fusion.grid_origin_z_m", "fusion.frequency_k", "fusion.position_sigma_m", "fusion.position_n",
      "fusion.direction_from_flags", "fusion.write_interval_s", "fusion.write_all_points", "fusion.map_interval_s",
      "fusion.map_resolution_m", "fusion.latency_log", "fusion.hold_s", "fusion.model_resolution_m",
      "fusion.max_points_per_voxel"};
  std::string bad;
  const std::function<void(const toml::table&, const std::string&)> walk = [&](const toml::table& t, const std::string& prefix) {
    for (const auto& [k, v] : t) {
      const std::string key = prefix.empty() ? std::string(k.str()) : prefix + "." + std::string(k.str());
      bool found = false;
      for (const char* known : kKnown) found = found || key == known;
      if (!found && bad.empty()) bad = key;
      if (const toml::table* sub = v.as_table()) walk(*sub, key);
    }
  };
  walk(root, "");
  if (!bad.empty()) {
    error.message = bad + ": unknown key";
    return false;
  }
  return true;
}

}  // namespace

bool kalman_tracker_available() {
#ifdef TEAMSCAN_HAVE_KALMAN_TRACKER
  return true;
#else
  return false;
#endif
}

bool parse_groundstation_config(const std::string& toml_text, const std::string& source_name, GroundStationConfig& out,
                                ConfigError& error) {
  toml::table root;
  try {
    root = toml::parse(toml_text, source_name);
  } catch (const toml::parse_error& e) {
    std::ostringstream m;
    m << source_name << ":" << e.source().begin.line << ":" << e.source().begin.column << ": " << e.description();
    error.message = m.str();
    return false;
  }
  if (!known_keys(root, error)) return false;
  Reader r(root, error);
  GroundStationConfig c = out;
  if (!kalman_tracker_available()) c.team_source = TeamSourceKind::kLastPose;
  double sync_s = to_seconds(c.sync_interval);
  double status_s = to_seconds(c.status_interval);
  std::int64_t domain = -1;
  std::int64_t depth = c.station.scan_history_depth;
  std::int64_t batch = c.station.take_batch;
  double rate_hz = 1.0 / to_seconds(c.station.team_period);
  double lease_s = to_seconds(c.station.team_liveliness_lease);
  double silence_s = to_seconds(c.station.silence_timeout);
  RobotBody& body = c.last_pose.default_body;
  const bool ok = r.string("station.session_root", c.session_root) &&
                  r.number("station.sync_interval_s", sync_s, 0.0, 3600.0) &&
                  r.number("station.status_interval_s", status_s, 0.0, 3600.0) &&
                  r.integer("dds.domain_id", domain, -1, 232) &&
                  r.integer("dds.scan_history_depth", depth, 1, 100000) &&
                  r.integer("dds.take_batch", batch, 1, 4096) &&
                  r.number("team.publish_rate_hz", rate_hz, 0.0, 1000.0) &&
                  r.number("team.liveliness_lease_s", lease_s, 0.0, 60.0) &&
                  r.number("team.silence_timeout_s", silence_s, 0.0, 3600.0, true) &&
                  r.number("team.body.length_m", body.length_m, 0.0, 10.0) &&
                  r.number("team.body.width_m", body.width_m, 0.0, 10.0) &&
                  r.number("team.body.height_m", body.height_m, 0.0, 10.0) &&
                  r.number("team.last_pose.sigma0_m", c.last_pose.sigma0_m, 0.0, 100.0, true) &&
                  r.number("team.last_pose.sigma_velocity_mps", c.last_pose.sigma_velocity_mps, 0.0, 100.0, true) &&
                  r.number("team.last_pose.max_extrapolation_s", c.last_pose.max_extrapolation_s, 0.0, 60.0, true);
  std::string source = kalman_tracker_available() ? "kalman" : "last_pose";
  const bool ok2 = ok && r.string("team.source", source) &&
                   r.number("team.kalman.accel_noise_mps2", c.kalman.accel_noise_mps2, 0.0, 100.0) &&
                   r.number("team.kalman.position_noise_m", c.kalman.position_noise_m, 0.0, 100.0) &&
                   r.number("team.kalman.velocity_noise_mps", c.kalman.velocity_noise_mps, 0.0, 100.0) &&
                   r.number("team.kalman.lost_after_s", c.kalman.lost_after_s, 0.0, 3600.0) &&
                   r.number("team.kalman.drift_m_per_m", c.kalman.drift_m_per_m, 0.0, 1.0, true) &&
                   r.number("team.kalman.drift_deg_per_m", c.kalman.drift_deg_per_m, 0.0, 90.0, true) &&
                   r.number("team.kalman.drift_deg_per_deg", c.kalman.drift_deg_per_deg, 0.0, 1.0, true);
  if (!ok2) return false;
  FusionConfig& f = c.fusion;
  double write_s = to_seconds(f.write_interval);
  double map_s = to_seconds(f.map_interval);
  std::int64_t max_per_voxel = f.max_points_per_voxel;
  const bool ok3 = r.boolean("fusion.enabled", f.enabled) && r.string("fusion.method", f.method) &&
                   r.number("fusion.resolution_m", f.resolution_m, 0.0, 10.0) &&
                   r.number("fusion.half_angle_deg", f.half_angle_deg, 0.0, 60.0) &&
                   r.number("fusion.grid_origin_z_m", f.grid_origin_z_m, -10.0, 10.0, true) &&
                   r.number("fusion.frequency_k", f.frequency_k, -100.0, 100.0, true) &&
                   r.number("fusion.position_sigma_m", f.position_sigma_m, 0.0, 100.0) &&
                   r.number("fusion.position_n", f.position_n, 0.0, 100.0) &&
                   r.boolean("fusion.direction_from_flags", f.direction_from_flags) &&
                   r.number("fusion.write_interval_s", write_s, 0.0, 86400.0, true) &&
                   r.boolean("fusion.write_all_points", f.write_all_points) &&
                   r.boolean("fusion.latency_log", f.latency_log) &&
                   r.number("fusion.map_interval_s", map_s, 0.0, 3600.0, true) &&
                   r.number("fusion.map_resolution_m", f.map_resolution_m, 0.0, 10.0) &&
                   r.number("fusion.hold_s", f.hold_s, 0.0, 60.0, true) &&
                   r.number("fusion.model_resolution_m", f.model_resolution_m, 0.0, 10.0) &&
                   r.integer("fusion.max_points_per_voxel", max_per_voxel, 0, 1'000'000);
  if (!ok3) return false;
  f.max_points_per_voxel = static_cast<std::uint32_t>(max_per_voxel);
  // The paper's methods and issue 7's (groundstation/mapping make_filter; docs/beyond.md).
  static const char* const kMethods[] = {"frequency", "visibility", "position", "direction", "combined",
                                         "freespace", "tracked",    "best"};
  bool known_method = false;
  for (const char* m : kMethods) known_method = known_method || f.method == m;
  if (!known_method) {
    return r.fail("fusion.method", "must be frequency, visibility, position, direction, combined, freespace, tracked "
                                   "or best, got \"" + f.method + "\"");
  }
  f.write_interval = from_seconds(write_s);
  f.map_interval = from_seconds(map_s);
  if (source == "kalman") {
    if (!kalman_tracker_available()) return r.fail("team.source", "\"kalman\" is not in this build (no groundstation/mapping)");
    c.team_source = TeamSourceKind::kKalman;
  } else if (source == "last_pose") {
    c.team_source = TeamSourceKind::kLastPose;
  } else {
    return r.fail("team.source", "must be \"kalman\" or \"last_pose\", got \"" + source + "\"");
  }
  c.sync_interval = from_seconds(sync_s);
  c.status_interval = from_seconds(status_s);
  c.station.domain_id = domain < 0 ? 0xFFFFFFFFu : static_cast<std::uint32_t>(domain);
  c.station.scan_history_depth = static_cast<std::uint32_t>(depth);
  c.station.take_batch = static_cast<std::uint32_t>(batch);
  c.station.team_period = from_seconds(1.0 / rate_hz);
  c.station.team_liveliness_lease = from_seconds(lease_s);
  c.station.silence_timeout = from_seconds(silence_s);
  out = c;
  return true;
}

bool load_groundstation_config(const std::string& path, GroundStationConfig& out, ConfigError& error) {
  std::ifstream in(path);
  if (!in) {
    error.message = path + ": cannot open";
    return false;
  }
  std::stringstream ss;
  ss << in.rdbuf();
  return parse_groundstation_config(ss.str(), path, out, error);
}

}  // namespace teamscan::station
