// Cost of the ROS 2 publishers (docs/ros2.md "Cost"). The receive loop's side: handing a
// teamscan/map update (D changed voxels) or the team's 32 estimates to Ros2Publisher. The worker
// thread's side: building and writing the map cloud of V voxels (no reader / one local RViz-like reader)
// and one /tf + 32 odometry messages.
// Run: CYCLONEDDS_URI=file://$PWD/deploy/cyclonedds-lo.xml build/dev/tests/bench/station/station_ros2_bench
#include <benchmark/benchmark.h>

#include <dds/dds.h>

#include <unistd.h>

#include <vector>

#include "common/clock.hpp"
#include "dds/ros2/wire.hpp"
#include "groundstation/station/ros2_publisher.hpp"
#include "teamscan.h"

namespace {

using namespace teamscan;

dds_entity_t participant() {
  static const dds_entity_t p = dds_create_participant(static_cast<dds_domainid_t>(1 + ::getpid() % 230), nullptr, nullptr);
  return p;
}

std::vector<teamscan_msg_MapVoxel> voxels(std::size_t n, std::int32_t z_mm) {
  std::vector<teamscan_msg_MapVoxel> v(n);
  for (std::size_t i = 0; i < n; ++i) {
    v[i] = {static_cast<std::int32_t>(i % 200) * 100 + 50, static_cast<std::int32_t>(i / 200 % 200) * 100 + 50,
            z_mm + static_cast<std::int32_t>(i / 40000) * 100, 3, 0};
  }
  return v;
}

// Loop side: one teamscan/map update of range(0) changed voxels handed over (a whole map every 10th).
void BM_LoopOfferMap(benchmark::State& state) {
  auto p = station::Ros2Publisher::create(station::Ros2Config{}, participant());
  if (!p) {
    state.SkipWithError("no publisher");
    return;
  }
  const auto update = voxels(static_cast<std::size_t>(state.range(0)), 50);
  std::uint64_t i = 0;
  for (auto _ : state) {
    const bool full = i++ % 10 == 0;
    p.value()->offer_map(update, full ? static_cast<std::uint32_t>(update.size()) : 1'000'000u);
  }
  state.SetItemsProcessed(static_cast<std::int64_t>(state.iterations()) * state.range(0));
}
BENCHMARK(BM_LoopOfferMap)->Arg(1000)->Arg(10000)->Arg(50000)->Unit(benchmark::kMicrosecond);

// Loop side: a tick that hands over 32 robots' estimates (the last-pose source's; the Kalman tracker's
// prediction costs what it costs for teamscan/team too). Pose rate 1 kHz with 1 ms steps: every tick.
void BM_LoopTickTeam32(benchmark::State& state) {
  station::Ros2Config c;
  c.pose_rate_hz = 1000.0;
  auto p = station::Ros2Publisher::create(c, participant());
  if (!p) {
    state.SkipWithError("no publisher");
    return;
  }
  station::LastPoseTeamSource team;
  station::PoseObservation pose;
  pose.stamp = now_realtime();
  for (std::uint32_t i = 1; i <= 32; ++i) {
    pose.robot_id = i;
    team.add_pose(pose);
    p.value()->add_pose(pose);
  }
  Time t = now_monotonic();
  for (auto _ : state) {
    t += std::chrono::milliseconds(1);
    p.value()->tick(t, team);
  }
}
BENCHMARK(BM_LoopTickTeam32)->Unit(benchmark::kMicrosecond);

// Worker side: the cloud of range(0) voxels built and written; range(1) = 1: one local reader
// (reliable, volatile, depth 5: RViz2's profile) that takes what it gets.
void BM_WorkerMapCloud(benchmark::State& state) {
  auto w = dds::ros2::Ros2Writers::create(participant());
  if (!w) {
    state.SkipWithError("no writers");
    return;
  }
  dds_entity_t reader = 0;
  if (state.range(1) != 0) {
    const dds_entity_t t = dds_create_topic(participant(), &sensor_msgs_msg_dds__PointCloud2__desc, dds::ros2::kTopicMapCloud, nullptr, nullptr);
    dds_qos_t* q = dds::ros2::make_rmw_like_reader_qos(true, false, 5);
    reader = dds_create_reader(participant(), t, q, nullptr);
    dds_delete_qos(q);
  }
  std::vector<dds::ros2::CloudPoint> points(static_cast<std::size_t>(state.range(0)));
  for (std::size_t i = 0; i < points.size(); ++i) points[i] = {0.1f * static_cast<float>(i % 200), 0.1f * static_cast<float>(i / 200), 0.5f, 2.0f};
  dds::ros2::PointCloudMessage cloud;
  for (auto _ : state) {
    cloud.set(now_realtime().ns(), dds::ros2::kFrameMap, points);
    benchmark::DoNotOptimize(w.value()->write_cloud(cloud).ok());
    if (reader > 0) {
      state.PauseTiming();
      void* samples[5] = {};
      dds_sample_info_t infos[5];
      const int n = dds_take(reader, samples, infos, 5, 5);
      if (n > 0) (void)dds_return_loan(reader, samples, n);
      state.ResumeTiming();
    }
  }
  if (reader > 0) (void)dds_delete(reader);
  state.SetBytesProcessed(static_cast<std::int64_t>(state.iterations()) * state.range(0) * 16);
}
BENCHMARK(BM_WorkerMapCloud)
    ->Args({10000, 0})->Args({100000, 0})->Args({300000, 0})->Args({100000, 1})->Unit(benchmark::kMillisecond);

// Worker side: one rt/tf message with 32 robots and 32 odometry messages.
void BM_WorkerTfAndOdometry32(benchmark::State& state) {
  auto w = dds::ros2::Ros2Writers::create(participant());
  if (!w) {
    state.SkipWithError("no writers");
    return;
  }
  std::vector<dds::ros2::PlanarState> states(32);
  for (std::uint32_t i = 0; i < 32; ++i) {
    states[i].robot_id = i + 1;
    states[i].x_m = i;
    states[i].yaw_rad = 0.1 * i;
  }
  dds::ros2::TfMessage tf;
  dds::ros2::OdometryMessage odom;
  for (auto _ : state) {
    for (auto& s : states) s.stamp_ns = now_realtime().ns();
    tf.set(states);
    benchmark::DoNotOptimize(w.value()->write_tf(tf).ok());
    for (const auto& s : states) {
      odom.set(s);
      benchmark::DoNotOptimize(w.value()->write_odometry(s.robot_id, odom).ok());
    }
  }
}
BENCHMARK(BM_WorkerTfAndOdometry32)->Unit(benchmark::kMicrosecond);

}  // namespace
