// On the real daemon: a teamscan-groundstation process fed by two test robots (DdsBridge in
// this process, loopback DDS, a domain of this test's own) publishes, beside its own topics, what a ROS 2
// node reads through rmw_cyclonedds. Readers set up as rmw sets them up (ROS type names, XCDR1 only, no
// type information; the QoS of a late transient-local RViz2, of tf2 and of the ROS default) receive:
//  - rt/teamscan/map_cloud: a PointCloud2 in frame `map` whose points are the voxel centres of the
//    fused map (the kept voxels of teamscan/map, merged as a viewer merges them), one point per voxel;
//  - rt/tf: map -> robotN/odom -> robotN/base_link composing to the station's tracked pose (a Kalman tracker fed with the
//    same poses, predicted to the transform's stamp) within 1 mm, heading that of the odometry;
//  - rt/robotN/odom: the same pose, the tracker's covariance, the velocity in the robot's frame.
#include <gtest/gtest.h>

#include <dds/dds.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <sstream>
#include <thread>
#include <tuple>

#include "common/clock.hpp"
#include "common/dataset/pcd.hpp"
#include "common/units.hpp"
#include "dds/ros2/wire.hpp"
#include "groundstation/mapping/tracker.hpp"
#include "groundstation/mapping/voxel_map.hpp"
#include "onboard/bridge/bridge.hpp"
#include "dds/qos.hpp"
#include "dds/topics.hpp"
#include "teamscan.h"
#include "tests/hil/station/process.hpp"
#include "tests/hil/station/robot_bridges.hpp"
#include "tests/support/test_domain.hpp"

namespace teamscan {
namespace {

using namespace std::chrono_literals;

constexpr int kPoses = 30;             // per robot, 10 Hz
constexpr double kSpeedMps = 0.2;
constexpr int kPointsPerScan = 60;
constexpr int kGhostPoints = 12;
constexpr int kLastPoses = 3;          // per robot, sent just before the stop

double robot_yaw(std::uint32_t id) { return 0.4 * id - 0.3; }
double robot_x0(std::uint32_t id) { return 1.0 * id; }
double robot_y0(std::uint32_t id) { return 0.5 * id; }

std::size_t csv_rows(const std::string& path) {
  std::ifstream in(path);
  std::string line;
  std::size_t n = 0;
  while (std::getline(in, line))
    if (!line.empty() && line[0] != '#' && line.rfind("recv", 0) != 0 && line.rfind("robot", 0) != 0) ++n;
  return n;
}

// A teamscan/map viewer: merges every update (the changed voxels, or the whole map) into its own map.
class MapViewer {
 public:
  explicit MapViewer(dds_entity_t participant) {
    const dds_entity_t topic = dds_create_topic(participant, &teamscan_msg_MapUpdate_desc, dds::kTopicMap, nullptr, nullptr);
    dds_qos_t* q = dds::make_map_qos();
    reader_ = dds_create_reader(participant, topic, q, nullptr);
    dds_delete_qos(q);
  }
  void take() {
    void* samples[8] = {};
    dds_sample_info_t infos[8];
    const int n = dds_take(reader_, samples, infos, 8, 8);
    for (int i = 0; i < n; ++i) {
      if (!infos[i].valid_data) continue;
      const auto* m = static_cast<const teamscan_msg_MapUpdate*>(samples[i]);
      if (m->total_voxels == m->voxels._length) map.clear();
      resolution_mm = m->resolution_mm;
      for (std::uint32_t k = 0; k < m->voxels._length; ++k) {
        const teamscan_msg_MapVoxel& v = m->voxels._buffer[k];
        map[{v.x_mm, v.y_mm, v.z_mm}] = {v.hits, v.flags};
      }
    }
    if (n > 0) (void)dds_return_loan(reader_, samples, n);
  }
  [[nodiscard]] std::uint64_t hits() const {
    std::uint64_t h = 0;
    for (const auto& [k, v] : map) h += v.first;
    return h;
  }
  [[nodiscard]] std::set<std::tuple<std::int32_t, std::int32_t, std::int32_t>> kept() const {
    std::set<std::tuple<std::int32_t, std::int32_t, std::int32_t>> s;
    for (const auto& [k, v] : map)
      if (v.second == 0) s.insert(k);
    return s;
  }
  std::map<std::tuple<std::int32_t, std::int32_t, std::int32_t>, std::pair<std::uint32_t, std::uint32_t>> map;
  std::uint32_t resolution_mm = 0;

 private:
  dds_entity_t reader_ = -1;
};

dds_entity_t rmw_reader(dds_entity_t participant, const dds_topic_descriptor_t* desc, const std::string& topic,
                        bool transient_local, std::int32_t depth) {
  const dds_entity_t t = dds_create_topic(participant, desc, topic.c_str(), nullptr, nullptr);
  dds_qos_t* q = dds::ros2::make_rmw_like_reader_qos(true, transient_local, depth);
  const dds_entity_t r = dds_create_reader(participant, t, q, nullptr);
  dds_delete_qos(q);
  return r;
}

// Takes every valid sample available and hands each to `f` (the loan is returned after).
template <class T, class F>
int take_all(dds_entity_t reader, F&& f) {
  int got = 0;
  for (;;) {
    void* samples[16] = {};
    dds_sample_info_t infos[16];
    const int n = dds_take(reader, samples, infos, 16, 16);
    if (n <= 0) return got;
    for (int i = 0; i < n; ++i) {
      if (!infos[i].valid_data) continue;
      f(*static_cast<const T*>(samples[i]));
      ++got;
    }
    (void)dds_return_loan(reader, samples, n);
  }
}

using VoxelCentre = std::tuple<std::int32_t, std::int32_t, std::int32_t>;  // mm

// The voxel centres of a station model file's points binned as the live map bins them
// (groundstation/station/live_map.cpp), each with whether a point in it was kept at release
// (live_keep): the map every output shows of that model.
std::map<VoxelCentre, bool> model_voxels(const std::string& pcd, std::uint32_t resolution_mm) {
  std::map<VoxelCentre, bool> out;
  auto cloud = read_pcd(pcd);
  EXPECT_TRUE(cloud.ok()) << pcd << ": " << (cloud.ok() ? "" : cloud.error().what);
  if (!cloud.ok()) return out;
  const PcdCloud& c = cloud.value();
  const int fx = c.field("x"), fy = c.field("y"), fz = c.field("z"), fk = c.field("live_keep");
  EXPECT_TRUE(fx >= 0 && fy >= 0 && fz >= 0 && fk >= 0) << pcd;
  if (fx < 0 || fy < 0 || fz < 0 || fk < 0) return out;
  const double resolution_m = resolution_mm * 1e-3;
  for (std::size_t i = 0; i < c.size(); ++i) {
    auto col = [&](int f) { return c.columns[static_cast<std::size_t>(f)][i]; };
    const mapping::MapPoint p{static_cast<float>(col(fx)), static_cast<float>(col(fy)), static_cast<float>(col(fz))};
    const mapping::VoxelKey k = mapping::voxel_key(p, 1.0 / resolution_m);
    const VoxelCentre centre{to_mm((k.x + 0.5) * resolution_m), to_mm((k.y + 0.5) * resolution_m), to_mm((k.z + 0.5) * resolution_m)};
    out[centre] = out[centre] || col(fk) != 0.0;
  }
  return out;
}

double yaw_of(const geometry_msgs_msg_dds__Quaternion_& q) { return 2.0 * std::atan2(q.z, q.w); }
std::int64_t ns_of(const builtin_interfaces_msg_dds__Time_& t) {
  return static_cast<std::int64_t>(t.sec) * 1'000'000'000 + t.nanosec;
}

TEST(StationRos2, MapCloudTfAndOdometryReachRmwLikeReaders) {
  char tmpl[] = "/tmp/teamscan-ros2-XXXXXX";
  const std::string root = ::mkdtemp(tmpl);
  const std::string session = root + "/session";
  const std::string config = root + "/gs.toml";
  {
    std::ofstream c(config);
    c << "[team.kalman]\nlost_after_s = 60.0\n"
      // No cap on the model store: the map is the model's points, here every point sent.
      << "[fusion]\nmethod = \"direction\"\nwrite_interval_s = 0.0\nmap_interval_s = 0.3\nmax_points_per_voxel = 1000000\nwrite_all_points = true\n"
      << "[ros2]\nmap_interval_s = 0.3\npose_rate_hz = 20\n";
  }
  const dds_entity_t ros = dds_create_participant(test::test_domain_id(), nullptr, nullptr);
  ASSERT_GT(ros, 0);
  MapViewer viewer(ros);
  const dds_entity_t tf_reader = rmw_reader(ros, &tf2_msgs_msg_dds__TFMessage__desc, dds::ros2::kTopicTf, false, 100);
  const dds_entity_t odom_readers[2] = {
      rmw_reader(ros, &nav_msgs_msg_dds__Odometry__desc, dds::ros2::odometry_topic(1), false, 10),
      rmw_reader(ros, &nav_msgs_msg_dds__Odometry__desc, dds::ros2::odometry_topic(2), false, 10)};

  std::vector<onboard::DdsBridge> robots;
  test::start_robot_bridges(robots);
  ASSERT_FALSE(::testing::Test::HasFatalFailure());
  test::ChildProcess gs({TEAMSCAN_GROUNDSTATION, "--config", config, "--session-dir", session, "--domain",
                         test::test_domain_arg()});
  for (auto& b : robots) {
    const auto deadline = std::chrono::steady_clock::now() + 15s;
    while (b.scan_subscribers() < 1 && std::chrono::steady_clock::now() < deadline) std::this_thread::sleep_for(10ms);
    ASSERT_EQ(b.scan_subscribers(), 1u);
  }
  std::this_thread::sleep_for(200ms);  // pose reader matched too

  // Two robots drive straight at kSpeedMps along their headings; each pose is followed by a scan of a
  // wall. The tracker of this test gets exactly what the station gets (the wire's mm and µrad).
  mapping::TrackerOptions tracker_options;
  tracker_options.lost_after_s = 60.0;
  mapping::TeamTracker reference(tracker_options);
  const std::int64_t base_ns = now_realtime().ns() - 3'000'000'000;
  std::uint64_t points_sent = 0;
  static ScanPoints scan;
  std::size_t poses_sent = 0;
  std::int32_t last_x_mm[2] = {0, 0}, last_y_mm[2] = {0, 0};
  // Robot `id`'s pose number k + 1 (10 Hz along its heading), published and given to the reference
  // tracker; the scan of that pose gets its header (number, stamp, origin) and kPointsPerScan points to fill.
  auto send_pose = [&](std::int64_t k, std::uint32_t id) {
    const std::int64_t stamp = base_ns + k * 100'000'000 + id * 1'000'000;
    const double t = static_cast<double>(k) * 0.1, yaw = robot_yaw(id);
    onboard::OnboardPose p;
    p.robot_id = id;
    p.seq = static_cast<std::uint32_t>(k + 1);
    p.stamp_ns = stamp;
    p.x_mm = static_cast<std::int32_t>(std::lround((robot_x0(id) + kSpeedMps * t * std::cos(yaw)) * 1000.0));
    p.y_mm = static_cast<std::int32_t>(std::lround((robot_y0(id) + kSpeedMps * t * std::sin(yaw)) * 1000.0));
    p.yaw_urad = static_cast<std::int32_t>(std::lround(yaw * 1e6));
    p.vx_mmps = static_cast<std::int32_t>(std::lround(kSpeedMps * std::cos(yaw) * 1000.0));
    p.vy_mmps = static_cast<std::int32_t>(std::lround(kSpeedMps * std::sin(yaw) * 1000.0));
    EXPECT_TRUE(robots[id - 1].publish_pose(p).ok());
    ++poses_sent;
    const double yaw_wire = p.yaw_urad * 1e-6;
    reference.add_pose(static_cast<std::uint8_t>(id), stamp, Pose2{p.x_mm * 1e-3, p.y_mm * 1e-3, yaw_wire},
                       p.vx_mmps * 1e-3 * std::cos(yaw_wire) + p.vy_mmps * 1e-3 * std::sin(yaw_wire));
    // teamscan/pose is keep-last 1: the next pose waits until the station has stored this one.
    const auto deadline = std::chrono::steady_clock::now() + 10s;
    while (csv_rows(session + "/poses.csv") < poses_sent && std::chrono::steady_clock::now() < deadline)
      std::this_thread::sleep_for(1ms);
    scan.robot_id = id;
    scan.seq = p.seq;
    scan.stamp = Time::from_ns(stamp + 500'000);
    scan.origin_x_mm = p.x_mm;
    scan.origin_y_mm = p.y_mm;
    scan.origin_z_mm = 400;
    scan.count = kPointsPerScan;
    return p;
  };
  for (std::int64_t k = 0; k < kPoses; ++k) {
    for (std::uint32_t id : {1u, 2u}) {
      const onboard::OnboardPose p = send_pose(k, id);
      for (int i = 0; i < kPointsPerScan; ++i) {
        const auto kk = static_cast<std::int32_t>(k);
        scan.points[i] = ScanPoint{6000, -3000 + 100 * i + 7 * kk, 200 + 20 * kk + static_cast<std::int32_t>(id) * 5,
                                               static_cast<std::uint16_t>(i), 0};
      }
      if (id == 2 && k > 0) {
        // Robot 2 also sees robot 1's body (its last pose, 0.3..0.6 m up): ghosts the filter removes,
        // so the cloud (kept voxels) differs from the whole map.
        for (int i = 0; i < kGhostPoints; ++i) {
          scan.points[scan.count++] = ScanPoint{last_x_mm[0], last_y_mm[0] + 40 * (i % 3) - 40, 300 + 100 * (i / 3),
                                                            static_cast<std::uint16_t>(kPointsPerScan + i), 0};
        }
      }
      ASSERT_TRUE(robots[id - 1].publish_scan(scan).ok());
      points_sent += scan.count;
      last_x_mm[id - 1] = p.x_mm;
      last_y_mm[id - 1] = p.y_mm;
    }
  }
  for (auto& b : robots) ASSERT_TRUE(b.wait_for_scan_acks(from_seconds(20.0)).ok());
  ASSERT_EQ(csv_rows(session + "/poses.csv"), poses_sent);
  // Transforms stamped from now on come from a tracker that has every pose (the station stamps them
  // with its CLOCK_REALTIME when it asks the tracker).
  const std::int64_t all_stored_ns = now_realtime().ns();

  // The map cloud, read by a reader that joins now (transient local, as `ros2 topic echo` or an RViz2
  // set to transient local): one point per kept voxel of the fused map, at the voxel centres.
  const dds_entity_t cloud_reader = rmw_reader(ros, &sensor_msgs_msg_dds__PointCloud2__desc, dds::ros2::kTopicMapCloud, true, 1);
  std::set<std::tuple<std::int32_t, std::int32_t, std::int32_t>> cloud_voxels, kept;
  std::uint32_t width = 0, clouds = 0;
  bool cloud_equals_map = false;
  const auto cloud_deadline = std::chrono::steady_clock::now() + 20s;
  while (!cloud_equals_map && std::chrono::steady_clock::now() < cloud_deadline) {
    viewer.take();
    take_all<sensor_msgs_msg_dds__PointCloud2_>(cloud_reader, [&](const sensor_msgs_msg_dds__PointCloud2_& m) {
      ++clouds;
      EXPECT_STREQ(m.header.frame_id, "map");
      ASSERT_EQ(m.fields._length, 4u);
      EXPECT_STREQ(m.fields._buffer[0].name, "x");
      EXPECT_STREQ(m.fields._buffer[1].name, "y");
      EXPECT_STREQ(m.fields._buffer[2].name, "z");
      EXPECT_EQ(m.height, 1u);
      ASSERT_EQ(m.data._length, m.width * m.point_step);
      width = m.width;
      cloud_voxels.clear();
      for (std::uint32_t i = 0; i < m.width; ++i) {
        float p[3];
        std::memcpy(p, m.data._buffer + i * m.point_step, sizeof p);
        cloud_voxels.insert({static_cast<std::int32_t>(std::lround(p[0] * 1000.0f)),
                             static_cast<std::int32_t>(std::lround(p[1] * 1000.0f)),
                             static_cast<std::int32_t>(std::lround(p[2] * 1000.0f))});
      }
    });
    kept = viewer.kept();
    cloud_equals_map = viewer.hits() == points_sent && !kept.empty() && cloud_voxels == kept && width == kept.size();
    if (!cloud_equals_map) std::this_thread::sleep_for(50ms);
  }
  EXPECT_TRUE(cloud_equals_map) << clouds << " clouds; last " << width << " points, " << kept.size()
                                << " kept voxels of " << viewer.map.size() << ", map hits " << viewer.hits() << " of "
                                << points_sent;

  // rt/tf and rt/robotN/odom, stamped after every pose was stored: the tracker's prediction to the stamp,
  // through the REP-105 chain map -> robotN/odom (the correction) -> robotN/base_link.
  struct Planar {
    double x, y, yaw;
  };
  auto planar = [](const geometry_msgs_msg_dds__Transform_& t) {
    return Planar{t.translation.x, t.translation.y, yaw_of(t.rotation)};
  };
  std::map<std::pair<std::uint32_t, std::int64_t>, Planar> corrections;  // (robot, stamp) -> map_from_odom
  int transforms_checked = 0;
  const auto tf_deadline = std::chrono::steady_clock::now() + 10s;
  while (transforms_checked < 4 && std::chrono::steady_clock::now() < tf_deadline) {
    take_all<tf2_msgs_msg_dds__TFMessage_>(tf_reader, [&](const tf2_msgs_msg_dds__TFMessage_& m) {
      std::map<std::string, const geometry_msgs_msg_dds__TransformStamped_*> by_child;
      for (std::uint32_t i = 0; i < m.transforms._length; ++i) by_child[m.transforms._buffer[i].child_frame_id] = &m.transforms._buffer[i];
      for (std::uint32_t id : {1u, 2u}) {
        const auto odom = by_child.find(dds::ros2::odom_frame(id));
        const auto base = by_child.find(dds::ros2::base_link_frame(id));
        if (odom == by_child.end() && base == by_child.end()) continue;
        ASSERT_TRUE(odom != by_child.end() && base != by_child.end()) << "robot " << id << ": half a chain";
        const std::int64_t stamp = ns_of(base->second->header.stamp);
        EXPECT_EQ(ns_of(odom->second->header.stamp), stamp);
        EXPECT_STREQ(odom->second->header.frame_id, "map");
        EXPECT_EQ(std::string(base->second->header.frame_id), dds::ros2::odom_frame(id));
        const Planar c = planar(odom->second->transform), o = planar(base->second->transform);
        corrections[{id, stamp}] = c;
        if (stamp <= all_stored_ns) continue;
        const double x = c.x + std::cos(c.yaw) * o.x - std::sin(c.yaw) * o.y;
        const double y = c.y + std::sin(c.yaw) * o.x + std::cos(c.yaw) * o.y;
        const mapping::TeamState predicted = reference.predict(stamp);
        const mapping::RobotEstimate* e = predicted.find(static_cast<std::uint8_t>(id));
        ASSERT_NE(e, nullptr);
        EXPECT_NEAR(x, e->position_m.x, 1e-3) << id;
        EXPECT_NEAR(y, e->position_m.y, 1e-3) << id;
        EXPECT_EQ(base->second->transform.translation.z, 0.0);
        for (const auto* t : {odom->second, base->second}) {
          const auto& q = t->transform.rotation;
          EXPECT_NEAR(q.x * q.x + q.y * q.y + q.z * q.z + q.w * q.w, 1.0, 1e-9);
        }
        EXPECT_NEAR(std::remainder(c.yaw + o.yaw - robot_yaw(id), 2 * M_PI), 0.0, 2e-6) << id;
        ++transforms_checked;
      }
    });
    std::this_thread::sleep_for(20ms);
  }
  EXPECT_GE(transforms_checked, 4);
  std::printf("map cloud: %u points = the kept voxels (%zu voxels in teamscan/map), %u clouds read; %d robot chains checked\n",
              width, viewer.map.size(), clouds, transforms_checked);
  EXPECT_LT(kept.size(), viewer.map.size()) << "the filter removed no voxel: the kept/removed split is not exercised";

  for (std::uint32_t id : {1u, 2u}) {
    bool checked = false;
    const auto deadline = std::chrono::steady_clock::now() + 10s;
    while (!checked && std::chrono::steady_clock::now() < deadline) {
      take_all<tf2_msgs_msg_dds__TFMessage_>(tf_reader, [&](const tf2_msgs_msg_dds__TFMessage_& m) {
        for (std::uint32_t i = 0; i < m.transforms._length; ++i) {
          const auto& t = m.transforms._buffer[i];
          if (std::string(t.child_frame_id) == dds::ros2::odom_frame(id))
            corrections[{id, ns_of(t.header.stamp)}] = planar(t.transform);
        }
      });
      take_all<nav_msgs_msg_dds__Odometry_>(odom_readers[id - 1], [&](const nav_msgs_msg_dds__Odometry_& m) {
        const std::int64_t stamp = ns_of(m.header.stamp);
        const auto corr = corrections.find({id, stamp});  // the /tf of the same tick
        if (stamp <= all_stored_ns || checked || corr == corrections.end()) return;
        checked = true;
        EXPECT_EQ(std::string(m.header.frame_id), dds::ros2::odom_frame(id));
        EXPECT_EQ(std::string(m.child_frame_id), dds::ros2::base_link_frame(id));
        const mapping::TeamState predicted = reference.predict(stamp);
        const mapping::RobotEstimate* e = predicted.find(static_cast<std::uint8_t>(id));
        ASSERT_NE(e, nullptr);
        const Planar k = corr->second;
        const double cc = std::cos(k.yaw), sc = std::sin(k.yaw);
        const double px = m.pose.pose.position.x, py = m.pose.pose.position.y;
        EXPECT_NEAR(k.x + cc * px - sc * py, e->position_m.x, 1e-3);
        EXPECT_NEAR(k.y + sc * px + cc * py, e->position_m.y, 1e-3);
        EXPECT_NEAR(std::remainder(k.yaw + yaw_of(m.pose.pose.orientation) - robot_yaw(id), 2 * M_PI), 0.0, 2e-6);
        // The covariance back in the map frame: R C R^T.
        const double* pc = m.pose.covariance;
        const double xx = cc * cc * pc[0] - 2 * cc * sc * pc[1] + sc * sc * pc[7];
        const double yy = sc * sc * pc[0] + 2 * cc * sc * pc[1] + cc * cc * pc[7];
        EXPECT_NEAR(xx, e->position_cov_m2(0, 0), 1e-3 * e->position_cov_m2(0, 0) + 1e-12);
        EXPECT_NEAR(yy, e->position_cov_m2(1, 1), 1e-3 * e->position_cov_m2(1, 1) + 1e-12);
        EXPECT_GT(m.pose.covariance[35], 0.0);  // heading_sigma_deg's square
        // The tracked velocity in the robot's frame: forward at about the speed driven.
        const double c = std::cos(robot_yaw(id)), s = std::sin(robot_yaw(id));
        EXPECT_NEAR(m.twist.twist.linear.x, c * e->velocity_mps.x + s * e->velocity_mps.y, 1e-3);
        EXPECT_NEAR(m.twist.twist.linear.y, -s * e->velocity_mps.x + c * e->velocity_mps.y, 1e-3);
        EXPECT_NEAR(m.twist.twist.linear.x, kSpeedMps, 0.02);
      });
      if (!checked) std::this_thread::sleep_for(20ms);
    }
    EXPECT_TRUE(checked) << "no odometry of robot " << id << " after the last pose";
  }

  // A last stretch, then the stop at once: its scans are released by the stop's last turn (or later on
  // the pose graph's poses), within the cloud's interval, so only the stop's flush brings them to the
  // readers. What the readers hold last, the cloud and teamscan/map, is the model the station wrote.
  for (std::int64_t k = kPoses; k < kPoses + kLastPoses; ++k) {
    for (std::uint32_t id : {1u, 2u}) {
      (void)send_pose(k, id);
      for (int i = 0; i < kPointsPerScan; ++i)  // a wall of its own, above the first one's
        scan.points[i] = ScanPoint{6500, -3000 + 100 * i, 2000 + 100 * static_cast<std::int32_t>(k - kPoses), static_cast<std::uint16_t>(i), 0};
      ASSERT_TRUE(robots[id - 1].publish_scan(scan).ok());
    }
  }
  for (auto& b : robots) ASSERT_TRUE(b.wait_for_scan_acks(from_seconds(20.0)).ok());
  gs.signal(SIGTERM);
  const auto st = gs.wait(30s);
  ASSERT_TRUE(st.has_value());
  EXPECT_TRUE(WIFEXITED(*st) && WEXITSTATUS(*st) == 0);
  viewer.take();
  std::set<VoxelCentre> last_cloud;
  clouds = 0;
  take_all<sensor_msgs_msg_dds__PointCloud2_>(cloud_reader, [&](const sensor_msgs_msg_dds__PointCloud2_& m) {
    ++clouds;
    last_cloud.clear();
    for (std::uint32_t i = 0; i < m.width; ++i) {
      float p[3];
      std::memcpy(p, m.data._buffer + i * m.point_step, sizeof p);
      last_cloud.insert({static_cast<std::int32_t>(std::lround(p[0] * 1000.0f)), static_cast<std::int32_t>(std::lround(p[1] * 1000.0f)),
                         static_cast<std::int32_t>(std::lround(p[2] * 1000.0f))});
    }
  });
  ASSERT_GT(viewer.resolution_mm, 0u);
  const std::map<VoxelCentre, bool> model = model_voxels(session + "/fused_all.pcd", viewer.resolution_mm);
  std::set<VoxelCentre> model_kept, model_all;
  for (const auto& [centre, kept_at_release] : model) {
    model_all.insert(centre);
    if (kept_at_release) model_kept.insert(centre);
  }
  std::set<VoxelCentre> map_all;
  for (const auto& [centre, v] : viewer.map) map_all.insert(centre);
  EXPECT_GT(clouds, 0u) << "no cloud since the last check: the stop sent none";
  EXPECT_GT(model_kept.size(), kept.size()) << "the last stretch added no voxel";
  EXPECT_EQ(last_cloud, model_kept) << last_cloud.size() << " cloud points, " << model_kept.size() << " kept voxels in the model";
  EXPECT_EQ(map_all, model_all) << map_all.size() << " voxels on teamscan/map, " << model_all.size() << " in the model";
  EXPECT_EQ(viewer.kept(), model_kept);
  std::ifstream events(session + "/events.log");
  std::stringstream text;
  text << events.rdbuf();
  EXPECT_NE(text.str().find("ros2: "), std::string::npos) << "no ros2 figures in events.log";
  EXPECT_EQ(text.str().find(" 0 clouds"), std::string::npos);
  (void)dds_delete(ros);
  if (std::getenv("ROS2_KEEP_SESSION") == nullptr) std::filesystem::remove_all(root);
}

}  // namespace
}  // namespace teamscan
