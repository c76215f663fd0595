// The ground station on ROS 2 wire names (docs/ros2.md): the fused map as PointCloud2 on
// rt/teamscan/map_cloud, every tracked robot on rt/tf (REP-105: map -> robotN/odom, the correction ->
// robotN/base_link), the configured laser mounts on rt/tf_static (robotN/base_link -> robotN/laser), its odometry on rt/robotN/odom (in robotN/odom) and its scans on rt/robotN/scan (in
// robotN/base_link at the scan stamp), through dds/ros2 on the station's participant. The receive loop only hands over what it
// has anyway -- each teamscan/map update (changed voxels, or the whole map), each stored scan's placed
// points and the team source's estimates at the pose rate -- by copying them into a mailbox it never
// waits for (try-lock: when the worker holds it, the hand-over is retried on the next loop turn); a worker
// thread merges the map updates into its own copy of the map, builds the messages and writes them.
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
#include "dds/ros2/wire.hpp"
#include "groundstation/station/config.hpp"
#include "common/pose.hpp"
#include "groundstation/station/scan_record.hpp"
#include "groundstation/station/team_source.hpp"

struct teamscan_msg_MapVoxel;

namespace teamscan::station {

struct Ros2Counters {
  std::uint64_t map_updates = 0;      // teamscan/map updates handed over
  std::uint64_t clouds = 0;
  std::uint64_t tf_messages = 0;
  std::uint64_t odometry = 0;
  std::uint64_t scans = 0;
  std::uint64_t scans_dropped = 0;    // more than kMaxPendingScans waited for the worker: the oldest went
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

// robotN/base_link -> robotN/laser of each configured mount ([[ros2.laser_mount]]), for rt/tf_static and
// the view's /tf_static.
[[nodiscard]] std::vector<dds::ros2::FrameTransform> laser_transforms(const Ros2Config& config, std::int64_t stamp_ns);

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
  // Each stored scan (Station scan hook): its placed points for rt/robotN/scan. With `odom_from_base`, the
  // robot's odometry pose at the scan's stamp (the fusion core's pose history), in robotN/base_link at that
  // stamp (REP-105; each beam was placed with the odometry at its own time, so the cloud is deskewed);
  // without it, in robotN/odom (the frame the station stores scans in: the robot's odometry, its applied
  // correction undone). Refused scans and unplaced points are left out.
  void add_scan(const ScanPoints& scan, const Receipt& receipt, const Pose2* odom_from_base = nullptr);
  // Each teamscan/map update as published: total_voxels == voxels.size() marks the whole map.
  void offer_map(std::span<const teamscan_msg_MapVoxel> voxels, std::uint32_t total_voxels);
  // Every loop turn: at the pose rate, the team source's estimates now (CLOCK_REALTIME) are handed
  // over; a deferred map hand-over is retried.
  void tick(Time now_monotonic, const TeamSource& team);

  // The stop: hands over what the loop holds (waiting for the mailbox if need be), has the worker write
  // the map cloud now whatever its interval, and waits at most `timeout` for the cloud's readers to
  // acknowledge it. True once they did (or there is no map to send).
  [[nodiscard]] bool flush(Duration timeout);

  [[nodiscard]] Ros2Counters counters() const;
  [[nodiscard]] const Ros2Config& config() const { return config_; }

 private:
  struct Worker;
  Ros2Publisher(const Ros2Config& config, std::unique_ptr<Worker> worker);
  void run();
  // Loop side: moves the loop's buffers into the mailbox if the worker does not hold it.
  void hand_over();
  // Moves the loop's buffers into the mailbox (mutex_ held).
  void move_to_mailbox();

  // Scans waiting for the worker: their points in one flat buffer.
  struct PendingScan {
    std::uint32_t robot_id = 0;
    std::int64_t stamp_ns = 0;
    std::size_t first = 0;
    std::size_t count = 0;
    bool in_base_link = false;  // else in robotN/odom
  };
  static constexpr std::size_t kMaxPendingScans = 512;
  struct ScanBatch {
    std::vector<PendingScan> scans;
    std::vector<dds::ros2::CloudPoint> points;
    void clear() {
      scans.clear();
      points.clear();
    }
  };

  Ros2Config config_;
  ScanBatch loop_scans_;
  std::uint64_t loop_scans_dropped_ = 0;
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
  ScanBatch pending_scans_;
  bool team_pending_ = false;
  // flush(): the requests made and done (the worker's rounds), the last one's acknowledgement.
  std::condition_variable flushed_;
  std::uint64_t flushes_asked_ = 0, flushes_done_ = 0;
  Duration flush_timeout_{0};
  bool flush_acknowledged_ = false;
  Ros2Counters counters_;

  std::unique_ptr<Worker> worker_;
  std::thread thread_;
};

}  // namespace teamscan::station
