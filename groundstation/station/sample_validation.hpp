// Validation at the edge (docs/validation.md): every pose, scan and status sample the station takes from
// DDS is checked against the IDL's ranges and physical sense before anything but the raw store sees it.
// Pure state (no I/O, no DDS): per robot and topic the sequence progress, per robot the clock offset
// seen in the stamps, and counters per robot and reason. A refused sample is still stored raw by the
// station (marked with its reason); it never reaches the tracker, the filters, the map or the statistics.
#pragma once

#include <array>
#include <cstdint>
#include <string>

#include "common/capacities.hpp"
#include "common/time.hpp"

struct teamscan_msg_RobotPose;
struct teamscan_msg_ScanPoints;
struct teamscan_msg_RobotStatus;

namespace teamscan::station {

// Why a sample was refused. The code is stored with the raw sample (scans.bin's record, the `rejected`
// column of poses.csv and status.csv): 0 = accepted. Append only; never renumber.
enum class Reject : std::uint16_t {
  kNone = 0,
  kRobotId = 1,       // robot_id outside 1..MAX_ROBOTS
  kBeamCount = 2,     // scan count above MAX_BEAMS
  kBeamIndex = 3,     // a point's beam index at or above MAX_BEAMS
  kOutsideSite = 4,   // pose, scan origin or a placed point outside the site's bounds
  kYaw = 5,           // yaw outside (−π, π]
  kVelocity = 6,      // speed or yaw rate beyond the plausible maximum
  kClockUnset = 7,    // stamp before clock_set_after: the robot's clock was never set (1970)
  kStampBehind = 8,   // stamp older than max_stamp_age at receipt: the robot's clock is behind
  kStampAhead = 9,    // stamp more than max_stamp_ahead after receipt: the robot's clock is ahead
  kSeqJump = 10,      // sequence number jumped (far forward, or far back without a restart)
  kIdentity = 11,     // sent by another participant than the robot it claims (DDS Security partitions)
  kCorrection = 12,   // a scan's applied correction (corr_*): yaw outside (−π, π], a shift beyond the
                      // site's extent, or values with corr_seq 0 (none applied)
};
inline constexpr std::size_t kRejectReasons = 13;  // including kNone
[[nodiscard]] const char* reject_name(Reject r);    // "robot_id", "beam_count", ... ("accepted" for kNone)

// kBackfill, kBackfillPose: teamscan/backfill and teamscan/backfill_pose, the scans and poses a robot
// re-publishes from its ring (docs/onboard.md "The ring").
enum class SampleTopic : std::uint8_t { kPose = 0, kScan = 1, kStatus = 2, kBackfill = 3, kBackfillPose = 4 };
inline constexpr std::size_t kSampleTopics = 5;
[[nodiscard]] const char* topic_name(SampleTopic t);  // "pose", "scan", "status", "backfill", "backfill_pose"

struct ValidationOptions {
  // The site's bounds in the map frame (metres): poses, scan origins and placed points outside are
  // refused. Defaults: ±10 km horizontally, −1 km .. +1 km vertically (config [validation]).
  double site_min_x_m = -10000.0, site_max_x_m = 10000.0;
  double site_min_y_m = -10000.0, site_max_y_m = 10000.0;
  double site_min_z_m = -1000.0, site_max_z_m = 1000.0;
  // Stamps must lie in [receive − max_stamp_age, receive + max_stamp_ahead] (CLOCK_REALTIME of the
  // station). The age covers the robots' scan history replayed to a restarted station (300 scans = 4 s)
  // and a loaded station's backlog.
  Duration max_stamp_age = std::chrono::seconds(30);
  Duration max_stamp_ahead = std::chrono::seconds(2);
  // A back-filled scan or pose (teamscan/backfill, teamscan/backfill_pose) is as old as the radio shadow it was taken in, plus its queue
  // in the robot's ring: its stamp may lie this far before receipt. Its seq is not checked against the
  // live numbering (a back-fill goes back by the whole shadow); the station stores each seq once.
  Duration max_backfill_age = std::chrono::hours(24);
  // A stamp before this is a clock that was never set (stamps near 1970). 2020-01-01T00:00:00Z.
  std::int64_t clock_set_after_ns = 1'577'836'800'000'000'000;
  // A robot whose stamps lie further than this from the receive times (minimum over clock_window) is
  // reported as "clock off" in the station's log and status, with the offset.
  Duration clock_offset_warn = std::chrono::milliseconds(500);
  Duration clock_window = std::chrono::seconds(5);
  // Plausible motion (a Pioneer 3-AT: 0.7 m/s, 300°/s; with a wide margin).
  double max_speed_mps = 10.0;
  double max_yaw_rate_radps = 10.0;
  // Sequence progress per robot and topic, modulo 2^32 (a wrap from 2^32−1 to 0 is progress):
  //   forward by 1..max_seq_jump: progress (gaps are the station's missing-scan count);
  //   back by at most replay_window: a replay of the robot's DDS history (accepted; fusion de-duplicates);
  //   back further to a seq ≤ restart_seq_max: a restarted robot (accepted, new base);
  //   anything else: kSeqJump, until resync_after samples in a row continue the new numbering.
  std::uint32_t max_seq_jump = 45'000;     // 10 min of scans at 75 Hz
  std::uint32_t replay_window = 1024;      // ≥ the robots' scan history depth (dds.scan_history_depth)
  std::uint32_t restart_seq_max = 1000;
  std::uint32_t resync_after = 3;
  // A refusal is logged at most once per reason in this interval (with the count since the last line).
  Duration log_interval = std::chrono::seconds(10);
};

// A verdict with the offending value (for the log line): e.g. the robot id, the count, the stamp.
struct Verdict {
  Reject reason = Reject::kNone;
  std::int64_t value = 0;
  [[nodiscard]] bool ok() const { return reason == Reject::kNone; }
};

// The clock offset a robot's stamps show: receive time − stamp, minimum over a window (≈ the clock
// offset plus the smallest transport delay). Positive: the robot's stamps are behind the station's clock.
struct RobotClock {
  bool any = false;
  bool unset = false;          // the newest stamp was before clock_set_after (clock never set)
  bool off = false;            // |offset| > clock_offset_warn (reported once on each change)
  std::int64_t offset_ns = 0;  // of the last complete window (or the current one before the first ends)
  std::int64_t window_min_ns = 0;
  Time window_start;           // CLOCK_REALTIME receive time the current window began
  bool window_any = false;
  bool window_complete = false;  // a whole window has passed (offset_ns is its minimum)
};

struct ValidationCounters {
  // [robot id 0..32][reason]: index 0 collects samples whose robot id is out of range.
  std::array<std::array<std::uint64_t, kRejectReasons>, kMaxRobots + 1> by_robot{};
  std::array<std::uint64_t, kRejectReasons> by_reason{};  // [kNone] = accepted samples
  std::array<std::uint64_t, kSampleTopics> rejected_by_topic{};
  std::uint64_t rejected = 0;
  std::uint64_t seq_resyncs = 0;   // a new numbering accepted after resync_after consistent samples
  std::uint64_t seq_restarts = 0;  // a robot's numbering restarted (seq ≤ restart_seq_max)
};

class SampleValidator {
 public:
  explicit SampleValidator(const ValidationOptions& options = {});

  // Each check counts its verdict. `received` is the station's CLOCK_REALTIME at the take.
  Verdict check_pose(const teamscan_msg_RobotPose& pose, Time received);
  Verdict check_scan(const teamscan_msg_ScanPoints& scan, Time received);
  Verdict check_status(const teamscan_msg_RobotStatus& status, Time received);
  // A back-filled scan: check_scan's checks but for the seq, with the stamp window max_backfill_age; its
  // stamp is not taken into the robot's clock offset (it is old by design).
  Verdict check_backfill(const teamscan_msg_ScanPoints& scan, Time received);
  // A back-filled pose: check_pose's checks but for the seq, with the stamp window max_backfill_age.
  Verdict check_backfill_pose(const teamscan_msg_RobotPose& pose, Time received);

  // The rate-limited log line for a refusal (empty: not due). `now` is CLOCK_MONOTONIC.
  [[nodiscard]] std::string log_line(const Verdict& v, SampleTopic topic, std::uint32_t robot_id, Time now);
  // Clock reports: calls on_change(robot, text) for each robot whose "clock off" state changed since
  // the last call ("robot 3 clock off: stamps 12.345 s behind the station's receive times").
  template <class F>
  void clock_changes(F&& on_change);

  [[nodiscard]] const ValidationCounters& counters() const { return counters_; }
  [[nodiscard]] const RobotClock& clock(std::uint32_t robot_id) const { return clocks_[robot_id]; }  // 1..32
  [[nodiscard]] const ValidationOptions& options() const { return options_; }
  // "rejected N (reason a, reason b); clock off: r3 +12.3 s, r5 unset" (empty parts left out).
  [[nodiscard]] std::string status_text() const;
  // validation.csv for the session folder: `robot,reason,count` for every non-zero counter, then the
  // clock offsets `clock,robot,offset_ms,state`.
  [[nodiscard]] std::string csv() const;

 private:
  struct SeqState {
    bool any = false;
    std::uint32_t last = 0;
    bool pending = false;         // a jumped numbering seen, not yet accepted
    std::uint32_t pending_last = 0;
    std::uint32_t pending_run = 0;
  };
  Verdict check_header(SampleTopic topic, std::uint32_t robot_id, std::int64_t stamp_ns, Time received);
  // The checks of a scan's body (count, correction, origin, points) after its header.
  Verdict check_scan_body(const teamscan_msg_ScanPoints& scan);
  // ... and of a pose's (site, yaw, motion).
  [[nodiscard]] Verdict check_pose_body(const teamscan_msg_RobotPose& pose) const;
  Verdict check_seq(SampleTopic topic, std::uint32_t robot_id, std::uint32_t seq);
  void observe_clock(std::uint32_t robot_id, std::int64_t stamp_ns, Time received);
  Verdict count(SampleTopic topic, std::uint32_t robot_id, Verdict v);
  [[nodiscard]] bool inside_site(std::int64_t x_mm, std::int64_t y_mm, std::int64_t z_mm) const;
  [[nodiscard]] bool inside_site_xy(std::int64_t x_mm, std::int64_t y_mm) const;

  ValidationOptions options_;
  std::int64_t min_x_mm_, max_x_mm_, min_y_mm_, max_y_mm_, min_z_mm_, max_z_mm_;
  std::array<std::array<SeqState, kSampleTopics>, kMaxRobots + 1> seq_{};
  std::array<RobotClock, kMaxRobots + 1> clocks_{};
  std::array<bool, kMaxRobots + 1> reported_off_{};
  std::array<bool, kMaxRobots + 1> reported_unset_{};
  ValidationCounters counters_{};
  std::array<Time, kRejectReasons> last_log_{};
  std::array<bool, kRejectReasons> logged_once_{};
  std::array<std::uint64_t, kRejectReasons> unlogged_{};
};

// Text for one robot's clock state, e.g. "stamps 12.345 s behind the station's receive times".
[[nodiscard]] std::string describe_clock(const RobotClock& c);

template <class F>
void SampleValidator::clock_changes(F&& on_change) {
  for (std::uint32_t id = 1; id <= kMaxRobots; ++id) {
    const RobotClock& c = clocks_[id];
    if (!c.any) continue;
    if (c.unset != reported_unset_[id] || c.off != reported_off_[id]) {
      reported_unset_[id] = c.unset;
      reported_off_[id] = c.off;
      on_change(id, (c.unset || c.off) ? "robot " + std::to_string(id) + " clock off: " + describe_clock(c)
                                       : "robot " + std::to_string(id) + " clock back in step: " + describe_clock(c));
    }
  }
}

}  // namespace teamscan::station
