// DDS bridge of the robot daemon: publishes teamscan/pose, teamscan/scan, teamscan/status and takes
// teamscan/team (DESIGN.md "DDS topics"). All samples are allocated once in create(); after that a
// publish allocates nothing in our code and a constant 3 blocks inside Cyclone's dds_write
// (DDS_SYSTEMD.md 1.8: integer key, instance registered once, static TX sample).
#pragma once

#include <cstdint>
#include <memory>
#include <utility>

#include "common/result.hpp"
#include "common/time.hpp"
#include "dds/participant.hpp"
#include "dds/qos.hpp"
#include "dds/take.hpp"
#include "onboard/core/config.hpp"
#include "onboard/core/messages.hpp"

namespace teamscan::onboard {

struct DdsBridgeOptions {
  std::uint32_t robot_id = 1;               // 1..kMaxRobots, the instance key of every topic
  std::uint32_t domain_id = dds::kDefaultDomain;
  // Scans kept by the writer (and offered to late joiners, durability transient-local): a ground station
  // that restarts within depth / scan rate seconds receives every scan it missed. 300 = 4 s at 75 Hz.
  std::uint32_t scan_history_depth = 300;
  // Of those, what a reader that joins late or matches again after a radio shadow gets at once (0: all of
  // scan_history_depth). With store_and_forward the ring back-fills the rest (dds/qos.hpp).
  std::uint32_t scan_late_joiner_depth = 0;
  // Poses kept the same way, as long as the scans (64 = 6.4 s at the 10 Hz SIP rate ≥ the scans' 4 s):
  // an outage of the ground station leaves no hole in the poses while no scan is missing, so the scans
  // of the outage get their team state and their ghosts are removed (docs/groundstation.md).
  std::uint32_t pose_history_depth = kPoseHistoryDepth;
  // Automatic liveliness lease of every writer: the ground station marks the robot lost within about
  // this long after the process dies. >= 2 s: a 1 s lease was lost spuriously on a loaded 2-core host
  // (DDS_SYSTEMD.md 3.2); the lease must stay below the 3 s detection requirement.
  Duration liveliness_lease = std::chrono::milliseconds(2000);
  // How long a reliable dds_write may block when the writer history is full (keep-last never blocks).
  Duration max_blocking = std::chrono::milliseconds(10);
  bool subscribe_team = true;               // create the teamscan/team reader
  // Store and forward: the teamscan/backfill and teamscan/backfill_pose writers and the teamscan/stored
  // reader (docs/onboard.md).
  bool store_and_forward = false;
  // DDS Security credential bundle of this robot (dds/security/credentials.hpp), checked by the caller;
  // null: an unsecured participant.
  const char* pki_dir = nullptr;
};

struct DdsBridgeCounters {
  std::uint32_t poses_written = 0;
  std::uint32_t scans_written = 0;
  std::uint32_t status_written = 0;
  std::uint32_t write_errors = 0;
  std::uint32_t teams_taken = 0;
  std::uint32_t bad_team_samples = 0;       // count out of range; dropped
  std::uint32_t backfills_written = 0;
  std::uint32_t backfill_poses_written = 0;
  std::uint32_t stored_taken = 0;
  std::uint32_t bad_stored_samples = 0;     // count out of range; dropped
};

class DdsBridge {
 public:
  [[nodiscard]] static Result<DdsBridge> create(const DdsBridgeOptions& options);

  DdsBridge(DdsBridge&& other) noexcept = default;
  DdsBridge& operator=(DdsBridge&& other) noexcept = default;
  DdsBridge(const DdsBridge&) = delete;
  DdsBridge& operator=(const DdsBridge&) = delete;
  ~DdsBridge() = default;  // the participant's deletion disposes this robot's instances

  // Publish one sample. Fails (counted) if the DDS write fails or the sample's robot_id differs from
  // the bridge's (a programming error elsewhere, but a runtime fault here: never abort on the robot).
  [[nodiscard]] Status publish_pose(const OnboardPose& pose);
  [[nodiscard]] Status publish_scan(const ScanPoints& scan);
  [[nodiscard]] Status publish_status(const OnboardStatus& status);
  // A scan re-published from the ring (teamscan/backfill, on the lane of its seq: dds::kBackfillLanes);
  // fails without store_and_forward.
  [[nodiscard]] Status publish_backfill(const ScanPoints& scan);
  // A pose re-published from the ring (teamscan/backfill_pose); fails without store_and_forward.
  [[nodiscard]] Status publish_backfill_pose(const OnboardPose& pose);

  // The newest team state received since the last call, if any. Never blocks, never allocates.
  [[nodiscard]] bool take_team(TeamSnapshot& out);
  // The newest teamscan/stored since the last call, if any. Never blocks, never allocates.
  [[nodiscard]] bool take_stored(StoredSnapshot& out);

  // Blocks until every matched reader acknowledged every scan written so far, or `timeout` (for an
  // orderly stop: SIGTERM flushes the last sweeps before the participant goes away). Not a data-path call.
  [[nodiscard]] Status wait_for_scan_acks(Duration timeout);

  // Number of ground stations (readers) currently matched to the scan writer.
  [[nodiscard]] std::uint32_t scan_subscribers() const;
  // Readers matched to the scan writer since it was created (each rematch counts): DDS's total_count.
  [[nodiscard]] std::uint32_t scan_reader_matches() const;
  [[nodiscard]] const DdsBridgeCounters& counters() const { return counters_; }

 private:
  // The transmit samples, allocated once in create().
  struct Samples {
    teamscan_msg_RobotPose pose_tx;
    teamscan_msg_ScanPoints scan_tx;
    teamscan_msg_RobotStatus status_tx;
    teamscan_msg_ScanPoints backfill_tx;
    teamscan_msg_RobotPose backfill_pose_tx;
  };
  explicit DdsBridge(dds::Participant participant)
      : participant_{std::move(participant)}, team_rx_{1}, stored_rx_{1} {}

  // Declared first, destroyed last: the writers and reader below belong to it.
  dds::Participant participant_;
  dds_entity_t pose_writer_ = 0;
  dds_entity_t scan_writer_ = 0;
  dds_entity_t status_writer_ = 0;
  dds_entity_t team_reader_ = 0;
  dds_entity_t backfill_writers_[dds::kBackfillLanes] = {};  // lane = scan seq % kBackfillLanes
  dds_entity_t backfill_pose_writer_ = 0;
  dds_entity_t stored_reader_ = 0;
  std::uint32_t robot_id_ = 0;
  std::unique_ptr<Samples> samples_;
  dds::TakeBuffer<teamscan_msg_TeamState> team_rx_;  // keep-last 1: one sample at a time
  dds::TakeBuffer<teamscan_msg_StoredState> stored_rx_;
  DdsBridgeCounters counters_{};
};

// Pure conversions between the onboard structs and the generated IDL types (no DDS, no allocation). The
// scan sample is common/scan_points.hpp ScanPoints written out to the wire's layout.
void encode_pose(const OnboardPose& in, teamscan_msg_RobotPose& out);
void encode_scan(const ScanPoints& in, teamscan_msg_ScanPoints& out);
void encode_status(const OnboardStatus& in, teamscan_msg_RobotStatus& out);
// False (out unchanged beyond count) if the sample's count is out of range.
[[nodiscard]] bool decode_team(const teamscan_msg_TeamState& in, TeamSnapshot& out);
[[nodiscard]] bool decode_stored(const teamscan_msg_StoredState& in, StoredSnapshot& out);

}  // namespace teamscan::onboard
