// The view's Foxglove WebSocket protocol (foxglove/ws-protocol docs/spec.md) and channels: the exact bytes
// of a binary Message Data frame, the JSON of serverInfo, advertise and status, the client's messages
// decoded (subscribe, unsubscribe; publish, services, parameters, graph and assets refused; anything else
// malformed), and the channels built from a drained feed batch: robots' channels advertised when they
// appear, /tf as REP-105 pairs in CDR equal to Cyclone's serialisation of the same TFMessage, the map
// cloud of the kept voxels, the robots' JSON, a lost robot left off /tf.
#include <gtest/gtest.h>

#include <cstring>
#include <nlohmann/json.hpp>

#include "dds/ros2/cdr.hpp"
#include "dds/ros2/wire.hpp"
#include "groundstation/view/foxglove_channels.hpp"
#include "groundstation/view/foxglove_protocol.hpp"

namespace teamscan::view::foxglove {
namespace {

using nlohmann::json;

std::string to_hex(std::string_view b) {
  static const char* const kDigits = "0123456789abcdef";
  std::string s;
  for (const char c : b) {
    const auto v = static_cast<unsigned char>(c);
    s += kDigits[v >> 4];
    s += kDigits[v & 15];
  }
  return s;
}

TEST(FoxgloveProtocol, MessageDataFrameBytes) {
  // opcode 01 | subscription id 0x04030201 LE | receive time 0x0102030405060708 ns LE | payload
  EXPECT_EQ(to_hex(encode_message_data(0x04030201u, 0x0102030405060708ull, std::string_view("\x00\x01\xff", 3))),
            "01" "01020304" "0807060504030201" "0001ff");
  EXPECT_EQ(to_hex(encode_message_data(0, 0, {})), "01" "00000000" "0000000000000000");
  EXPECT_EQ(encode_message_data(7, 1, "abc").size(), kMessageDataHeaderBytes + 3);
}

TEST(FoxgloveProtocol, ServerInfoAnnouncesNoCapabilities) {
  const json j = json::parse(encode_server_info("teamscan-groundstation", "1700000000"));
  EXPECT_EQ(j, json::parse(R"({"op":"serverInfo","name":"teamscan-groundstation","capabilities":[],)"
                           R"("supportedEncodings":[],"metadata":{"read_only":"true"},"sessionId":"1700000000"})"));
}

TEST(FoxgloveProtocol, AdvertiseAndStatusJson) {
  const Channel c[2] = {{1, "/map", "cdr", "sensor_msgs/msg/PointCloud2", "uint32 height\n", "ros2msg"},
                        {3, "/teamscan/robots", "json", "teamscan.RobotStates", "{\"type\":\"object\"}", "jsonschema"}};
  EXPECT_EQ(json::parse(encode_advertise(c)),
            json::parse(R"({"op":"advertise","channels":[)"
                        R"({"id":1,"topic":"/map","encoding":"cdr","schemaName":"sensor_msgs/msg/PointCloud2",)"
                        R"("schema":"uint32 height\n","schemaEncoding":"ros2msg"},)"
                        R"({"id":3,"topic":"/teamscan/robots","encoding":"json","schemaName":"teamscan.RobotStates",)"
                        R"("schema":"{\"type\":\"object\"}","schemaEncoding":"jsonschema"}]})"));
  EXPECT_EQ(json::parse(encode_status(StatusLevel::kError, "no \"x\"")),
            json::parse(R"({"op":"status","level":2,"message":"no \"x\""})"));
}

TEST(FoxgloveProtocol, SubscribeAndUnsubscribeDecode) {
  const ClientRequest s =
      decode_client_text(R"({"op":"subscribe","subscriptions":[{"id":0,"channelId":3},{"id":7,"channelId":1}]})");
  ASSERT_EQ(s.kind, ClientRequest::Kind::kSubscribe);
  ASSERT_EQ(s.subscriptions.size(), 2u);
  EXPECT_EQ(s.subscriptions[0], std::make_pair(0u, 3u));
  EXPECT_EQ(s.subscriptions[1], std::make_pair(7u, 1u));
  const ClientRequest u = decode_client_text(R"({"op":"unsubscribe","subscriptionIds":[7,0]})");
  ASSERT_EQ(u.kind, ClientRequest::Kind::kUnsubscribe);
  EXPECT_EQ(u.subscription_ids, (std::vector<std::uint32_t>{7, 0}));
  EXPECT_EQ(decode_client_text(R"({"op":"subscribe","subscriptions":[]})").kind, ClientRequest::Kind::kSubscribe);
}

TEST(FoxgloveProtocol, PublishServicesParametersAreRefused) {
  for (const char* text :
       {R"({"op":"advertise","channels":[{"id":1,"topic":"/cmd_vel","encoding":"json","schemaName":"x"}]})",
        R"({"op":"unadvertise","channelIds":[1]})", R"({"op":"getParameters","parameterNames":[]})",
        R"({"op":"setParameters","parameters":[{"name":"/a","value":1}]})",
        R"({"op":"subscribeParameterUpdates","parameterNames":[]})",
        R"({"op":"unsubscribeParameterUpdates","parameterNames":[]})", R"({"op":"subscribeConnectionGraph"})",
        R"({"op":"unsubscribeConnectionGraph"})", R"({"op":"fetchAsset","uri":"package://a","requestId":1})"}) {
    const ClientRequest r = decode_client_text(text);
    EXPECT_EQ(r.kind, ClientRequest::Kind::kRefused) << text;
    EXPECT_EQ(r.op, json::parse(text)["op"].get<std::string>());
  }
  EXPECT_EQ(decode_client_binary(std::string("\x01\x01\x00\x00\x00{}", 7)).kind, ClientRequest::Kind::kRefused);
  EXPECT_EQ(decode_client_binary(std::string("\x02\x01\x00\x00\x00", 5)).op, "serviceCallRequest");
}

TEST(FoxgloveProtocol, AnythingElseIsMalformed) {
  for (const char* text : {"", "not json", "[1,2]", R"({"subscriptions":[]})", R"({"op":3})", R"({"op":"launch"})",
                           R"({"op":"subscribe"})", R"({"op":"subscribe","subscriptions":[{"id":-1,"channelId":1}]})",
                           R"({"op":"subscribe","subscriptions":[{"id":1}]})",
                           R"({"op":"subscribe","subscriptions":[{"id":4294967296,"channelId":1}]})",
                           R"({"op":"unsubscribe","subscriptionIds":["a"]})"}) {
    const ClientRequest r = decode_client_text(text);
    EXPECT_EQ(r.kind, ClientRequest::Kind::kMalformed) << text;
    EXPECT_FALSE(r.why.empty()) << text;
  }
  EXPECT_EQ(decode_client_binary({}).kind, ClientRequest::Kind::kMalformed);
  EXPECT_EQ(decode_client_binary("\x05").kind, ClientRequest::Kind::kMalformed);
}

TeamSnapshot two_robots(std::int64_t stamp_ns, bool second_lost) {
  TeamSnapshot t;
  t.stamp_ns = stamp_ns;
  t.count = 2;
  t.robots[0].robot_id = 1;
  t.robots[0].x_m = 1.5;
  t.robots[0].y_m = -2.0;
  t.robots[0].yaw_rad = 0.5;
  t.robots[0].map_from_odom_x_m = 0.25;
  t.robots[0].map_from_odom_yaw_rad = 0.1;
  t.robots[1].robot_id = 2;
  t.robots[1].x_m = -3.0;
  t.robots[1].lost = second_lost;
  return t;
}

TEST(FoxgloveChannels, RobotChannelsAreAdvertisedWhenTheRobotAppears) {
  FoxgloveChannels ch;
  ViewHub hub;
  ASSERT_EQ(ch.channels().size(), 3u);
  EXPECT_EQ(ch.channels()[0].topic, "/map");
  EXPECT_EQ(ch.channels()[1].topic, "/tf");
  EXPECT_EQ(ch.channels()[2].topic, "/teamscan/robots");
  FeedBatch b;
  b.snapshot = two_robots(1'700'000'000'000'000'000, false);
  std::vector<ChannelMessage> out;
  std::vector<Channel> added;
  ch.apply(b, hub, 1'700'000'000'000'000'000, out, added);
  ASSERT_EQ(added.size(), 6u);
  const char* topics[] = {"/robot1/pose", "/robot1/odom", "/robot1/scan", "/robot2/pose", "/robot2/odom", "/robot2/scan"};
  for (std::size_t i = 0; i < 6; ++i) {
    EXPECT_EQ(added[i].topic, topics[i]);
    EXPECT_EQ(added[i].id, 4 + i);
    EXPECT_EQ(added[i].encoding, "cdr");
    EXPECT_EQ(added[i].schema_encoding, "ros2msg");
    EXPECT_FALSE(added[i].schema.empty());
  }
  // tf, pose + odom per robot, robots: 1 + 4 + 1 (no map yet: the hub's map is empty).
  EXPECT_EQ(out.size(), 6u);
  added.clear();
  out.clear();
  ch.apply(b, hub, 1'700'000'000'100'000'000, out, added);
  EXPECT_TRUE(added.empty());  // advertised once
}

TEST(FoxgloveChannels, TfIsTheRep105TreeInCdrAndALostRobotIsLeftOff) {
  FoxgloveChannels ch;
  ViewHub hub;
  FeedBatch b;
  const std::int64_t stamp = 1'700'000'000'500'000'000;
  b.snapshot = two_robots(stamp, true);
  std::vector<ChannelMessage> out;
  std::vector<Channel> added;
  ch.apply(b, hub, stamp, out, added);
  const ChannelMessage* tf = ch.latest(FoxgloveChannels::kTfChannel);
  ASSERT_NE(tf, nullptr);
  EXPECT_EQ(tf->stamp_ns, static_cast<std::uint64_t>(stamp));
  dds::ros2::PlanarState s;
  s.robot_id = 1;
  s.stamp_ns = stamp;
  s.x_m = 1.5;
  s.y_m = -2.0;
  s.yaw_rad = 0.5;
  s.map_from_odom_x_m = 0.25;
  s.map_from_odom_yaw_rad = 0.1;
  dds::ros2::TfMessage expected;
  expected.set(std::span<const dds::ros2::PlanarState>(&s, 1));
  ASSERT_EQ(expected.msg().transforms._length, 2u);  // map -> robot1/odom -> robot1/base_link; robot 2 lost
  EXPECT_STREQ(expected.msg().transforms._buffer[1].header.frame_id, "robot1/odom");
  EXPECT_EQ(to_hex(*tf->payload), to_hex(dds::ros2::cdr_bytes(tf2_msgs_msg_dds__TFMessage__desc, &expected.msg())));
  EXPECT_EQ(ch.latest(7), nullptr);  // robot 2's pose: lost, none sent
  const ChannelMessage* robots = ch.latest(FoxgloveChannels::kRobotsChannel);
  ASSERT_NE(robots, nullptr);
  const json j = json::parse(*robots->payload);
  ASSERT_EQ(j["robots"].size(), 2u);
  EXPECT_EQ(j["robots"][1]["lost"], true);
  EXPECT_DOUBLE_EQ(j["robots"][0]["x_m"].get<double>(), 1.5);
}

TEST(FoxgloveChannels, MapIsTheKeptVoxelsAtMostEveryInterval) {
  ChannelOptions options;
  options.map_interval_ns = 1'000'000'000;
  FoxgloveChannels ch(options);
  ViewHub hub;
  FeedBatch b;
  b.voxels = {{50, 50, 50, 3, 0}, {150, 50, 50, 2, 1}, {250, -50, 1050, 1, 0}};  // the second removed as a ghost
  std::vector<SharedMessage> view_out;
  hub.apply(b, view_out);
  std::vector<ChannelMessage> out;
  std::vector<Channel> added;
  ch.apply(b, hub, 5'000'000'000, out, added);
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(out[0].channel_id, FoxgloveChannels::kMapChannel);
  // PointCloud2 CDR: header (4) stamp (8) "map" (8), height 1 at 20, width at 24.
  const std::string& p = *out[0].payload;
  std::uint32_t width = 0;
  std::memcpy(&width, p.data() + 24, 4);
  EXPECT_EQ(width, 2u);
  out.clear();
  FeedBatch more;
  more.voxels = {{350, 50, 50, 1, 0}};
  hub.apply(more, view_out);
  ch.apply(more, hub, 5'500'000'000, out, added);
  EXPECT_TRUE(out.empty());  // within the interval
  ch.apply(FeedBatch{}, hub, 6'000'000'000, out, added);
  ASSERT_EQ(out.size(), 1u);
  std::memcpy(&width, out[0].payload->data() + 24, 4);
  EXPECT_EQ(width, 3u);
  out.clear();
  ch.apply(FeedBatch{}, hub, 8'000'000'000, out, added);
  EXPECT_TRUE(out.empty());  // unchanged: not republished (a new subscriber gets latest())
  EXPECT_NE(ch.latest(FoxgloveChannels::kMapChannel), nullptr);
}

// The station's last map (the final model on the pose graph's poses, ViewServer::flush) goes out on the
// map channel within the interval; unchanged, it still does not.
TEST(FoxgloveChannels, TheFinalMapGoesOutWhateverTheInterval) {
  ChannelOptions options;
  options.map_interval_ns = 1'000'000'000;
  FoxgloveChannels ch(options);
  ViewHub hub;
  std::vector<SharedMessage> view_out;
  std::vector<ChannelMessage> out;
  std::vector<Channel> added;
  FeedBatch b;
  b.voxels = {{50, 50, 50, 3, 0}};
  hub.apply(b, view_out);
  ch.apply(b, hub, 5'000'000'000, out, added);
  ASSERT_EQ(out.size(), 1u);
  out.clear();
  FeedBatch last;  // the map decided again: a whole map that drops the first voxel
  last.voxels = {{150, 50, 50, 2, 0}, {250, 50, 50, 1, 0}};
  last.voxels_are_full_map = true;
  hub.apply(last, view_out);
  ch.apply(last, hub, 5'100'000'000, out, added);
  EXPECT_TRUE(out.empty());  // within the interval
  ch.apply(FeedBatch{}, hub, 5'200'000'000, out, added, true);
  ASSERT_EQ(out.size(), 1u);
  std::uint32_t width = 0;
  std::memcpy(&width, out[0].payload->data() + 24, 4);
  EXPECT_EQ(width, 2u);
  out.clear();
  ch.apply(FeedBatch{}, hub, 5'300'000'000, out, added, true);
  EXPECT_TRUE(out.empty());  // unchanged since
}

}  // namespace
}  // namespace teamscan::view::foxglove
