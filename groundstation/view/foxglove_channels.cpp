// The view's Foxglove channels and their messages (foxglove_channels.hpp).
#include "groundstation/view/foxglove_channels.hpp"

#include <nlohmann/json.hpp>

#include "dds/ros2/cdr.hpp"
#include "dds/ros2/frames.hpp"
#include "dds/ros2/wire.hpp"

namespace teamscan::view::foxglove {
namespace {

namespace ros2 = teamscan::dds::ros2;

constexpr char kRobotsSchemaName[] = "teamscan.RobotStates";
// JSON Schema of /teamscan/robots (Foxglove reads json channels with a jsonschema).
constexpr char kRobotsSchema[] = R"({"type":"object","properties":{)"
                                 R"("stamp_ns":{"type":"integer"},"map_voxels":{"type":"integer"},)"
                                 R"("robots":{"type":"array","items":{"type":"object","properties":{)"
                                 R"("id":{"type":"integer"},"lost":{"type":"boolean"},)"
                                 R"("x_m":{"type":"number"},"y_m":{"type":"number"},"yaw_rad":{"type":"number"},)"
                                 R"("cov_xx_m2":{"type":"number"},"cov_xy_m2":{"type":"number"},"cov_yy_m2":{"type":"number"},)"
                                 R"("scans":{"type":"integer"},"scans_lost":{"type":"integer"},)"
                                 R"("ghosts_removed":{"type":"integer"},"latency_ms":{"type":"number"}}}}}})";

ros2::PlanarState planar_state(const RobotState& r, std::int64_t stamp_ns) {
  ros2::PlanarState s;
  s.robot_id = r.robot_id;
  s.stamp_ns = stamp_ns;
  s.x_m = r.x_m;
  s.y_m = r.y_m;
  s.yaw_rad = r.yaw_rad;
  s.vx_mps = r.vx_mps;
  s.vy_mps = r.vy_mps;
  s.cov_xx_m2 = r.cov_xx_m2;
  s.cov_xy_m2 = r.cov_xy_m2;
  s.cov_yy_m2 = r.cov_yy_m2;
  s.map_from_odom_x_m = r.map_from_odom_x_m;
  s.map_from_odom_y_m = r.map_from_odom_y_m;
  s.map_from_odom_yaw_rad = r.map_from_odom_yaw_rad;
  return s;
}

std::string robots_json(const TeamSnapshot& t) {
  nlohmann::json robots = nlohmann::json::array();
  for (std::uint32_t i = 0; i < t.count && i < t.robots.size(); ++i) {
    const RobotState& r = t.robots[i];
    robots.push_back({{"id", r.robot_id},
                      {"lost", r.lost},
                      {"x_m", r.x_m},
                      {"y_m", r.y_m},
                      {"yaw_rad", r.yaw_rad},
                      {"cov_xx_m2", r.cov_xx_m2},
                      {"cov_xy_m2", r.cov_xy_m2},
                      {"cov_yy_m2", r.cov_yy_m2},
                      {"scans", r.scans},
                      {"scans_lost", r.scans_lost},
                      {"ghosts_removed", r.ghosts_removed},
                      {"latency_ms", r.latency_ms}});
  }
  return nlohmann::json{{"stamp_ns", t.stamp_ns}, {"map_voxels", t.map_voxels}, {"robots", std::move(robots)}}.dump();
}

}  // namespace

FoxgloveChannels::FoxgloveChannels(ChannelOptions options) : options_{options}, robots_(kMaxRobots + 1) {
  add_channel("/map", ros2::kPointCloud2Type);
  add_channel("/tf", ros2::kTfMessageType);
  Channel robots;
  robots.id = kRobotsChannel;
  robots.topic = "/teamscan/robots";
  robots.encoding = "json";
  robots.schema_name = kRobotsSchemaName;
  robots.schema = kRobotsSchema;
  robots.schema_encoding = "jsonschema";
  channels_.push_back(std::move(robots));
  latest_.emplace_back();
  if (!options_.static_transforms.empty()) {
    add_channel("/tf_static", ros2::kTfMessageType);
    ros2::TfMessage mounts;
    mounts.set_transforms(options_.static_transforms);
    std::vector<ChannelMessage> unused;
    emit(kTfStaticChannel, static_cast<std::uint64_t>(options_.static_transforms.front().stamp_ns),
         ros2::cdr_bytes(tf2_msgs_msg_dds__TFMessage__desc, &mounts.msg()), unused);
  }
}

std::uint32_t FoxgloveChannels::add_channel(std::string topic, const char* type_name) {
  Channel c;
  c.id = static_cast<std::uint32_t>(channels_.size() + 1);
  c.topic = std::move(topic);
  c.encoding = "cdr";
  c.schema_name = type_name;
  c.schema = std::string(ros2::ros2msg_definition(type_name));
  c.schema_encoding = "ros2msg";
  channels_.push_back(std::move(c));
  latest_.emplace_back();
  return channels_.back().id;
}

const ChannelMessage* FoxgloveChannels::latest(std::uint32_t channel_id) const {
  if (!has_channel(channel_id) || !latest_[channel_id - 1].payload) return nullptr;
  return &latest_[channel_id - 1];
}

void FoxgloveChannels::emit(std::uint32_t channel, std::uint64_t stamp_ns, std::string payload,
                            std::vector<ChannelMessage>& out) {
  ChannelMessage m{channel, stamp_ns, std::make_shared<const std::string>(std::move(payload))};
  latest_[channel - 1] = m;
  out.push_back(std::move(m));
}

void FoxgloveChannels::apply(const FeedBatch& batch, const ViewHub& hub, std::int64_t now_ns,
                             std::vector<ChannelMessage>& out, std::vector<Channel>& added, bool final_map) {
  if (batch.snapshot) robot_messages(*batch.snapshot, out, added);
  ros2::PointCloudMessage cloud;
  std::vector<ros2::CloudPoint> points;
  for (std::size_t i = 0; i < batch.scan_count && i < batch.scans.size(); ++i) {
    const TapScan& s = batch.scans[i];
    if (s.robot_id == 0 || s.robot_id >= robots_.size() || robots_[s.robot_id].scan == 0) continue;
    points.clear();
    for (std::uint32_t k = 0; k < s.count && k < s.points.size(); ++k) {
      const TapPoint& p = s.points[k];
      points.push_back({static_cast<float>(p.x_mm * 1e-3), static_cast<float>(p.y_mm * 1e-3),
                        static_cast<float>(p.z_mm * 1e-3), 1.0f});
    }
    cloud.set(now_ns, ros2::odom_frame(s.robot_id), points);
    emit(robots_[s.robot_id].scan, static_cast<std::uint64_t>(now_ns),
         ros2::cdr_bytes(sensor_msgs_msg_dds__PointCloud2__desc, &cloud.msg()), out);
  }
  map_message(hub, now_ns, out, final_map);
}

void FoxgloveChannels::robot_messages(const TeamSnapshot& t, std::vector<ChannelMessage>& out,
                                      std::vector<Channel>& added) {
  const auto stamp = static_cast<std::uint64_t>(t.stamp_ns);
  std::vector<ros2::PlanarState> states;
  for (std::uint32_t i = 0; i < t.count && i < t.robots.size(); ++i) {
    const RobotState& r = t.robots[i];
    if (r.robot_id == 0 || r.robot_id >= robots_.size()) continue;
    RobotChannels& c = robots_[r.robot_id];
    if (c.pose == 0) {
      const std::string prefix = "/robot" + std::to_string(r.robot_id);
      c.pose = add_channel(prefix + "/pose", ros2::kPoseStampedType);
      c.odom = add_channel(prefix + "/odom", ros2::kOdometryType);
      c.scan = add_channel(prefix + "/scan", ros2::kPointCloud2Type);
      added.insert(added.end(), channels_.end() - 3, channels_.end());
    }
    if (r.lost) continue;  // as on rt/tf: a lost robot's frames go stale
    states.push_back(planar_state(r, t.stamp_ns));
  }
  ros2::TfMessage tf;
  tf.set(states);
  emit(kTfChannel, stamp, ros2::cdr_bytes(tf2_msgs_msg_dds__TFMessage__desc, &tf.msg()), out);
  ros2::OdometryMessage odometry;
  for (const ros2::PlanarState& s : states) {
    geometry_msgs_msg_dds__PoseStamped_ pose{};
    pose.header.stamp = ros2::ros_time(s.stamp_ns);
    pose.header.frame_id = const_cast<char*>(ros2::kFrameMap);
    pose.pose.position = {s.x_m, s.y_m, 0.0};
    pose.pose.orientation = ros2::yaw_quaternion(s.yaw_rad);
    emit(robots_[s.robot_id].pose, stamp, ros2::cdr_bytes(geometry_msgs_msg_dds__PoseStamped__desc, &pose), out);
    odometry.set(s);
    emit(robots_[s.robot_id].odom, stamp, ros2::cdr_bytes(nav_msgs_msg_dds__Odometry__desc, &odometry.msg()), out);
  }
  emit(kRobotsChannel, stamp, robots_json(t), out);
}

void FoxgloveChannels::map_message(const ViewHub& hub, std::int64_t now_ns, std::vector<ChannelMessage>& out, bool final_map) {
  const std::uint64_t changes = hub.counters().voxels_changed + hub.counters().whole_maps;
  if ((now_ns < next_map_ns_ && !final_map) || changes == map_changes_seen_ || hub.map_voxels() == 0) return;
  map_changes_seen_ = changes;
  next_map_ns_ = now_ns + options_.map_interval_ns;
  std::vector<ros2::CloudPoint> points;
  points.reserve(hub.map_voxels());
  hub.for_each_map_voxel([&](const WireVoxel& v) {
    if (v.flags & 1u) return;  // removed as a ghost: not in the fused map
    points.push_back({static_cast<float>(v.x_mm * 1e-3), static_cast<float>(v.y_mm * 1e-3),
                      static_cast<float>(v.z_mm * 1e-3), static_cast<float>(v.hits)});
  });
  ros2::PointCloudMessage cloud;
  cloud.set(now_ns, ros2::kFrameMap, points);
  emit(kMapChannel, static_cast<std::uint64_t>(now_ns),
       ros2::cdr_bytes(sensor_msgs_msg_dds__PointCloud2__desc, &cloud.msg()), out);
}

}  // namespace teamscan::view::foxglove
