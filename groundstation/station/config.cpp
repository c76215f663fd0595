// TOML parsing of the ground-station config with toml++; each error names its key.
#include "groundstation/station/config.hpp"

#include <sched.h>

#include <fstream>
#include <sstream>

#include <toml++/toml.h>

#include "common/capacities.hpp"
#include "common/toml_reader.hpp"
#include "common/units.hpp"
#include "groundstation/view/requests.hpp"

namespace teamscan::station {

namespace {

// The odometry-prior keys of [registration] or of one [[registration.robot]] table onto `prior` (absent
// keys keep its values), in the config's units (percent, degrees per metre), checked as a whole
// (registration::prior_error).
void read_prior(TomlReader& r, const toml::table* t, const std::string& sect, registration::OdometryPrior& prior) {
  if (t == nullptr) return;
  registration::OdometryPrior p = prior;
  const char* s = sect.c_str();
  double v = 0;
  if (r.number(t, s, "scale_percent", v, false)) p.scale = 0.01 * v;
  if (r.number(t, s, "scale_sigma_percent", v, false)) p.sigma_scale = 0.01 * v;
  if (r.number(t, s, "drift_deg_per_m", v, false)) p.drift_rad_per_m = deg_to_rad(v);
  if (r.number(t, s, "drift_sigma_deg_per_m", v, false)) p.sigma_drift_rad_per_m = deg_to_rad(v);
  if (r.number(t, s, "turn_percent", v, false)) p.turn = 0.01 * v;
  if (r.number(t, s, "turn_sigma_percent", v, false)) p.sigma_turn = 0.01 * v;
  if (r.failed()) return;
  const std::string why = registration::prior_error(p);
  if (!why.empty()) {
    r.fail(sect, why, t);
    return;
  }
  prior = p;
}

// The keys of an odometry prior, in [registration] and in each [[registration.robot]] (one list for both).
#define TEAMSCAN_PRIOR_KEYS "scale_percent", "scale_sigma_percent", "drift_deg_per_m", "drift_sigma_deg_per_m", \
                            "turn_percent", "turn_sigma_percent"

// [registration]'s odometry priors: the team's default, then each [[registration.robot]] table (an id
// 1..kMaxRobots, once) on top of it.
void read_priors(TomlReader& r, const toml::table* reg, registration::RegistrationOptions& o) {
  if (reg == nullptr) return;
  read_prior(r, reg, "registration", o.prior);
  const toml::node* robots = r.node(reg, "robot");
  if (robots == nullptr || r.failed()) return;
  const toml::array* list = robots->as_array();
  if (list == nullptr || !list->is_array_of_tables()) {
    r.fail("registration.robot", "must be [[registration.robot]] tables", robots);
    return;
  }
  std::vector<registration::RobotPrior> priors;
  for (const toml::node& n : *list) {
    const toml::table* t = n.as_table();
    r.only(t, "registration.robot", {"id", TEAMSCAN_PRIOR_KEYS});
    std::int64_t id = 0;
    if (!r.integer(t, "registration.robot", "id", id, true)) return;
    if (id < 1 || id > static_cast<std::int64_t>(kMaxRobots)) {
      r.fail("registration.robot.id", "must be in [1, " + std::to_string(kMaxRobots) + "], got " + std::to_string(id),
             r.node(t, "id"));
      return;
    }
    for (const registration::RobotPrior& p : priors)
      if (p.robot == id) {
        r.fail("registration.robot.id", std::to_string(id) + " is listed twice", r.node(t, "id"));
        return;
      }
    registration::RobotPrior rp{static_cast<std::uint8_t>(id), o.prior};
    read_prior(r, t, "registration.robot (id " + std::to_string(id) + ")", rp.prior);
    if (r.failed()) return;
    priors.push_back(rp);
  }
  o.robot_priors = std::move(priors);
}

// [[ros2.laser_mount]] tables: a robot id (once each) and its mount.
void read_laser_mounts(TomlReader& r, const toml::table* ros2, Ros2Config& o) {
  if (ros2 == nullptr) return;
  const toml::node* mounts = r.node(ros2, "laser_mount");
  if (mounts == nullptr || r.failed()) return;
  const toml::array* list = mounts->as_array();
  if (list == nullptr || !list->is_array_of_tables()) {
    r.fail("ros2.laser_mount", "must be [[ros2.laser_mount]] tables", mounts);
    return;
  }
  for (const toml::node& n : *list) {
    const toml::table* t = n.as_table();
    r.only(t, "ros2.laser_mount", {"id", "x_m", "y_m", "z_m", "roll_deg", "pitch_deg", "yaw_deg"});
    std::int64_t id = 0;
    if (!r.integer(t, "ros2.laser_mount", "id", id, true)) return;
    if (id < 1 || id > static_cast<std::int64_t>(kMaxRobots)) {
      r.fail("ros2.laser_mount.id", "must be in [1, " + std::to_string(kMaxRobots) + "], got " + std::to_string(id),
             r.node(t, "id"));
      return;
    }
    for (const Ros2Config::RobotLaserMount& m : o.laser_mounts)
      if (m.robot_id == id) {
        r.fail("ros2.laser_mount.id", std::to_string(id) + " is listed twice", r.node(t, "id"));
        return;
      }
    Ros2Config::RobotLaserMount m{static_cast<std::uint32_t>(id), {}};
    double roll_deg = 0, pitch_deg = 0, yaw_deg = 0;
    r.number_in(t, "ros2.laser_mount", "x_m", m.mount.x_m, -10.0, 10.0, true);
    r.number_in(t, "ros2.laser_mount", "y_m", m.mount.y_m, -10.0, 10.0, true);
    r.number_in(t, "ros2.laser_mount", "z_m", m.mount.z_m, -10.0, 10.0, true);
    r.number_in(t, "ros2.laser_mount", "roll_deg", roll_deg, -180.0, 180.0, true);
    r.number_in(t, "ros2.laser_mount", "pitch_deg", pitch_deg, -180.0, 180.0, true);
    r.number_in(t, "ros2.laser_mount", "yaw_deg", yaw_deg, -180.0, 180.0, true);
    if (r.failed()) return;
    m.mount.roll_rad = deg_to_rad(roll_deg);
    m.mount.pitch_rad = deg_to_rad(pitch_deg);
    m.mount.yaw_rad = deg_to_rad(yaw_deg);
    o.laser_mounts.push_back(m);
  }
}

// The TOML text as a table; a syntax error as "<source>:<line>:<column>: <what>".
bool parse_toml(const std::string& toml_text, const std::string& source_name, toml::table& root, ConfigError& error) {
  try {
    root = toml::parse(toml_text, source_name);
  } catch (const toml::parse_error& e) {
    std::ostringstream m;
    m << source_name << ":" << e.source().begin.line << ":" << e.source().begin.column << ": " << e.description();
    error.message = m.str();
    return false;
  }
  return true;
}

void read_station(TomlReader& r, GroundStationConfig& c) {
  double sync_s = to_seconds(c.sync_interval);
  double status_s = to_seconds(c.status_interval);
  const toml::table* station = r.section("station", false);
  r.only(station, "station", {"session_root", "sync_interval_s", "status_interval_s"});
  if (r.string(station, "station", "session_root", c.session_root, false) && c.session_root.empty())
    r.fail("station.session_root", "must not be empty", r.node(station, "session_root"));
  r.number_in(station, "station", "sync_interval_s", sync_s, 0.0, 3600.0);
  r.number_in(station, "station", "status_interval_s", status_s, 0.0, 3600.0);
  c.sync_interval = from_seconds(sync_s);
  c.status_interval = from_seconds(status_s);
}

void read_dds(TomlReader& r, StationOptions& o) {
  std::int64_t domain = -1;  // absent: Cyclone's default domain
  std::int64_t depth = o.scan_history_depth;
  std::int64_t batch = o.take_batch;
  const toml::table* dds = r.section("dds", false);
  r.only(dds, "dds", {"domain_id", "scan_history_depth", "take_batch", "batch_receive_threads"});
  r.integer_in(dds, "dds", "domain_id", domain, -1, 232);
  r.integer_in(dds, "dds", "scan_history_depth", depth, 1, 100000);
  r.integer_in(dds, "dds", "take_batch", batch, 1, 4096);
  r.boolean(dds, "dds", "batch_receive_threads", o.batch_receive_threads);
  o.domain_id = domain < 0 ? 0xFFFFFFFFu : static_cast<std::uint32_t>(domain);
  o.scan_history_depth = static_cast<std::uint32_t>(depth);
  o.take_batch = static_cast<std::uint32_t>(batch);
}

// [team], [team.body] and [team.last_pose]; the source's name is checked last (check_team_source).
const toml::table* read_team(TomlReader& r, GroundStationConfig& c, std::string& source) {
  StationOptions& o = c.station;
  double rate_hz = 1.0 / to_seconds(o.team_period);
  double lease_s = to_seconds(o.team_liveliness_lease);
  double silence_s = to_seconds(o.silence_timeout);
  const toml::table* team = r.section("team", false);
  r.only(team, "team", {"publish_rate_hz", "liveliness_lease_s", "silence_timeout_s", "body", "last_pose", "source",
                        "kalman"});
  r.number_in(team, "team", "publish_rate_hz", rate_hz, 0.0, 1000.0);
  r.number_in(team, "team", "liveliness_lease_s", lease_s, 0.0, 60.0);
  r.number_in(team, "team", "silence_timeout_s", silence_s, 0.0, 3600.0, true);
  r.string(team, "team", "source", source, false);
  const toml::table* body_t = r.section("team.body", false);
  r.only(body_t, "team.body", {"length_m", "width_m", "height_m"});
  RobotBody& body = c.last_pose.default_body;
  r.number_in(body_t, "team.body", "length_m", body.length_m, 0.0, 10.0);
  r.number_in(body_t, "team.body", "width_m", body.width_m, 0.0, 10.0);
  r.number_in(body_t, "team.body", "height_m", body.height_m, 0.0, 10.0);
  const toml::table* last = r.section("team.last_pose", false);
  r.only(last, "team.last_pose", {"sigma0_m", "sigma_velocity_mps", "max_extrapolation_s"});
  r.number_in(last, "team.last_pose", "sigma0_m", c.last_pose.sigma0_m, 0.0, 100.0, true);
  r.number_in(last, "team.last_pose", "sigma_velocity_mps", c.last_pose.sigma_velocity_mps, 0.0, 100.0, true);
  r.number_in(last, "team.last_pose", "max_extrapolation_s", c.last_pose.max_extrapolation_s, 0.0, 60.0, true);
  o.team_period = from_seconds(1.0 / rate_hz);
  o.team_liveliness_lease = from_seconds(lease_s);
  o.silence_timeout = from_seconds(silence_s);
  return team;
}

// [team.kalman]: the tracker's options in the config's units (degrees per metre; deg/deg = rad/rad).
void read_kalman(TomlReader& r, mapping::TrackerOptions& o) {
  const toml::table* kalman = r.section("team.kalman", false);
  r.only(kalman, "team.kalman", {"accel_noise_mps2", "position_noise_m", "velocity_noise_mps", "lost_after_s",
                                 "drift_m_per_m", "drift_deg_per_m", "drift_deg_per_deg"});
  r.number_in(kalman, "team.kalman", "accel_noise_mps2", o.accel_noise_mps2, 0.0, 100.0);
  r.number_in(kalman, "team.kalman", "position_noise_m", o.position_noise_m, 0.0, 100.0);
  r.number_in(kalman, "team.kalman", "velocity_noise_mps", o.velocity_noise_mps, 0.0, 100.0);
  r.number_in(kalman, "team.kalman", "lost_after_s", o.lost_after_s, 0.0, 3600.0);
  r.number_in(kalman, "team.kalman", "drift_m_per_m", o.drift_m_per_m, 0.0, 1.0, true);
  double deg_per_m = rad_to_deg(o.drift_heading_rad_per_m);
  if (r.number_in(kalman, "team.kalman", "drift_deg_per_m", deg_per_m, 0.0, 90.0, true))
    o.drift_heading_rad_per_m = deg_to_rad(deg_per_m);
  r.number_in(kalman, "team.kalman", "drift_deg_per_deg", o.drift_heading_rad_per_rad, 0.0, 1.0, true);
}

// [fusion]'s keys of the filters (mapping::MethodOptions): one voxel edge, grid offset and cone for
// every method that has one.
void read_methods(TomlReader& r, const toml::table* fusion, mapping::MethodOptions& m) {
  double resolution_m = m.frequency.resolution_m;
  if (r.number_in(fusion, "fusion", "resolution_m", resolution_m, 0.0, 10.0))
    m.frequency.resolution_m = m.visibility.resolution_m = m.combined_resolution_m = resolution_m;
  double half_angle_deg = rad_to_deg(m.direction.half_angle_rad);
  if (r.number_in(fusion, "fusion", "half_angle_deg", half_angle_deg, 0.0, 60.0))
    m.direction.half_angle_rad = m.combined_half_angle_rad = deg_to_rad(half_angle_deg);
  double origin_z_m = m.frequency.grid_origin_z_m;
  if (r.number_in(fusion, "fusion", "grid_origin_z_m", origin_z_m, -10.0, 10.0, true))
    m.frequency.grid_origin_z_m = m.visibility.grid_origin_z_m = m.combined_grid_origin_z_m = origin_z_m;
  r.number_in(fusion, "fusion", "frequency_k", m.frequency.k, -100.0, 100.0, true);
  r.number_in(fusion, "fusion", "position_sigma_m", m.position.sigma_m, 0.0, 100.0);
  r.number_in(fusion, "fusion", "position_n", m.position.n, 0.0, 100.0);
  bool from_flags = m.direction.source == mapping::DirectionSource::flags;
  if (r.boolean(fusion, "fusion", "direction_from_flags", from_flags))
    m.direction.source = from_flags ? mapping::DirectionSource::flags : mapping::DirectionSource::recompute;
}

// [fusion]: the stage's files and cadence, the filters, the core; the methods' names are checked last
// (check_methods).
const toml::table* read_fusion(TomlReader& r, FusionOptions& f) {
  fusion::CoreOptions& core = f.core;
  double write_s = to_seconds(f.write_interval);
  double map_s = to_seconds(f.map_interval);
  const toml::table* fusion = r.section("fusion", false);
  r.only(fusion, "fusion", {"enabled", "method", "resolution_m", "half_angle_deg", "grid_origin_z_m", "frequency_k",
                            "position_sigma_m", "position_n", "direction_from_flags", "write_interval_s",
                            "write_all_points", "map_interval_s", "map_resolution_m", "latency_log", "hold_s", "team_lag_s",
                            "min_scan_interval_s",
                            "model_resolution_m", "max_points_per_voxel", "compare_methods", "write_slice_ms", "writer_cpus",
                            "catch_up_min_scans", "catch_up_quiet_s", "catch_up_slice_scans", "registration"});
  r.boolean(fusion, "fusion", "enabled", f.enabled);
  if (r.string(fusion, "fusion", "method", core.method, false) && core.method.empty())
    r.fail("fusion.method", "must not be empty", r.node(fusion, "method"));
  read_methods(r, fusion, core.methods);
  r.strings(fusion, "fusion", "compare_methods", f.compare_methods);
  r.number_in(fusion, "fusion", "write_slice_ms", f.write_slice_ms, 0.0, 1000.0, true);
  std::vector<std::int64_t> writer_cpus(f.writer_cpus.begin(), f.writer_cpus.end());
  if (r.integers_in(fusion, "fusion", "writer_cpus", writer_cpus, 0, CPU_SETSIZE - 1))
    f.writer_cpus.assign(writer_cpus.begin(), writer_cpus.end());
  r.number_in(fusion, "fusion", "write_interval_s", write_s, 0.0, 86400.0, true);
  bool all_points = !f.all_points_pcd.empty();
  if (r.boolean(fusion, "fusion", "write_all_points", all_points)) f.all_points_pcd = all_points ? "fused_all.pcd" : "";
  bool latency_log = !f.latency_log_csv.empty();
  if (r.boolean(fusion, "fusion", "latency_log", latency_log)) f.latency_log_csv = latency_log ? "fused_latency.csv" : "";
  r.number_in(fusion, "fusion", "map_interval_s", map_s, 0.0, 3600.0, true);
  r.number_in(fusion, "fusion", "map_resolution_m", f.map_resolution_m, 0.0, 10.0);
  r.number_in(fusion, "fusion", "hold_s", core.hold_s, 0.0, 60.0, true);
  r.number_in(fusion, "fusion", "team_lag_s", core.tracker.team_lag_s, 0.0, 10.0, true);
  r.number_in(fusion, "fusion", "min_scan_interval_s", core.min_scan_interval_s, 0.0, 1.0, true);
  r.number_in(fusion, "fusion", "model_resolution_m", core.model_resolution_m, 0.0, 10.0);
  std::int64_t max_per_voxel = core.max_points_per_voxel;
  r.integer_in(fusion, "fusion", "max_points_per_voxel", max_per_voxel, 0, 1'000'000);
  core.max_points_per_voxel = static_cast<std::uint32_t>(max_per_voxel);
  r.boolean(fusion, "fusion", "registration", core.registration);
  std::int64_t catch_up_min = f.catch_up_min_scans, catch_up_slice = f.catch_up_slice_scans;
  r.integer_in(fusion, "fusion", "catch_up_min_scans", catch_up_min, 0, 1'000'000'000);
  f.catch_up_min_scans = static_cast<std::uint32_t>(catch_up_min);
  r.number_in(fusion, "fusion", "catch_up_quiet_s", f.catch_up_quiet_s, 0.0, 3600.0, true);
  r.integer_in(fusion, "fusion", "catch_up_slice_scans", catch_up_slice, 0, 1'000'000);
  f.catch_up_slice_scans = static_cast<std::uint32_t>(catch_up_slice);
  f.write_interval = from_seconds(write_s);
  f.map_interval = from_seconds(map_s);
  return fusion;
}

// [registration]: its presence turns the core's registration on (unless `enabled = false`).
void read_registration(TomlReader& r, fusion::CoreOptions& core) {
  registration::RegistrationOptions& o = core.registration_options;
  const toml::table* reg = r.section("registration", false);
  r.only(reg, "registration",
         {"enabled", "window_s", "match_every_s", "match_delay_s", "cpus", "min_map_features", "robot", TEAMSCAN_PRIOR_KEYS});
  if (reg != nullptr) {
    core.registration = true;
    r.boolean(reg, "registration", "enabled", core.registration);
  }
  r.number_in(reg, "registration", "window_s", o.window_s, 0.0, 60.0);
  r.number_in(reg, "registration", "match_every_s", o.match_every_s, 0.0, 60.0, true);
  r.number_in(reg, "registration", "match_delay_s", o.match_delay_s, 0.0, 10.0, true);
  std::vector<std::int64_t> match_cpus(o.cpus.begin(), o.cpus.end());
  if (r.integers_in(reg, "registration", "cpus", match_cpus, 0, CPU_SETSIZE - 1)) o.cpus.assign(match_cpus.begin(), match_cpus.end());
  std::int64_t min_features = o.min_map_features;
  r.integer_in(reg, "registration", "min_map_features", min_features, 0, 1'000'000);
  o.min_map_features = static_cast<std::uint32_t>(min_features);
  read_priors(r, reg, o);
}

// [pose_graph]: the pose graph as the fusion core's back end (on unless `enabled = false`; absent: the
// defaults), with the returns it takes (fusion::PlanarReturnOptions) and how often the live map follows
// it (follow_s: GraphBackendOptions::estimate_every_s; 0: only the final model) and how
// (follow_rigidly, follow_min_shift_m, exact_follow_share, exact_follow_max_s: FusionOptions).
void read_pose_graph(TomlReader& r, FusionOptions& f) {
  const toml::table* graph = r.section("pose_graph", false);
  r.only(graph, "pose_graph", {"enabled", "min_height_m", "max_height_m", "node_s", "follow_s", "follow_rigidly", "follow_min_shift_m", "exact_follow_share", "exact_follow_max_s", "cpus"});
  if (graph == nullptr) return;
  bool enabled = true;
  r.boolean(graph, "pose_graph", "enabled", enabled);
  r.boolean(graph, "pose_graph", "follow_rigidly", f.follow_rigidly);
  r.number_in(graph, "pose_graph", "follow_min_shift_m", f.follow_min_shift_m, 0.0, 100.0, true);
  r.number_in(graph, "pose_graph", "exact_follow_share", f.exact_follow_share, 0.0, 1.0, true);
  r.number_in(graph, "pose_graph", "exact_follow_max_s", f.exact_follow_max_s, 0.0, 3600.0, true);
  fusion::GraphBackendOptions o = f.pose_graph.value_or(fusion::GraphBackendOptions{});
  r.number_in(graph, "pose_graph", "follow_s", o.estimate_every_s, 0.0, 3600.0, true);
  r.number_in(graph, "pose_graph", "min_height_m", o.returns.min_height_m, -10.0, 10.0, true);
  r.number_in(graph, "pose_graph", "max_height_m", o.returns.max_height_m, -10.0, 10.0, true);
  r.number_in(graph, "pose_graph", "node_s", o.returns.tilted_node_s, 0.0, 10.0);
  std::vector<std::int64_t> cpus(o.cpus.begin(), o.cpus.end());
  if (r.integers_in(graph, "pose_graph", "cpus", cpus, 0, CPU_SETSIZE - 1)) o.cpus.assign(cpus.begin(), cpus.end());
  if (o.returns.max_height_m <= o.returns.min_height_m)
    r.fail("pose_graph.max_height_m", "must be above pose_graph.min_height_m", r.node(graph, "max_height_m"));
  if (enabled) f.pose_graph = o;
  else f.pose_graph.reset();
}

void read_ros2(TomlReader& r, Ros2Config& ros) {
  double cloud_s = to_seconds(ros.map_interval);
  const toml::table* ros2 = r.section("ros2", false);
  r.only(ros2, "ros2", {"enabled", "map_interval_s", "pose_rate_hz", "heading_sigma_deg", "laser_mount"});
  r.boolean(ros2, "ros2", "enabled", ros.enabled);
  r.number_in(ros2, "ros2", "map_interval_s", cloud_s, 0.0, 3600.0);
  r.number_in(ros2, "ros2", "pose_rate_hz", ros.pose_rate_hz, 0.0, 1000.0);
  r.number_in(ros2, "ros2", "heading_sigma_deg", ros.heading_sigma_deg, 0.0, 180.0, true);
  read_laser_mounts(r, ros2, ros);
  ros.map_interval = from_seconds(cloud_s);
}

// The browser view: listen may be empty (off); a present value must be HOST:PORT.
void read_view(TomlReader& r, ViewConfig& o) {
  const toml::table* view = r.section("view", false);
  r.only(view, "view", {"listen", "web_root", "period_s", "cpus"});
  if (r.string(view, "view", "listen", o.listen, false) && !o.listen.empty()) {
    view::ListenAddress address;
    std::string why;
    if (!view::parse_listen(o.listen, address, why)) r.fail("view.listen", why, r.node(view, "listen"));
  }
  r.string(view, "view", "web_root", o.web_root, false);
  r.number_in(view, "view", "period_s", o.period_s, 0.0, 60.0);
  std::vector<std::int64_t> view_cpus(o.cpus.begin(), o.cpus.end());
  if (r.integers_in(view, "view", "cpus", view_cpus, 0, CPU_SETSIZE - 1)) o.cpus.assign(view_cpus.begin(), view_cpus.end());
}

// [validation] (sample_validation.hpp, docs/validation.md), the site's box checked as a whole.
bool read_validation(TomlReader& r, ValidationOptions& v) {
  double age_s = to_seconds(v.max_stamp_age), ahead_s = to_seconds(v.max_stamp_ahead);
  double warn_s = to_seconds(v.clock_offset_warn), vlog_s = to_seconds(v.log_interval);
  std::int64_t jump = v.max_seq_jump;
  const toml::table* val = r.section("validation", false);
  r.only(val, "validation", {"site_min_x_m", "site_max_x_m", "site_min_y_m", "site_max_y_m", "site_min_z_m",
                             "site_max_z_m", "max_stamp_age_s", "max_stamp_ahead_s", "clock_offset_warn_s",
                             "max_speed_mps", "max_yaw_rate_radps", "max_seq_jump", "log_interval_s"});
  r.number_in(val, "validation", "site_min_x_m", v.site_min_x_m, -1e7, 1e7, true);
  r.number_in(val, "validation", "site_max_x_m", v.site_max_x_m, -1e7, 1e7, true);
  r.number_in(val, "validation", "site_min_y_m", v.site_min_y_m, -1e7, 1e7, true);
  r.number_in(val, "validation", "site_max_y_m", v.site_max_y_m, -1e7, 1e7, true);
  r.number_in(val, "validation", "site_min_z_m", v.site_min_z_m, -1e7, 1e7, true);
  r.number_in(val, "validation", "site_max_z_m", v.site_max_z_m, -1e7, 1e7, true);
  r.number_in(val, "validation", "max_stamp_age_s", age_s, 0.0, 86400.0);
  r.number_in(val, "validation", "max_stamp_ahead_s", ahead_s, 0.0, 86400.0, true);
  r.number_in(val, "validation", "clock_offset_warn_s", warn_s, 0.0, 86400.0);
  r.number_in(val, "validation", "max_speed_mps", v.max_speed_mps, 0.0, 1000.0);
  r.number_in(val, "validation", "max_yaw_rate_radps", v.max_yaw_rate_radps, 0.0, 1000.0);
  r.integer_in(val, "validation", "max_seq_jump", jump, 1, 1'000'000'000);
  r.number_in(val, "validation", "log_interval_s", vlog_s, 0.0, 86400.0, true);
  if (r.failed()) return false;
  if (!(v.site_min_x_m < v.site_max_x_m && v.site_min_y_m < v.site_max_y_m && v.site_min_z_m < v.site_max_z_m)) {
    return r.fail("validation", "each site_min_*_m must be below its site_max_*_m", val);
  }
  v.max_stamp_age = from_seconds(age_s);
  v.max_stamp_ahead = from_seconds(ahead_s);
  v.clock_offset_warn = from_seconds(warn_s);
  v.log_interval = from_seconds(vlog_s);
  v.max_seq_jump = static_cast<std::uint32_t>(jump);
  return true;
}

// The primary method and the compared ones (groundstation/mapping make_filter; docs/beyond.md): known,
// and each compared one not the primary (it is decided anyway) and listed once: refused, not ignored.
bool check_methods(TomlReader& r, const FusionOptions& f, const toml::table* fusion) {
  static const char* const kMethods[] = {"frequency", "visibility", "position", "direction", "combined",
                                         "freespace", "tracked",    "best"};
  auto known = [&](const std::string& method) {
    for (const char* m : kMethods)
      if (method == m) return true;
    return false;
  };
  const std::string& primary = f.core.method;
  if (!known(primary)) {
    return r.fail("fusion.method", "must be frequency, visibility, position, direction, combined, freespace, tracked "
                                   "or best, got \"" + primary + "\"", r.node(fusion, "method"));
  }
  for (std::size_t i = 0; i < f.compare_methods.size(); ++i) {
    const std::string& m = f.compare_methods[i];
    const toml::node* at = r.node(fusion, "compare_methods");
    if (!known(m)) {
      return r.fail("fusion.compare_methods", "must list methods among frequency, visibility, position, direction, "
                                              "combined, freespace, tracked and best, got \"" + m + "\"", at);
    }
    if (m == primary) {
      return r.fail("fusion.compare_methods", "\"" + m + "\" is fusion.method (the primary model); list only other methods", at);
    }
    for (std::size_t j = 0; j < i; ++j)
      if (f.compare_methods[j] == m) return r.fail("fusion.compare_methods", "\"" + m + "\" is listed twice", at);
  }
  return true;
}

bool check_team_source(TomlReader& r, const std::string& source, const toml::table* team, TeamSourceKind& kind) {
  if (source == "kalman") {
    kind = TeamSourceKind::kKalman;
  } else if (source == "last_pose") {
    kind = TeamSourceKind::kLastPose;
  } else {
    return r.fail("team.source", "must be \"kalman\" or \"last_pose\", got \"" + source + "\"", r.node(team, "source"));
  }
  return true;
}

}  // namespace

FusionOptions station_fusion_defaults() {
  FusionOptions o;
  o.core.methods.frequency.resolution_m = 0.1;
  o.core.methods.visibility.resolution_m = 0.1;
  return o;
}

// Every section in the order of deploy/groundstation.toml; the first error is the one reported, and
// `out` is changed only when the whole text is good.
bool parse_groundstation_config(const std::string& toml_text, const std::string& source_name, GroundStationConfig& out,
                                ConfigError& error) {
  toml::table root;
  if (!parse_toml(toml_text, source_name, root, error)) return false;
  TomlReader r(root, error.message);
  GroundStationConfig c = out;
  std::string source = c.team_source == TeamSourceKind::kKalman ? "kalman" : "last_pose";
  r.top_level({"station", "dds", "team", "fusion", "registration", "pose_graph", "ros2", "view", "validation"});
  read_station(r, c);
  read_dds(r, c.station);
  const toml::table* team = read_team(r, c, source);
  read_kalman(r, c.fusion.core.tracker);
  const toml::table* fusion = read_fusion(r, c.fusion);
  read_registration(r, c.fusion.core);
  read_pose_graph(r, c.fusion);
  read_ros2(r, c.ros2);
  read_view(r, c.view);
  if (r.failed()) return false;
  if (!read_validation(r, c.station.validation)) return false;
  if (!check_methods(r, c.fusion, fusion)) return false;
  if (!check_team_source(r, source, team, c.team_source)) return false;
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

#undef TEAMSCAN_PRIOR_KEYS

bool load_registration_priors(const std::string& path, registration::RegistrationOptions& options, ConfigError& error) {
  GroundStationConfig c;
  registration::RegistrationOptions& read = c.fusion.core.registration_options;
  read.prior = options.prior;
  read.robot_priors = options.robot_priors;
  if (!load_groundstation_config(path, c, error)) return false;
  options.prior = read.prior;
  options.robot_priors = read.robot_priors;
  return true;
}

}  // namespace teamscan::station
