// FoxgloveChannels: what the view offers a Foxglove client (docs/view.md "Foxglove"), built on the view's
// server thread from the same drained feed and map copy as the browser view. Channels, ROS 2 messages in
// CDR (schema encoding ros2msg, serialised by dds/ros2) unless said otherwise:
//   /map                the fused map: sensor_msgs/PointCloud2 in `map`, one point per kept voxel (x y z hits)
//   /tf                 tf2_msgs/TFMessage: map -> robotN/odom -> robotN/base_link (REP-105, dds/ros2/frames)
//   /tf_static          tf2_msgs/TFMessage: robotN/base_link -> robotN/laser (when mounts are configured)
//   /teamscan/robots    JSON (jsonschema): every robot's state as the browser view shows it
//   /robotN/pose        geometry_msgs/PoseStamped: the tracked pose in `map`
//   /robotN/odom        nav_msgs/Odometry in robotN/odom (child robotN/base_link)
//   /robotN/scan        sensor_msgs/PointCloud2 of each scan's placed points, in robotN/odom (the station
//                       stores scans in the robot's odometry frame: its applied correction undone)
// Robot channels are advertised when the robot first appears. Each channel's newest message is kept and
// sent to a client as soon as it subscribes (the map is republished every map_interval only).
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "common/capacities.hpp"
#include "dds/ros2/frames.hpp"
#include "groundstation/view/feed.hpp"
#include "groundstation/view/foxglove_protocol.hpp"
#include "groundstation/view/hub.hpp"

namespace teamscan::view::foxglove {

struct ChannelOptions {
  std::int64_t map_interval_ns = 1'000'000'000;  // /map republished at most this often (when it changed)
  // The static transforms (robotN/base_link -> robotN/laser, [[ros2.laser_mount]]): if any, a /tf_static
  // channel (id 4) holding them all in one TFMessage.
  std::vector<dds::ros2::FrameTransform> static_transforms;
};

// One message on a channel, encoded once for every subscriber.
struct ChannelMessage {
  std::uint32_t channel_id = 0;
  std::uint64_t stamp_ns = 0;  // the Message Data receive time (CLOCK_REALTIME)
  std::shared_ptr<const std::string> payload;
};

class FoxgloveChannels {
 public:
  explicit FoxgloveChannels(ChannelOptions options = {});

  // After the hub applied `batch`: appends this batch's messages to `out` and the channels it added
  // (robots seen for the first time) to `added`. `now_ns`: CLOCK_REALTIME, the scans' and map's stamp.
  // `final_map`: the map goes out if it changed, whatever its interval (the station's last map).
  void apply(const FeedBatch& batch, const ViewHub& hub, std::int64_t now_ns, std::vector<ChannelMessage>& out,
             std::vector<Channel>& added, bool final_map = false);

  [[nodiscard]] const std::vector<Channel>& channels() const { return channels_; }
  [[nodiscard]] bool has_channel(std::uint32_t id) const { return id >= 1 && id <= channels_.size(); }
  // The channel's newest message (null before the first).
  [[nodiscard]] const ChannelMessage* latest(std::uint32_t channel_id) const;

  // Channel ids (fixed; a robot's three are added in this order when it appears).
  static constexpr std::uint32_t kMapChannel = 1;
  static constexpr std::uint32_t kTfChannel = 2;
  static constexpr std::uint32_t kRobotsChannel = 3;
  static constexpr std::uint32_t kTfStaticChannel = 4;  // only with ChannelOptions::static_transforms

 private:
  struct RobotChannels {
    std::uint32_t pose = 0, odom = 0, scan = 0;  // 0: not advertised yet
  };
  std::uint32_t add_channel(std::string topic, const char* type_name);
  void emit(std::uint32_t channel, std::uint64_t stamp_ns, std::string payload, std::vector<ChannelMessage>& out);
  void robot_messages(const TeamSnapshot& snapshot, std::vector<ChannelMessage>& out, std::vector<Channel>& added);
  void map_message(const ViewHub& hub, std::int64_t now_ns, std::vector<ChannelMessage>& out, bool final_map);

  ChannelOptions options_;
  std::vector<Channel> channels_;        // id i at [i - 1]
  std::vector<ChannelMessage> latest_;  // id i at [i - 1]
  std::vector<RobotChannels> robots_;   // index robot id
  std::int64_t next_map_ns_ = 0;
  std::uint64_t map_changes_seen_ = ~std::uint64_t{0};
};

}  // namespace teamscan::view::foxglove
