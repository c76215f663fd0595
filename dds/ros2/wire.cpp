// The ROS 2 messages, names and QoS of wire.hpp, and the rt/ writers.
#include "dds/ros2/wire.hpp"

#include <bit>
#include <cmath>
#include <cstring>

namespace teamscan::dds::ros2 {
namespace {

// PointCloudMessage copies CloudPoints as bytes and says is_bigendian = false.
static_assert(std::endian::native == std::endian::little);

dds_qos_t* writer_qos(bool transient_local, std::int32_t depth) {
  dds_qos_t* q = dds_create_qos();
  dds_qset_reliability(q, DDS_RELIABILITY_RELIABLE, DDS_MSECS(100));
  dds_qset_durability(q, transient_local ? DDS_DURABILITY_TRANSIENT_LOCAL : DDS_DURABILITY_VOLATILE);
  dds_qset_history(q, DDS_HISTORY_KEEP_LAST, depth);
  // XCDR1 only, as rmw_cyclonedds and rmw_fastrtps accept (ROS2_WIRE.md 2): the types are @final, so
  // this is also what Cyclone would pick; saying it keeps a later IDL change from going XCDR2 silently.
  const dds_data_representation_id_t xcdr1 = DDS_DATA_REPRESENTATION_XCDR1;
  dds_qset_data_representation(q, 1, &xcdr1);
  dds_qset_userdata(q, kWriterUserData, std::strlen(kWriterUserData));
  return q;
}

// The C types take char* for strings they only read here.
char* c_str(const std::string& s) { return const_cast<char*>(s.c_str()); }
char* c_str(const char* s) { return const_cast<char*>(s); }

}  // namespace

std::string odometry_topic(std::uint32_t robot_id) { return "rt/robot" + std::to_string(robot_id) + "/odom"; }
std::string scan_topic(std::uint32_t robot_id) { return "rt/robot" + std::to_string(robot_id) + "/scan"; }
std::string base_link_frame(std::uint32_t robot_id) { return "robot" + std::to_string(robot_id) + "/base_link"; }

dds_qos_t* make_map_cloud_writer_qos() { return writer_qos(true, 1); }
dds_qos_t* make_tf_writer_qos() { return writer_qos(false, 100); }
dds_qos_t* make_tf_static_writer_qos() { return writer_qos(true, 1); }
dds_qos_t* make_odometry_writer_qos() { return writer_qos(false, 10); }
dds_qos_t* make_scan_writer_qos() { return writer_qos(false, 5); }

dds_qos_t* make_rmw_like_reader_qos(bool reliable, bool transient_local, std::int32_t depth) {
  dds_qos_t* q = dds_create_qos();
  dds_qset_reliability(q, reliable ? DDS_RELIABILITY_RELIABLE : DDS_RELIABILITY_BEST_EFFORT, DDS_MSECS(100));
  dds_qset_durability(q, transient_local ? DDS_DURABILITY_TRANSIENT_LOCAL : DDS_DURABILITY_VOLATILE);
  dds_qset_history(q, DDS_HISTORY_KEEP_LAST, depth);
  const dds_data_representation_id_t xcdr1 = DDS_DATA_REPRESENTATION_XCDR1;
  dds_qset_data_representation(q, 1, &xcdr1);
  return q;
}

builtin_interfaces_msg_dds__Time_ ros_time(std::int64_t stamp_ns) {
  constexpr std::int64_t kNsPerS = 1'000'000'000;
  std::int64_t sec = stamp_ns / kNsPerS;
  std::int64_t ns = stamp_ns % kNsPerS;
  if (ns < 0) {
    ns += kNsPerS;
    --sec;
  }
  return {static_cast<std::int32_t>(sec), static_cast<std::uint32_t>(ns)};
}

geometry_msgs_msg_dds__Quaternion_ yaw_quaternion(double yaw_rad) {
  return {0.0, 0.0, std::sin(yaw_rad / 2.0), std::cos(yaw_rad / 2.0)};
}

PointCloudMessage::PointCloudMessage(const char* fourth) : fourth_{fourth} {
  const char* const names[] = {"x", "y", "z", fourth_.c_str()};
  for (std::uint32_t i = 0; i < 4; ++i) {
    fields_.push_back({c_str(names[i]), 4 * i, sensor_msgs_msg_dds__PointField_Constants_FLOAT32, 1});
  }
  msg_.height = 1;
  msg_.fields = {static_cast<std::uint32_t>(fields_.size()), static_cast<std::uint32_t>(fields_.size()),
                 fields_.data(), false};
  msg_.is_bigendian = false;
  msg_.point_step = sizeof(CloudPoint);
  msg_.is_dense = true;
}

void PointCloudMessage::set(std::int64_t stamp_ns, const std::string& frame_id, std::span<const CloudPoint> points) {
  frame_id_ = frame_id;
  msg_.header.stamp = ros_time(stamp_ns);
  msg_.header.frame_id = c_str(frame_id_);
  // CloudPoint is four packed little-endian float32 on this platform: the bytes are the layout.
  data_.resize(points.size_bytes());
  if (!points.empty()) std::memcpy(data_.data(), points.data(), points.size_bytes());
  msg_.width = static_cast<std::uint32_t>(points.size());
  msg_.row_step = msg_.width * msg_.point_step;
  msg_.data = {static_cast<std::uint32_t>(data_.size()), static_cast<std::uint32_t>(data_.size()), data_.data(), false};
}

RobotFrames robot_frames(const PlanarState& s) {
  return {s.robot_id, s.stamp_ns, s.x_m, s.y_m, s.yaw_rad, s.map_from_odom_x_m, s.map_from_odom_y_m, s.map_from_odom_yaw_rad};
}

void TfMessage::set(std::span<const PlanarState> states) {
  std::vector<RobotFrames> robots;
  robots.reserve(states.size());
  for (const PlanarState& s : states) robots.push_back(robot_frames(s));
  std::vector<FrameTransform> frames;
  append_dynamic_transforms(robots, frames);
  set_transforms(frames);
}

void TfMessage::set_transforms(std::span<const FrameTransform> transforms) {
  frames_.assign(transforms.begin(), transforms.end());
  transforms_.clear();
  for (const FrameTransform& f : frames_) {  // frames_ is complete: its strings no longer move
    geometry_msgs_msg_dds__TransformStamped_ t{};
    t.header.stamp = ros_time(f.stamp_ns);
    t.header.frame_id = c_str(f.parent);
    t.child_frame_id = c_str(f.child);
    t.transform.translation = {f.x_m, f.y_m, f.z_m};
    t.transform.rotation = {f.rotation.x, f.rotation.y, f.rotation.z, f.rotation.w};
    transforms_.push_back(t);
  }
  const auto n = static_cast<std::uint32_t>(transforms_.size());
  msg_.transforms = {n, n, transforms_.data(), false};
}

void OdometryMessage::set(const PlanarState& s) {
  frame_ = odom_frame(s.robot_id);
  child_ = base_link_frame(s.robot_id);
  msg_ = nav_msgs_msg_dds__Odometry_{};
  msg_.header.stamp = ros_time(s.stamp_ns);
  msg_.header.frame_id = c_str(frame_);
  msg_.child_frame_id = c_str(child_);
  const PlanarPose p = odom_from_base_link(robot_frames(s));
  msg_.pose.pose.position = {p.x_m, p.y_m, 0.0};
  msg_.pose.pose.orientation = yaw_quaternion(p.yaw_rad);
  // The map-frame position covariance C in the odom frame: R^T C R, R the correction's rotation.
  const double cc = std::cos(s.map_from_odom_yaw_rad), sc = std::sin(s.map_from_odom_yaw_rad);
  const double xx = cc * cc * s.cov_xx_m2 + 2 * cc * sc * s.cov_xy_m2 + sc * sc * s.cov_yy_m2;
  const double yy = sc * sc * s.cov_xx_m2 - 2 * cc * sc * s.cov_xy_m2 + cc * cc * s.cov_yy_m2;
  const double xy = (cc * cc - sc * sc) * s.cov_xy_m2 + cc * sc * (s.cov_yy_m2 - s.cov_xx_m2);
  double* pc = msg_.pose.covariance;  // row-major 6x6: x y z roll pitch yaw
  pc[0] = xx;
  pc[1] = pc[6] = xy;
  pc[7] = yy;
  pc[35] = s.yaw_var_rad2;
  // Twist in child_frame_id: the map-frame velocity rotated by -yaw.
  const double c = std::cos(s.yaw_rad), sn = std::sin(s.yaw_rad);
  msg_.twist.twist.linear = {c * s.vx_mps + sn * s.vy_mps, -sn * s.vx_mps + c * s.vy_mps, 0.0};
  msg_.twist.twist.angular = {0.0, 0.0, s.yaw_rate_radps};
}

Result<std::unique_ptr<Ros2Writers>> Ros2Writers::create(dds_entity_t participant) {
  std::unique_ptr<Ros2Writers> w(new Ros2Writers(participant));
  const dds_entity_t cloud_topic =
      dds_create_topic(participant, &sensor_msgs_msg_dds__PointCloud2__desc, kTopicMapCloud, nullptr, nullptr);
  const dds_entity_t tf_topic = dds_create_topic(participant, &tf2_msgs_msg_dds__TFMessage__desc, kTopicTf, nullptr, nullptr);
  if (cloud_topic < 0 || tf_topic < 0) return Error{"ros2: cannot create the rt/ topics"};
  dds_qos_t* cq = make_map_cloud_writer_qos();
  w->cloud_writer_ = dds_create_writer(participant, cloud_topic, cq, nullptr);
  dds_delete_qos(cq);
  dds_qos_t* tq = make_tf_writer_qos();
  w->tf_writer_ = dds_create_writer(participant, tf_topic, tq, nullptr);
  dds_delete_qos(tq);
  const dds_entity_t tf_static_topic =
      dds_create_topic(participant, &tf2_msgs_msg_dds__TFMessage__desc, kTopicTfStatic, nullptr, nullptr);
  dds_qos_t* sq = make_tf_static_writer_qos();
  w->tf_static_writer_ = tf_static_topic < 0 ? tf_static_topic : dds_create_writer(participant, tf_static_topic, sq, nullptr);
  dds_delete_qos(sq);
  if (w->cloud_writer_ < 0 || w->tf_writer_ < 0 || w->tf_static_writer_ < 0)
    return Error{"ros2: cannot create the rt/ writers"};
  return w;
}

Ros2Writers::~Ros2Writers() {
  // Writers (and topics) go with the participant; delete the writers now so a caller that keeps the
  // participant does not keep publishing stale endpoints.
  for (const std::vector<dds_entity_t>* list : {&odometry_writers_, &scan_writers_})
    for (dds_entity_t e : *list)
      if (e > 0) (void)dds_delete(e);
  if (cloud_writer_ > 0) (void)dds_delete(cloud_writer_);
  if (tf_writer_ > 0) (void)dds_delete(tf_writer_);
  if (tf_static_writer_ > 0) (void)dds_delete(tf_static_writer_);
}

Status Ros2Writers::write_cloud(const PointCloudMessage& cloud) {
  if (dds_write(cloud_writer_, &cloud.msg()) < 0) {
    ++counters_.write_errors;
    return Error{"ros2: map cloud write failed"};
  }
  ++counters_.clouds;
  return ok_status();
}

Status Ros2Writers::write_tf(const TfMessage& tf) {
  if (dds_write(tf_writer_, &tf.msg()) < 0) {
    ++counters_.write_errors;
    return Error{"ros2: rt/tf write failed"};
  }
  ++counters_.tf_messages;
  return ok_status();
}

Status Ros2Writers::write_tf_static(const TfMessage& tf) {
  if (dds_write(tf_static_writer_, &tf.msg()) < 0) {
    ++counters_.write_errors;
    return Error{"ros2: rt/tf_static write failed"};
  }
  return ok_status();
}

dds_entity_t Ros2Writers::odometry_writer(std::uint32_t robot_id) const {
  return robot_id < odometry_writers_.size() ? odometry_writers_[robot_id] : 0;
}

dds_entity_t Ros2Writers::robot_writer(std::vector<dds_entity_t>& writers, std::uint32_t robot_id,
                                       const std::string& topic, const dds_topic_descriptor_t* desc,
                                       dds_qos_t* (*make_qos)()) {
  if (robot_id >= writers.size()) writers.resize(robot_id + 1, 0);
  dds_entity_t& w = writers[robot_id];
  if (w <= 0) {
    const dds_entity_t t = dds_create_topic(participant_, desc, topic.c_str(), nullptr, nullptr);
    dds_qos_t* q = make_qos();
    w = t < 0 ? t : dds_create_writer(participant_, t, q, nullptr);
    dds_delete_qos(q);
    if (w < 0) w = 0;
  }
  return w;
}

Status Ros2Writers::write_odometry(std::uint32_t robot_id, const OdometryMessage& odometry) {
  const dds_entity_t w = robot_writer(odometry_writers_, robot_id, odometry_topic(robot_id),
                                      &nav_msgs_msg_dds__Odometry__desc, make_odometry_writer_qos);
  if (w == 0) {
    ++counters_.write_errors;
    return Error{"ros2: cannot create an odometry writer"};
  }
  if (dds_write(w, &odometry.msg()) < 0) {
    ++counters_.write_errors;
    return Error{"ros2: odometry write failed"};
  }
  ++counters_.odometry;
  return ok_status();
}

Status Ros2Writers::write_scan(std::uint32_t robot_id, const PointCloudMessage& scan) {
  const dds_entity_t w = robot_writer(scan_writers_, robot_id, scan_topic(robot_id),
                                      &sensor_msgs_msg_dds__PointCloud2__desc, make_scan_writer_qos);
  if (w == 0) {
    ++counters_.write_errors;
    return Error{"ros2: cannot create a scan writer"};
  }
  if (dds_write(w, &scan.msg()) < 0) {
    ++counters_.write_errors;
    return Error{"ros2: scan write failed"};
  }
  ++counters_.scans;
  return ok_status();
}

}  // namespace teamscan::dds::ros2
