// The ground station's receiving side: subscribes to teamscan/pose, /scan and /status of up
// to 32 robots, stores every sample with its receive time (SessionStore) before anything else sees it,
// detects robots that stop (liveliness / no-writers / dispose, DDS_SYSTEMD.md 3.2) and marks them lost,
// publishes teamscan/team from a TeamSource at a fixed rate, and hands every scan to the mapping hooks.
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <mutex>
#include <span>
#include <string>
#include <vector>

#include "common/capacities.hpp"
#include "common/result.hpp"
#include "common/time.hpp"
#include "groundstation/station/sample_validation.hpp"
#include "groundstation/station/scan_record.hpp"
#include "groundstation/station/sender_identity.hpp"
#include "groundstation/station/session_store.hpp"
#include "groundstation/station/stored_seqs.hpp"
#include "groundstation/station/team_source.hpp"

struct teamscan_msg_MapVoxel;
struct teamscan_msg_RobotPose;
struct teamscan_msg_RobotStatus;
struct teamscan_msg_ScanPoints;
struct teamscan_msg_TeamMember;

namespace teamscan::station {

// The one conversion of teamscan/scan: a received sample back into the robot's ScanPoints (into `out`,
// reused: no allocation), as the station stores it (scans.bin) and hands it on; returns its receipt
// (receive times, the validator's verdict). Every point the sample carries is kept: a count above
// MAX_BEAMS (refused) stores the MAX_BEAMS points of the fixed-size sample. An accepted scan goes back
// to the odometry-map frame (the robot's applied correction undone, and kept in `applied`:
// undo_applied_correction), so the session record and everything after it (the fusion core, its
// registration, `teamscan eval` of the session) see the frame of teamscan/pose; a refused one is stored
// as received.
Receipt stored_from(const teamscan_msg_ScanPoints& s, const ReceiveTime& at, Reject verdict, ScanPoints& out);

// A received pose in the station's units (the one conversion of teamscan/pose), received at `received`
// (CLOCK_REALTIME).
[[nodiscard]] PoseObservation pose_observation(const teamscan_msg_RobotPose& p, Time received);

// One member of teamscan/team from the team source's estimate (mm, mm/s, mm², µrad; the robot's
// odometry correction with its σ), marked lost if `lost`.
void team_member_from(const TeamMemberEstimate& e, bool lost, teamscan_msg_TeamMember& m);

struct StationOptions {
  std::uint32_t domain_id = 0xFFFFFFFFu;      // DDS_DOMAIN_DEFAULT
  // The robots' scan history depth (the scan reader itself keeps all): a scan seq that falls back by more
  // than this is taken as a restarted robot rather than a replay of the history.
  std::uint32_t scan_history_depth = 300;
  Duration team_period = std::chrono::milliseconds(50);    // 20 Hz
  Duration team_liveliness_lease = std::chrono::seconds(2);
  // Safety net beside liveliness: a robot heard of for this long (no pose, scan or status) is lost
  // even if its writers are alive (a hung robot loop). Zero: off.
  Duration silence_timeout = std::chrono::seconds(5);
  std::uint32_t take_batch = 64;               // samples taken per dds_take (preallocated)
  // Cyclone's receive threads run SCHED_BATCH (dds/receive_threads.hpp): they take the queued packets at
  // the loop's next tick or wait instead of preempting it for every packet.
  bool batch_receive_threads = true;
  // DDS Security credential bundle of the station (dds/security/credentials.hpp), checked by the caller;
  // empty: an unsecured participant.
  std::string pki_dir;
  // Validation at the edge (config [validation], docs/validation.md).
  ValidationOptions validation;
};

// Per-robot bookkeeping.
struct RobotRecord {
  std::uint32_t robot_id = 0;
  bool seen = false;
  bool lost = false;
  std::uint64_t scans = 0;
  std::uint64_t poses = 0;
  std::uint64_t statuses = 0;
  std::uint64_t scans_missing = 0;     // gaps in seq (writer history overrun while we were away)
  std::uint64_t scans_repeated = 0;    // seq not above the last one (robot restart or duplicate)
  std::uint64_t scans_duplicate = 0;   // a seq the session holds already (history replay, back-fill): not stored again
  std::uint64_t scans_backfilled = 0;  // stored from teamscan/backfill (the robot's ring)
  std::uint64_t poses_duplicate = 0;   // a pose seq the session holds already: not stored again
  std::uint64_t poses_backfilled = 0;  // stored from teamscan/backfill_pose (the robot's ring)
  std::uint32_t last_pose_seq = 0;
  // The robot's store and forward as its teamscan/status reports it (docs/onboard.md "The ring").
  std::uint32_t ring_unconfirmed = 0;    // scans in its ring the station has not confirmed
  std::uint32_t backfill_total = 0;      // to back-fill since it came back
  std::uint32_t backfill_remaining = 0;
  std::uint32_t last_shadow_ms = 0;      // its last shadow
  bool backfilling = false;
  Time whole_again;                    // CLOCK_REALTIME of the last back-fill's end (0: none yet)
  Time last_backfill_event;            // CLOCK_MONOTONIC: progress events every 5 s at most
  std::uint32_t last_scan_seq = 0;
  Time last_heard;                     // CLOCK_MONOTONIC
  Time lost_at;                        // CLOCK_MONOTONIC of the last transition to lost
  Time last_gap_event;                 // CLOCK_MONOTONIC: gap events are rate-limited to 1 per second
  std::uint64_t gaps_unreported = 0;
  std::uint64_t identity_mismatches = 0;  // samples claiming this robot's id sent by another participant
  Time last_identity_event;            // CLOCK_MONOTONIC: identity events are rate-limited to 1 per second
  std::uint8_t clock_sync = 0;         // the robot's own report (RobotStatus.clock_sync): 0 unknown, 1 yes, 2 no
  std::uint32_t teams_rejected = 0;    // the robot's count of refused team states (RobotStatus)
  std::uint32_t corrections_rejected = 0;  // the robot's count of refused own corrections (RobotStatus)
  // pose, scan, status, backfill, backfill_pose: publication handles, this robot's instance on each reader
  std::uint64_t writer_handles[5] = {0, 0, 0, 0, 0};
  std::uint64_t instance_handles[5] = {0, 0, 0, 0, 0};
};

struct StationCounters {
  std::uint64_t scans = 0;
  std::uint64_t poses = 0;
  std::uint64_t statuses = 0;
  std::uint64_t invalid_samples = 0;   // dispose / no-writers notifications
  std::uint64_t rejected = 0;          // refused at the edge (validator().counters() has the reasons): stored raw, not fused
  std::uint64_t teams_published = 0;
  std::uint64_t team_write_errors = 0;
  std::uint64_t liveliness_events = 0;
  std::uint64_t hook_failures = 0;     // a mapping hook threw; the station carried on
  std::uint64_t robots_lost = 0;       // transitions to lost
  std::uint64_t identity_mismatches = 0;  // a sample whose robot_id is not its sender's: refused, not stored
  std::uint64_t duplicate_scans = 0;   // a (robot, seq) the session holds already: not stored, not fused again
  std::uint64_t scans_backfilled = 0;  // stored from teamscan/backfill
  std::uint64_t duplicate_poses = 0;   // a (robot, pose seq) the session holds already: not stored again
  std::uint64_t poses_backfilled = 0;  // stored from teamscan/backfill_pose
  std::uint64_t stored_published = 0;  // teamscan/stored samples
  std::uint64_t recovered_scans = 0;   // (robot, seq) found in the session folder's scans.bin at start-up
  std::uint64_t recovered_poses = 0;   // (robot, pose seq) found in its poses.csv
};

using ScanHook = std::function<void(const ScanPoints&, const Receipt&)>;
using PoseHook = std::function<void(const PoseObservation&)>;
using LostHook = std::function<void(std::uint32_t robot_id, bool lost)>;

class Station {
 public:
  [[nodiscard]] static Result<std::unique_ptr<Station>> create(const StationOptions& options, SessionStore& store,
                                                               TeamSource& team);
  ~Station();
  Station(const Station&) = delete;
  Station& operator=(const Station&) = delete;

  // Waits up to max_wait for data, then takes and handles everything available. Returns the number of
  // valid samples handled.
  std::size_t poll(Duration max_wait);
  // Publishes teamscan/team if a period has passed since the last publication (CLOCK_MONOTONIC), and
  // teamscan/stored (what the session holds of each robot's scans) with it when that changed, or at
  // least once a second.
  bool publish_team_if_due(Time now_monotonic);
  // Checks the silence timeout (also done in poll).
  void check_silence(Time now_monotonic);
  // Makes a blocked poll() return early (thread-safe).
  void wake();

  // Mapping stage hooks, run after the sample is stored (a hook that throws is counted and logged).
  void add_scan_hook(ScanHook hook) { scan_hooks_.push_back(std::move(hook)); }
  void add_pose_hook(PoseHook hook) { pose_hooks_.push_back(std::move(hook)); }
  // Poses back-filled from a robot's ring (old by a radio shadow): stored, then these hooks only (the
  // fusion core's pose history), not the live pose hooks (tracker, view, ROS 2).
  void add_backfill_pose_hook(PoseHook hook) { backfill_pose_hooks_.push_back(std::move(hook)); }
  void add_lost_hook(LostHook hook) { lost_hooks_.push_back(std::move(hook)); }

  // Stops hearing the robots at the stop: the readers and the teamscan/team and teamscan/stored writers
  // are deleted, so a robot sees the station go and keeps what it sends from now on in its store for the
  // next one (nothing is taken that is not stored). The participant and teamscan/map stay, with the
  // process's other publishers (ROS 2), until the final model is out. poll() and publish_team_if_due()
  // do nothing after it.
  void close_inputs();
  [[nodiscard]] bool inputs_closed() const;

  // The station's DDS participant, for other publishers of the process (the ROS 2 topics): one
  // participant per process, one participant index per host in the site's Cyclone config.
  [[nodiscard]] std::int32_t participant() const;

  // teamscan/map for live viewers.
  [[nodiscard]] Status publish_map(std::span<const teamscan_msg_MapVoxel> voxels, std::uint32_t resolution_mm,
                                   std::uint32_t total_voxels);
  // Waits at most `timeout` for teamscan/map's readers to acknowledge what was published: true once they
  // did (the stop's last map).
  [[nodiscard]] bool map_acknowledged_within(Duration timeout);

  [[nodiscard]] const RobotRecord& robot(std::uint32_t robot_id) const;  // 1..32
  // The scans and poses of robot robot_id (1..32) the session holds (store and forward's confirmations).
  [[nodiscard]] const StoredSeqs& stored(std::uint32_t robot_id) const;
  [[nodiscard]] const StoredSeqs& stored_poses(std::uint32_t robot_id) const;
  [[nodiscard]] std::uint32_t robots_seen() const;
  [[nodiscard]] std::uint32_t robots_lost() const;
  [[nodiscard]] const StationCounters& counters() const { return counters_; }
  // One line for STATUS= and the journal.
  [[nodiscard]] std::string status_line() const;
  // The edge validation's counters and clock reports (sample_validation.hpp).
  [[nodiscard]] const SampleValidator& validator() const { return validator_; }
  // Rewrites validation.csv in the session folder (the validator's counters); false if it failed.
  bool write_validation() const;

  // Called from Cyclone's listener thread on LIVELINESS_CHANGED of any reader (queued, handled in poll).
  void push_liveliness(std::uint64_t writer_handle, int alive_change, int not_alive_change);
  // Called from Cyclone's listener thread when a reader matches a publication (resolved in poll).
  void push_matched(std::int32_t reader, std::uint64_t publication_handle);

 private:
  struct Dds;
  struct LivelinessEvent {
    std::uint64_t handle;
    int alive_change;
    int not_alive_change;
  };
  Station(const StationOptions& options, SessionStore& store, TeamSource& team);
  // The one receive loop of the three topics (defined in station.cpp): takes `topic`'s reader empty,
  // counts invalid samples (a dispose or no-writers notice ends the robot's instance), finds the robot
  // and hands each valid sample to on_sample(sample, robot, receive_time).
  template <class Sample, class OnSample>
  void take(int topic, OnSample&& on_sample);
  // The edge validation of one sample; a refused one is stored raw (marked) and reported here.
  // A refused sample stored raw, marked with its reason (validation, or a sender that is not the robot it
  // claims: counted in identity_mismatches).
  void store_refused(const teamscan_msg_RobotPose& p, const ReceiveTime& at, Reject reason);
  void store_refused(const teamscan_msg_RobotStatus& s, const ReceiveTime& at, Reject reason);
  void store_refused(const teamscan_msg_ScanPoints& s, const ReceiveTime& at, Reject reason);
  // A refused sample its own robot sent: its seq counts as stored (teamscan/stored), as it is, raw.
  void confirm_refused(const teamscan_msg_RobotPose& p);
  void confirm_refused(const teamscan_msg_ScanPoints& s);
  void confirm_refused(const teamscan_msg_RobotStatus& s);
  // Validates a received sample; a refused one is stored raw, marked, counted and logged (refused()).
  template <class Sample>
  Verdict check_and_store_if_refused(const Sample& sample, const ReceiveTime& at, int topic);
  void on_pose(const teamscan_msg_RobotPose& p, RobotRecord& r, const ReceiveTime& at);
  // A pose from the robot's ring (teamscan/backfill_pose): stored unless the session holds its seq, then
  // the back-fill pose hooks.
  void on_backfill_pose(const teamscan_msg_RobotPose& p, RobotRecord& r, const ReceiveTime& at);
  // Enters an accepted pose into the session once per seq; false: a duplicate, counted.
  bool store_pose(const teamscan_msg_RobotPose& p, RobotRecord& r, const ReceiveTime& at);
  void on_status(const teamscan_msg_RobotStatus& s, RobotRecord& r, const ReceiveTime& at);
  // The robot's ring report in its status: shadow, back-fill progress, whole again (events).
  void on_ring_status(const teamscan_msg_RobotStatus& s, RobotRecord& r, const ReceiveTime& at);
  void on_scan(const teamscan_msg_ScanPoints& s, RobotRecord& r, const ReceiveTime& at);
  // A scan from the robot's ring (teamscan/backfill): stored unless the session holds its seq, then the hooks.
  void on_backfill(const teamscan_msg_ScanPoints& s, RobotRecord& r, const ReceiveTime& at);
  // Stores an accepted scan (once per seq) and runs the scan hooks; false: a duplicate, counted.
  bool store_scan(const teamscan_msg_ScanPoints& s, RobotRecord& r, const ReceiveTime& at);
  // The (robot, seq) of every accepted scan and pose already in the session folder (a restart on the same
  // folder).
  void recover_stored();
  bool publish_stored(Time now_monotonic);
  void handle_liveliness_events();
  RobotRecord* heard(std::uint32_t robot_id, int topic, std::uint64_t writer, std::uint64_t instance, Time now_mono);
  // An invalid sample (dispose / no writers) on `topic`: the robot whose instance it is goes lost.
  void instance_ended(int topic, std::uint64_t instance, std::uint32_t instance_state);
  void set_lost(RobotRecord& r, bool lost, const std::string& why);
  // A sample the validator refused: counted, its raw header into rejected.csv, logged (rate-limited).
  void refused(SampleTopic topic, const Verdict& v, std::uint32_t robot_id, std::uint32_t seq, std::int64_t stamp_ns,
               const ReceiveTime& at);
  void event(const std::string& text);

  StationOptions options_;
  SessionStore& store_;
  TeamSource& team_;
  std::unique_ptr<Dds> dds_;
  SampleValidator validator_;
  std::array<RobotRecord, kMaxRobots + 1> robots_{};
  std::array<StoredSeqs, kMaxRobots + 1> stored_{};
  std::array<StoredSeqs, kMaxRobots + 1> stored_poses_{};
  bool stored_changed_ = false;
  Time last_stored_;
  std::uint32_t stored_seq_ = 0;
  StationCounters counters_{};
  Time last_team_;
  std::uint32_t team_seq_ = 0;
  std::uint32_t map_seq_ = 0;
  std::vector<ScanHook> scan_hooks_;
  std::vector<PoseHook> pose_hooks_;
  std::vector<PoseHook> backfill_pose_hooks_;
  std::vector<LostHook> lost_hooks_;
  std::mutex events_mutex_;                  // liveliness events come on Cyclone's threads
  std::vector<LivelinessEvent> events_;
  std::vector<LivelinessEvent> events_work_;
  std::vector<std::pair<std::int32_t, std::uint64_t>> matched_;       // (reader, publication), under events_mutex_
  std::vector<std::pair<std::int32_t, std::uint64_t>> matched_work_;
  SenderIdentity senders_;
};

}  // namespace teamscan::station
