// A session folder as an MCAP file (session_mcap.hpp). Messages are encoded by Cyclone's own XCDR1
// serialiser over the idlc types of idl/ros2_wire.idl (the bytes rt/ topics carry, ROS2_WIRE.md 4); the
// status message, which has no IDL type, by the same rules in StatusCdr.
#include "tools/mcap_export/session_mcap.hpp"

#include <dds/dds.h>
#include <dds/ddsi/ddsi_cdrstream.h>
#include <dds/ddsi/q_protocol.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <map>
#include <sstream>

#include "common/dataset/pcd.hpp"
#include "common/point_flags.hpp"
#include "common/pose.hpp"
#include "dds/ros2/wire.hpp"
#include "groundstation/fusion/pose_history.hpp"
#include "groundstation/station/fusion.hpp"
#include "groundstation/station/session_replay.hpp"
#include "onboard/core/config.hpp"
#include "ros2_wire.h"
#include "tools/mcap_export/ros2_definitions.hpp"

namespace teamscan::mcap_export {
namespace {

using mcap::Bytes;

std::string odom_frame(std::uint32_t robot) { return "robot" + std::to_string(robot) + "/odom"; }
std::string laser_frame(std::uint32_t robot) { return "robot" + std::to_string(robot) + "/laser"; }
std::string robot_topic(std::uint32_t robot, const char* name) { return "/robot" + std::to_string(robot) + "/" + name; }
std::uint64_t log_time(std::int64_t ns) { return ns < 0 ? 0u : static_cast<std::uint64_t>(ns); }

// One sample in XCDR1 little-endian with the 4-byte encapsulation header (00 01 00 00, as rmw writes it).
template <class T>
void encode_cdr(const dds_topic_descriptor_t& desc, const T& sample, Bytes& out) {
  dds_ostreamLE_t os;
  dds_ostreamLE_init(&os, 0, CDR_ENC_VERSION_1);
  (void)dds_stream_writeLE(&os, reinterpret_cast<const char*>(&sample), desc.m_ops);
  out.assign({0x00, 0x01, 0x00, 0x00});
  out.insert(out.end(), os.x.m_buffer, os.x.m_buffer + os.x.m_index);
  dds_ostreamLE_fini(&os);
}

// XCDR1 by hand for teamscan_msgs/msg/RobotStatus: each primitive aligned to its size from the first
// byte after the encapsulation header, little-endian.
class StatusCdr {
 public:
  explicit StatusCdr(Bytes& out) : out_{out} { out_.assign({0x00, 0x01, 0x00, 0x00}); }
  void put(std::uint64_t v, std::size_t size) {
    while ((out_.size() - 4) % size != 0) out_.push_back(0);
    for (std::size_t i = 0; i < size; ++i) out_.push_back(static_cast<std::uint8_t>(v >> (8 * i)));
  }
  void string(const std::string& s) {
    put(s.size() + 1, 4);
    out_.insert(out_.end(), s.begin(), s.end());
    out_.push_back(0);
  }

 private:
  Bytes& out_;
};

geometry_msgs_msg_dds__Quaternion_ quaternion(const Rot3& r) {
  const auto& m = r.m;
  const double trace = m[0][0] + m[1][1] + m[2][2];
  geometry_msgs_msg_dds__Quaternion_ q{};
  if (trace > 0) {
    const double s = 2.0 * std::sqrt(1.0 + trace);
    q = {(m[2][1] - m[1][2]) / s, (m[0][2] - m[2][0]) / s, (m[1][0] - m[0][1]) / s, 0.25 * s};
  } else if (m[0][0] > m[1][1] && m[0][0] > m[2][2]) {
    const double s = 2.0 * std::sqrt(1.0 + m[0][0] - m[1][1] - m[2][2]);
    q = {0.25 * s, (m[0][1] + m[1][0]) / s, (m[0][2] + m[2][0]) / s, (m[2][1] - m[1][2]) / s};
  } else if (m[1][1] > m[2][2]) {
    const double s = 2.0 * std::sqrt(1.0 + m[1][1] - m[0][0] - m[2][2]);
    q = {(m[0][1] + m[1][0]) / s, 0.25 * s, (m[1][2] + m[2][1]) / s, (m[0][2] - m[2][0]) / s};
  } else {
    const double s = 2.0 * std::sqrt(1.0 + m[2][2] - m[0][0] - m[1][1]);
    q = {(m[0][2] + m[2][0]) / s, (m[1][2] + m[2][1]) / s, 0.25 * s, (m[1][0] - m[0][1]) / s};
  }
  return q;
}

// One transform of a TFMessage, with the strings it points into.
struct Transform {
  std::string parent, child;
  std::int64_t stamp_ns = 0;
  Pose3 parent_from_child;
};

void encode_tf(const std::vector<Transform>& tfs, Bytes& out) {
  std::vector<geometry_msgs_msg_dds__TransformStamped_> ts(tfs.size());
  for (std::size_t i = 0; i < tfs.size(); ++i) {
    const Transform& t = tfs[i];
    ts[i].header.stamp = dds::ros2::ros_time(t.stamp_ns);
    ts[i].header.frame_id = const_cast<char*>(t.parent.c_str());
    ts[i].child_frame_id = const_cast<char*>(t.child.c_str());
    const Vec3& p = t.parent_from_child.translation;
    ts[i].transform.translation = {p.x, p.y, p.z};
    ts[i].transform.rotation = quaternion(t.parent_from_child.rotation);
  }
  tf2_msgs_msg_dds__TFMessage_ msg{};
  msg.transforms = {static_cast<std::uint32_t>(ts.size()), static_cast<std::uint32_t>(ts.size()), ts.data(), false};
  encode_cdr(tf2_msgs_msg_dds__TFMessage__desc, msg, out);
}

// A scan as PointCloud2 in robotN/odom: x y z FLOAT32 (m), beam UINT16, flags UINT16 (the wire's point
// flags, common/point_flags.hpp), 16 bytes a point; points without a position (kPointUnplaced) are NaN.
void encode_scan(const ScanPoints& s, Bytes& data, Bytes& out) {
  static char kX[] = "x", kY[] = "y", kZ[] = "z", kBeam[] = "beam", kFlags[] = "flags";
  sensor_msgs_msg_dds__PointField_ fields[] = {
      {kX, 0, sensor_msgs_msg_dds__PointField_Constants_FLOAT32, 1},
      {kY, 4, sensor_msgs_msg_dds__PointField_Constants_FLOAT32, 1},
      {kZ, 8, sensor_msgs_msg_dds__PointField_Constants_FLOAT32, 1},
      {kBeam, 12, sensor_msgs_msg_dds__PointField_Constants_UINT16, 1},
      {kFlags, 14, sensor_msgs_msg_dds__PointField_Constants_UINT16, 1},
  };
  const std::size_t n = std::min<std::size_t>(s.count, kMaxBeams);
  data.resize(n * 16);
  bool dense = true;
  for (std::size_t i = 0; i < n; ++i) {
    const ScanPoint& p = s.points[i];
    const bool placed = (p.flags & kPointUnplaced) == 0;
    dense = dense && placed;
    const float nan = std::numeric_limits<float>::quiet_NaN();
    const float xyz[3] = {placed ? static_cast<float>(p.x_mm * 1e-3) : nan,
                          placed ? static_cast<float>(p.y_mm * 1e-3) : nan,
                          placed ? static_cast<float>(p.z_mm * 1e-3) : nan};
    std::memcpy(&data[i * 16], xyz, 12);
    std::memcpy(&data[i * 16 + 12], &p.beam, 2);
    std::memcpy(&data[i * 16 + 14], &p.flags, 2);
  }
  std::string frame = odom_frame(s.robot_id);
  sensor_msgs_msg_dds__PointCloud2_ msg{};
  msg.header.stamp = dds::ros2::ros_time(s.stamp.ns());
  msg.header.frame_id = frame.data();
  msg.height = 1;
  msg.width = static_cast<std::uint32_t>(n);
  msg.fields = {5, 5, fields, false};
  msg.is_bigendian = false;
  msg.point_step = 16;
  msg.row_step = static_cast<std::uint32_t>(n * 16);
  msg.data = {static_cast<std::uint32_t>(data.size()), static_cast<std::uint32_t>(data.size()), data.data(), false};
  msg.is_dense = dense;
  encode_cdr(sensor_msgs_msg_dds__PointCloud2__desc, msg, out);
}

// nav_msgs/Odometry of a pose: pose in robotN/odom, twist in robotN/base_link (REP-105); no covariance
// (the robot reports none: all 0).
void encode_odometry(const station::PoseObservation& p, Bytes& out) {
  std::string frame = odom_frame(p.robot_id), child = dds::ros2::base_link_frame(p.robot_id);
  nav_msgs_msg_dds__Odometry_ msg{};
  msg.header.stamp = dds::ros2::ros_time(p.stamp.ns());
  msg.header.frame_id = frame.data();
  msg.child_frame_id = child.data();
  msg.pose.pose.position = {p.x_m, p.y_m, 0.0};
  msg.pose.pose.orientation = dds::ros2::yaw_quaternion(p.yaw_rad);
  const double c = std::cos(p.yaw_rad), s = std::sin(p.yaw_rad);
  msg.twist.twist.linear = {c * p.vx_mps + s * p.vy_mps, -s * p.vx_mps + c * p.vy_mps, 0.0};
  msg.twist.twist.angular = {0.0, 0.0, p.yaw_rate_radps};
  encode_cdr(nav_msgs_msg_dds__Odometry__desc, msg, out);
}

// nav_msgs/Odometry of a robot's Kalman track (the team state the station publishes on teamscan/team):
// position and the last measured heading in `map`, position covariance (x, y) and the heading's σ² in
// the 6x6 row-major covariance (x y z roll pitch yaw), velocity rotated into robotN/base_link.
void encode_track(const mapping::RobotEstimate& e, Bytes& out) {
  std::string frame = dds::ros2::kFrameMap, child = dds::ros2::base_link_frame(e.robot);
  nav_msgs_msg_dds__Odometry_ msg{};
  msg.header.stamp = dds::ros2::ros_time(e.stamp_ns);
  msg.header.frame_id = frame.data();
  msg.child_frame_id = child.data();
  msg.pose.pose.position = {e.position_m.x, e.position_m.y, 0.0};
  msg.pose.pose.orientation = dds::ros2::yaw_quaternion(e.heading_rad);
  msg.pose.covariance[0] = e.position_cov_m2(0, 0);
  msg.pose.covariance[1] = e.position_cov_m2(0, 1);
  msg.pose.covariance[6] = e.position_cov_m2(1, 0);
  msg.pose.covariance[7] = e.position_cov_m2(1, 1);
  msg.pose.covariance[35] = e.heading_sigma_rad * e.heading_sigma_rad;
  const double c = std::cos(e.heading_rad), s = std::sin(e.heading_rad);
  msg.twist.twist.linear = {c * e.velocity_mps.x + s * e.velocity_mps.y, -s * e.velocity_mps.x + c * e.velocity_mps.y,
                            0.0};
  encode_cdr(nav_msgs_msg_dds__Odometry__desc, msg, out);
}

struct StatusRow {
  std::int64_t recv_realtime_ns = 0;
  std::uint32_t robot_id = 0;
  std::uint32_t seq = 0;
  std::int64_t stamp_ns = 0;
  std::vector<std::int64_t> values;  // every column
};

bool valid_field_name(const std::string& s) {
  if (s.empty() || !std::islower(static_cast<unsigned char>(s[0]))) return false;
  for (char c : s)
    if (!(std::islower(static_cast<unsigned char>(c)) || std::isdigit(static_cast<unsigned char>(c)) || c == '_'))
      return false;
  return true;
}

// status.csv: its columns (the header row) and every row that parses; a missing file is empty.
bool read_status(const std::string& path, std::vector<std::string>& columns, std::vector<StatusRow>& rows,
                 std::uint64_t& bad_lines, std::string& message) {
  std::ifstream in(path);
  if (!in) return true;
  std::string line;
  if (!std::getline(in, line)) return true;
  std::stringstream header(line);
  for (std::string c; std::getline(header, c, ',');) columns.push_back(c);
  static const char* const kFirst[] = {"recv_realtime_ns", "recv_monotonic_ns", "robot_id", "seq", "stamp_ns"};
  bool ok = columns.size() >= 5;
  for (std::size_t i = 0; ok && i < 5; ++i) ok = columns[i] == kFirst[i];
  for (const std::string& c : columns) ok = ok && valid_field_name(c);
  if (!ok) {
    message =
        path + ": line 1 is not a status.csv header (recv_realtime_ns,recv_monotonic_ns,robot_id,seq,stamp_ns,...)";
    return false;
  }
  while (std::getline(in, line)) {
    if (line.empty()) continue;
    StatusRow r;
    const char* p = line.c_str();
    bool good = true;
    for (std::size_t i = 0; i < columns.size() && good; ++i) {
      char* end = nullptr;
      errno = 0;
      const long long v = std::strtoll(p, &end, 10);
      good = end != p && errno == 0 && (*end == (i + 1 == columns.size() ? '\0' : ','));
      r.values.push_back(v);
      p = end + (*end == ',' ? 1 : 0);
    }
    if (!good) {
      ++bad_lines;
      continue;
    }
    r.recv_realtime_ns = r.values[0];
    r.robot_id = static_cast<std::uint32_t>(r.values[2]);
    r.seq = static_cast<std::uint32_t>(r.values[3]);
    r.stamp_ns = r.values[4];
    rows.push_back(std::move(r));
  }
  return true;
}

void encode_status(const StatusRow& r, Bytes& out) {
  StatusCdr c(out);
  const builtin_interfaces_msg_dds__Time_ t = dds::ros2::ros_time(r.stamp_ns);
  c.put(static_cast<std::uint32_t>(t.sec), 4);
  c.put(t.nanosec, 4);
  c.string("");
  for (std::int64_t v : r.values) c.put(static_cast<std::uint64_t>(v), 8);
}

// The writer's channels: shared ones at once, per-robot ones on a robot's first message.
class Channels {
 public:
  Channels(mcap::Writer& w, const std::vector<std::string>& status_columns) : w_{w} {
    cloud_ = w.add_schema("sensor_msgs/msg/PointCloud2", kSchemaEncoding, point_cloud2_definition());
    tf_ = w.add_schema("tf2_msgs/msg/TFMessage", kSchemaEncoding, tf_message_definition());
    odom_ = w.add_schema("nav_msgs/msg/Odometry", kSchemaEncoding, odometry_definition());
    if (!status_columns.empty()) {
      status_ = w.add_schema("teamscan_msgs/msg/RobotStatus", kSchemaEncoding, robot_status_definition(status_columns));
    }
    tf_static_channel = add(tf_, "/tf_static");
    tf_channel = add(tf_, "/tf");
    map_channel = add(cloud_, "/teamscan/map_cloud");
  }
  std::uint16_t scan(std::uint32_t robot) { return per_robot(scans_, robot, cloud_, "scan"); }
  std::uint16_t odometry(std::uint32_t robot) { return per_robot(odometry_, robot, odom_, "odom"); }
  std::uint16_t track(std::uint32_t robot) { return per_robot(tracks_, robot, odom_, "track"); }
  std::uint16_t status(std::uint32_t robot) { return per_robot(statuses_, robot, status_, "status"); }
  std::uint16_t tf_static_channel = 0, tf_channel = 0, map_channel = 0;

 private:
  std::uint16_t add(std::uint16_t schema, const std::string& topic) {
    // The ros2 profile's one required key (rosbag2 writes the publishers' QoS there as YAML; none here).
    return w_.add_channel(schema, topic, kMessageEncoding, {{"offered_qos_profiles", ""}});
  }
  std::uint16_t per_robot(std::map<std::uint32_t, std::uint16_t>& m, std::uint32_t robot, std::uint16_t schema,
                          const char* name) {
    auto it = m.find(robot);
    if (it == m.end()) it = m.emplace(robot, add(schema, robot_topic(robot, name))).first;
    return it->second;
  }
  mcap::Writer& w_;
  std::uint16_t cloud_ = 0, tf_ = 0, odom_ = 0, status_ = 0;
  std::map<std::uint32_t, std::uint16_t> scans_, odometry_, tracks_, statuses_;
};

bool is_directory(const std::string& path) {
  struct stat st {};
  return ::stat(path.c_str(), &st) == 0 && S_ISDIR(st.st_mode);
}
bool exists(const std::string& path) { return ::access(path.c_str(), F_OK) == 0; }

}  // namespace

namespace {

// The export's state while the session streams through it, in receive order.
class Exporter {
 public:
  Exporter(mcap::Writer& w, const std::vector<std::string>& status_columns, std::vector<StatusRow> statuses,
           std::map<std::uint32_t, Pose3> mounts, SessionExportSummary& summary)
      : w_{w},
        channels_{w, status_columns},
        statuses_{std::move(statuses)},
        mounts_{std::move(mounts)},
        sum_{summary},
        tracks_{fusion::PoseHistoryOptions{}} {}  // the tracker's defaults: a station without [team.kalman]

  void on_pose(const station::PoseObservation& p) {
    before(p.received.ns());
    encode_odometry(p, buf_);
    write(channels_.odometry(p.robot_id), p.seq, p.received.ns(), p.stamp.ns());
    ++sum_.poses;
    // map -> robotN/odom (the correction in force: the one the robot's last scan carried) and
    // robotN/odom -> robotN/base_link (this pose), one TFMessage.
    const Pose2 correction = corrections_[p.robot_id].map_from_odom();
    std::vector<Transform> tfs = {
        {dds::ros2::kFrameMap, odom_frame(p.robot_id), p.stamp.ns(), Pose3::from_pose2(correction)},
        {odom_frame(p.robot_id), dds::ros2::base_link_frame(p.robot_id), p.stamp.ns(),
         Pose3::from_pose2(Pose2{p.x_m, p.y_m, p.yaw_rad})}};
    encode_tf(tfs, buf_);
    write(channels_.tf_channel, static_cast<std::uint32_t>(sum_.tf_messages), p.received.ns(), p.stamp.ns());
    ++sum_.tf_messages;
    // The robot's track as the station publishes it at this moment: its newest pose folded in,
    // predicted to the receive time.
    if (tracks_.add(station::pose_input(p))) {
      const mapping::TeamState team = tracks_.newest_tracks_at(p.received.ns());
      const mapping::RobotEstimate* e = team.find(static_cast<std::uint8_t>(p.robot_id));
      if (e != nullptr && e->valid) {
        encode_track(*e, buf_);
        write(channels_.track(p.robot_id), p.seq, p.received.ns(), e->stamp_ns);
        ++sum_.tracks;
      }
    }
  }

  void on_scan(const ScanPoints& s, const station::Receipt& receipt) {
    before(receipt.recv_realtime_ns);
    // A correction the robot applied for the first time: the station's map_from_odom from this stamp on.
    if (!s.applied.none() && s.applied.seq != corrections_[s.robot_id].seq && s.robot_id <= kMaxRobots) {
      tracks_.set_map_from_odom(static_cast<std::uint8_t>(s.robot_id), s.stamp.ns(), s.applied.map_from_odom());
    }
    corrections_[s.robot_id] = s.applied;
    encode_scan(s, points_, buf_);
    write(channels_.scan(s.robot_id), s.seq, receipt.recv_realtime_ns, s.stamp.ns());
    ++sum_.scans;
  }

  // The status rows left, then the fused model at the last message's time.
  void finish(const PcdCloud* model) {
    before(std::numeric_limits<std::int64_t>::max());
    if (model == nullptr) return;
    std::vector<dds::ros2::CloudPoint> points(model->xyz.size() / 3);
    for (std::size_t i = 0; i < points.size(); ++i) {
      points[i] = {model->xyz[3 * i], model->xyz[3 * i + 1], model->xyz[3 * i + 2], 1.0f};
    }
    dds::ros2::PointCloudMessage cloud;
    cloud.set(last_ns_, dds::ros2::kFrameMap, points);
    encode_cdr(sensor_msgs_msg_dds__PointCloud2__desc, cloud.msg(), buf_);
    write(channels_.map_channel, 0, last_ns_, last_ns_);
    sum_.model_points = points.size();
  }

  [[nodiscard]] const Status& status() const { return status_; }

 private:
  // Before a message received at `t_ns`: /tf_static once, then every status row received up to it.
  void before(std::int64_t t_ns) {
    if (!static_written_ && t_ns != std::numeric_limits<std::int64_t>::max()) write_static(t_ns);
    while (next_status_ < statuses_.size() && statuses_[next_status_].recv_realtime_ns <= t_ns) {
      const StatusRow& r = statuses_[next_status_++];
      if (!static_written_) write_static(r.recv_realtime_ns);
      encode_status(r, buf_);
      write(channels_.status(r.robot_id), r.seq, r.recv_realtime_ns, r.stamp_ns);
      ++sum_.statuses;
    }
  }
  // robotN/base_link -> robotN/laser for every robot with a config, all in one TFMessage (as tf2's
  // static broadcaster sends them).
  void write_static(std::int64_t t_ns) {
    static_written_ = true;
    std::vector<Transform> tfs;
    for (const auto& [robot, mount] : mounts_) {
      tfs.push_back({dds::ros2::base_link_frame(robot), laser_frame(robot), t_ns, mount});
    }
    if (tfs.empty()) return;
    encode_tf(tfs, buf_);
    write(channels_.tf_static_channel, 0, t_ns, t_ns);
    sum_.laser_frames = tfs.size();
  }
  void write(std::uint16_t channel, std::uint32_t seq, std::int64_t log_ns, std::int64_t publish_ns) {
    last_ns_ = std::max(last_ns_, log_ns);
    if (!status_.ok()) return;
    status_ = w_.write(channel, seq, log_time(log_ns), log_time(publish_ns), buf_);
  }

  mcap::Writer& w_;
  Channels channels_;
  std::vector<StatusRow> statuses_;
  std::size_t next_status_ = 0;
  std::map<std::uint32_t, Pose3> mounts_;
  std::map<std::uint32_t, OdomCorrection> corrections_;
  SessionExportSummary& sum_;
  bool static_written_ = false;
  std::int64_t last_ns_ = 0;
  Bytes buf_, points_;
  Status status_ = ok_status();
  fusion::PoseHistory tracks_;
};

Result<SessionExportSummary> fail(std::string& message, std::string text) {
  message = std::move(text);
  return Error{"teamscan export: cannot export the session"};
}

}  // namespace

Result<SessionExportSummary> export_session_mcap(const std::string& dir, const std::string& out_path,
                                                 const SessionExportOptions& options, std::string& message) {
  if (!is_directory(dir)) return fail(message, dir + ": no such folder");
  if (!exists(dir + "/scans.bin") && !exists(dir + "/poses.csv")) {
    return fail(message, dir + ": not a ground-station session folder (it has neither scans.bin nor poses.csv)");
  }
  std::map<std::uint32_t, Pose3> mounts;
  for (const std::string& path : options.robot_configs) {
    std::string why;
    Result<onboard::OnboardConfig> cfg = onboard::load_onboard_config(path, why);
    if (!cfg) return fail(message, why.empty() ? path + ": " + cfg.error().what : why);  // `why` names the file
    mounts[cfg->robot_id] = cfg->mount.robot_from_laser();
  }
  SessionExportSummary sum;
  std::vector<std::string> status_columns;
  std::vector<StatusRow> statuses;
  if (!read_status(dir + "/status.csv", status_columns, statuses, sum.bad_lines, message))
    return fail(message, message);
  std::unique_ptr<PcdCloud> model;
  if (const std::string path = dir + "/" + options.model_file; exists(path)) {
    Result<PcdCloud> cloud = read_pcd(path);
    if (!cloud) return fail(message, path + ": " + cloud.error().what);
    model = std::make_unique<PcdCloud>(std::move(cloud.value()));
  }

  const std::string partial = out_path + ".partial";  // renamed to out_path once complete
  Result<std::unique_ptr<mcap::Writer>> writer = mcap::Writer::to_file(partial, options.writer);
  if (!writer) return fail(message, out_path + ": cannot create: " + std::strerror(writer.error().sys_errno));
  mcap::Writer& w = *writer.value();
  Exporter ex(w, status_columns, std::move(statuses), std::move(mounts), sum);
  station::SessionReadStats read;
  Status replayed = station::replay_session_files(
      dir, [&](const station::PoseObservation& p) { ex.on_pose(p); },
      [&](const ScanPoints& s, const station::Receipt& receipt) { ex.on_scan(s, receipt); }, read);
  if (replayed.ok()) ex.finish(model.get());
  Status closed = ex.status().ok() ? w.close() : ex.status();
  if (!replayed.ok() || !closed.ok()) {
    std::remove(partial.c_str());
    if (!replayed.ok()) {
      return fail(
          message,
          dir + ": " + replayed.error().what +
              (replayed.error().sys_errno != 0 ? std::string(": ") + std::strerror(replayed.error().sys_errno) : ""));
    }
    return fail(message, out_path + ": " + closed.error().what + ": " + std::strerror(closed.error().sys_errno));
  }
  if (std::rename(partial.c_str(), out_path.c_str()) != 0) {
    std::remove(partial.c_str());
    return fail(message, out_path + ": cannot rename the finished file into place: " + std::strerror(errno));
  }
  sum.refused_scans = read.refused_scans;
  sum.refused_poses = read.refused_poses;
  sum.damaged_scan_records = read.bad_scan_records;
  sum.bad_lines += read.bad_pose_lines;
  sum.scans_torn_tail = read.scans_torn_tail;
  sum.messages = w.counters().messages;
  sum.chunks = w.counters().chunks;
  sum.bytes = w.counters().bytes;
  return sum;
}

}  // namespace teamscan::mcap_export
