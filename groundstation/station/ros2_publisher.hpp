// The ground station on ROS 2 wire names (issue 13, docs/ros2.md): the fused map as PointCloud2 on
// rt/teamscan/map_cloud, every tracked robot on rt/tf (map -> robotN/base_link) and its odometry on
// rt/robotN/odom, through dds/ros2 on the station's participant. The receive loop only hands over what it
// has anyway -- each teamscan/map update (changed voxels, or the whole map) and the team source's
// estimates at the pose rate -- by copying them into a mailbox it never waits for (try-lock: when the
// worker holds it, the hand-over is retried on the next loop turn); a worker thread merges the map
// updates into its own copy of the map, builds the messages and writes them.
#pragma once

#include <array>
#include <condition_variable>
#include <cstdint>
#include <memory>
#include <mutex>
#include <span>
#include <thread>
#include <vector>

#include "common/capacities.hpp"
#include "common/result.hpp"
#include "common/time.hpp"
#include "groundstation/station/config.hpp"
#include "groundstation/station/team_source.hpp"

struct teamscan_msg_MapVoxel;

namespace teamscan::station {

struct Ros2Counters {
  std::uint64_t map_updates = 0;      // teamscan/map updates handed over
  std::uint64_t clouds = 0;
  std::uint64_t tf_messages = 0;
  std::uint64_t odometry = 0;
  std::uint64_t write_errors = 0;
  std::uint64_t last_cloud_points = 0;
  std::uint64_t map_voxels = 0;       // voxels in the worker's copy of the map (kept and removed)
  Duration cloud_max{0};              // build + write of one cloud on the worker thread
  Duration cloud_total{0};
  Duration offer_max{0};              // the loop's side: the longest offer_map / tick call
  std::uint64_t handovers_deferred = 0;  // the worker held the mailbox: retried on the next loop turn
};

// A tracked robot's heading: yaw and yaw rate of its newest odometry pose.
struct Heading {
  bool known = false;
  Time stamp;
  double yaw_rad = 0.0;
  double yaw_rate_radps = 0.0;
};

// The robot's pose on rt/tf and rt/robotN/odom at the estimate's time: the tracked position, velocity
// and covariance, and the newest odometry heading moved on with its yaw rate (at most 0.5 s).
[[nodiscard]] double heading_at(const Heading& h, Time at);

class Ros2Publisher {
 public:
  // `participant`: the station's (Station::participant()); must outlive this object.
  [[nodiscard]] static Result<std::unique_ptr<Ros2Publisher>> create(const Ros2Config& config, std::int32_t participant);
  ~Ros2Publisher();  // stops the worker, deletes the writers
  Ros2Publisher(const Ros2Publisher&) = delete;
  Ros2Publisher& operator=(const Ros2Publisher&) = delete;

  // Receive loop side, all cheap. Every received pose (Station pose hook): its heading.
  void add_pose(const PoseObservation& pose);
  // Each teamscan/map update as published: total_voxels == voxels.size() marks the whole map.
  void offer_map(std::span<const teamscan_msg_MapVoxel> voxels, std::uint32_t total_voxels);
  // Every loop turn: at the pose rate, the team source's estimates now (CLOCK_REALTIME) are handed
  // over; a deferred map hand-over is retried.
  void tick(Time now_monotonic, const TeamSource& team);

  [[nodiscard]] Ros2Counters counters() const;
  [[nodiscard]] const Ros2Config& config() const { return config_; }

 private:
  struct Worker;
  Ros2Publisher(const Ros2Config& config, std::unique_ptr<Worker> worker);
  void run();
  // Loop side: moves the loop's buffers into the mailbox if the worker does not hold it.
  void hand_over();

  Ros2Config config_;
  // The loop's own: headings (index robot id), map updates and estimates not handed over yet.
  std::array<Heading, kMaxRobots + 1> headings_{};
  std::vector<teamscan_msg_MapVoxel> loop_map_;
  bool loop_full_ = false;
  std::uint64_t loop_updates_ = 0;
  std::array<TeamMemberEstimate, kMaxRobots> loop_team_{};
  std::size_t loop_team_count_ = 0;
  bool loop_team_pending_ = false;
  Time next_poses_;
  Duration offer_max_{0};
  std::uint64_t deferred_ = 0;

  mutable std::mutex mutex_;  // guards the mailbox, stop_ and counters_
  std::condition_variable wake_;
  bool stop_ = false;
  std::vector<teamscan_msg_MapVoxel> pending_map_;  // updates not merged yet (a whole map restarts it)
  bool pending_full_ = false;
  std::uint64_t pending_updates_ = 0;
  std::vector<TeamMemberEstimate> pending_team_;
  std::array<Heading, kMaxRobots + 1> pending_headings_{};
  bool team_pending_ = false;
  Ros2Counters counters_;

  std::unique_ptr<Worker> worker_;
  std::thread thread_;
};

}  // namespace teamscan::station
