// The store-and-forward ring's state, without I/O (STYLE.md 1: pure logic; ring_file.hpp is the seam to
// the file): which slot the next record goes to, what every slot holds, what the station has confirmed,
// which scans are still to be back-filled and at what rate. The slot tables are allocated once in create();
// nothing after that allocates.
//
// Records are numbered by ring_seq since the file was made; record r lives in slot r % slots. Scans keep
// their own sequence numbers (ScanPoints.seq), which continue across restarts (the daemon resumes after the
// newest recovered one), so the scans in the ring have increasing seq in ring order.
#pragma once

#include <cstdint>
#include <memory>

#include "common/result.hpp"
#include "common/time.hpp"
#include "onboard/ring/record.hpp"

namespace teamscan::onboard::ring {

struct RingIndexOptions {
  std::uint64_t slots = 0;     // records the ring holds (>= 16)
  std::uint32_t robot_id = 0;  // records of another robot found at recovery are ignored (counted)
  // Scans newer than this many below the newest are left to the live writer's DDS history, which a
  // returning station receives anyway (dds.scan_history_depth): the back-fill takes the older ones.
  std::uint32_t live_window = 300;
  // Of those, what a station that comes back after a shadow gets at once from the live writer (its
  // late-joiner depth, dds/qos.hpp; 0: all live_window): at the return the back-fill takes every scan
  // below the newest rejoin_window, not only those below live_window.
  std::uint32_t rejoin_window = 0;
  double backfill_rate_hz = 300.0;   // back-filled scans per second at most (live ones come first)
  std::uint32_t backfill_burst = 8;  // back-filled scans per loop turn at most
  // The station counts as reachable while its confirmations keep arriving: the newest within this.
  Duration reachable_timeout = std::chrono::seconds(3);
  // At most this many scans above the station's confirmation are back-filled before it confirms more:
  // below the back-fill writer's history (dds::kBackfillHistoryDepth), so a back-filled scan the link
  // delays is never replaced in that history before the station has it (which would leave a hole that
  // only a resend fills), and the back-fill never sends faster than the link takes it. 0: no window.
  std::uint32_t backfill_window = 200;
  // A back-fill the confirmations did not follow within this is sent again from the confirmed seq (at most
  // backfill_window scans: the rest was never sent).
  Duration resend_after = std::chrono::seconds(2);
  // Poses newer than this many below the newest are left to the live pose writer's DDS history, which it
  // offers whole to a returning station (dds pose history depth): the pose back-fill takes the older ones.
  std::uint32_t pose_live_window = 64;
};

struct RingCounters {
  std::uint64_t scans_written = 0;
  std::uint64_t poses_written = 0;
  std::uint64_t write_errors = 0;         // records the file refused (the record is not in the ring)
  std::uint64_t dropped_unconfirmed = 0;  // scans overwritten (ring full) before the station confirmed them
  std::uint64_t recovered_scans = 0;      // at start-up: records found intact
  std::uint64_t recovered_poses = 0;
  std::uint64_t recovered_empty = 0;  // never-written slots
  std::uint64_t torn = 0;             // slots whose record failed its check (a write a power cut tore): skipped
  std::uint64_t misplaced = 0;        // intact records in a slot that is not theirs (another ring size): skipped
  std::uint64_t foreign = 0;          // intact records of another robot: skipped
  std::uint64_t confirmations = 0;    // accepted station confirmations
  std::uint64_t confirmations_unknown_robot = 0;  // refused: robot id outside 1..32
  std::uint64_t confirmations_future = 0;         // refused: a seq this robot has not written yet
  std::uint64_t backfilled = 0;                   // scans handed to the back-fill writer
  std::uint64_t backfill_rewinds = 0;             // back-fills sent again (the confirmations did not follow)
  std::uint64_t backfill_missing = 0;  // unconfirmed seqs the ring does not hold (never written, torn, overwritten)
  std::uint64_t poses_backfilled = 0;           // poses handed to the pose back-fill writer
  std::uint64_t pose_confirmations_future = 0;  // refused: a pose seq this robot has not written yet
};

enum class Confirmation : std::uint8_t { kAccepted, kOtherRobot, kUnknownRobot, kFuture };

// The shadow as the robot sees it, for teamscan/status and the journal.
struct ShadowState {
  bool reachable = false;  // a confirmation arrived within reachable_timeout
  bool ever_confirmed = false;
  std::uint32_t confirmed_seq = 0;       // the station's highest contiguous stored scan
  std::uint32_t newest_seq = 0;          // the newest scan written
  std::uint32_t unconfirmed = 0;         // scans in the ring above confirmed_seq
  Time shadow_since{};                   // monotonic; valid while !reachable and ever_confirmed
  std::uint32_t backfill_total = 0;      // scans to back-fill when the station came back (0: none)
  std::uint32_t backfill_remaining = 0;  // of those, not yet confirmed
  Duration last_shadow{0};               // the last shadow that ended: its last confirmation to the next
};

class RingIndex {
 public:
  [[nodiscard]] static Result<std::unique_ptr<RingIndex>> create(const RingIndexOptions& options);

  // Start-up: every slot's check_record result, in any order; then finish_recovery().
  void recover_slot(std::uint64_t slot, RecordError error, const RecordHeader& header);
  void finish_recovery();

  // Where the next record goes (slot and ring_seq); then written(...) with the outcome of the write.
  [[nodiscard]] std::uint64_t next_slot() const { return head_ % options_.slots; }
  [[nodiscard]] std::uint64_t next_ring_seq() const { return head_; }
  void written(RecordKind kind, std::uint32_t seq, bool ok);

  // A station confirmation: robot robot_id has stored every scan up to contiguous_seq and every pose up to
  // pose_contiguous_seq (0: none of its poses). `now` monotonic. `fresh`: the confirmation was published just
  // now (not the transient-local copy of an old one that a restarted robot receives at once): only a fresh
  // one says the station is reachable. The result is the scans'; a pose seq from the future is counted and
  // ignored.
  Confirmation on_confirmation(std::uint32_t robot_id, std::uint32_t contiguous_seq, Time now, bool fresh = true,
                               std::uint32_t pose_contiguous_seq = 0);

  // A station's reader matched the live scan writer (a station that started, restarted or came back from a
  // shadow, however short): the writer offers it only its newest rejoin_window scans, so every scan below
  // those is the back-fill's, whether or not the confirmations ever stopped.
  void on_live_reader_matched(Time now);

  // The next scan to back-fill, if one is due at `now` (monotonic): its slot and seq. Call again until
  // false; at most backfill_burst per turn (start_turn) and backfill_rate_hz on average.
  void start_turn(Time now);
  [[nodiscard]] bool next_backfill(Time now, std::uint64_t& slot, std::uint32_t& seq);
  // The slot's record could not be read or decoded: the scan (or pose) is skipped.
  void backfill_failed();
  // The next pose to back-fill, if one is due: every pose in the ring above the station's pose confirmation
  // and below the live pose writer's history, oldest first, at most backfill_burst per turn (start_turn),
  // within backfill_window above the confirmation, sent again after resend_after without progress. Poses
  // are small: they do not spend the scans' rate.
  [[nodiscard]] bool next_backfill_pose(Time now, std::uint64_t& slot, std::uint32_t& seq);

  [[nodiscard]] ShadowState shadow(Time now) const;
  [[nodiscard]] const RingCounters& counters() const { return counters_; }
  [[nodiscard]] std::uint32_t newest_scan_seq() const { return newest_scan_seq_; }
  [[nodiscard]] std::uint32_t newest_pose_seq() const { return newest_pose_seq_; }
  [[nodiscard]] std::uint32_t oldest_scan_seq() const { return oldest_scan_seq_; }
  [[nodiscard]] std::uint32_t pose_confirmed_seq() const { return pose_confirmed_seq_; }
  [[nodiscard]] std::uint64_t slots() const { return options_.slots; }
  [[nodiscard]] const RingIndexOptions& options() const { return options_; }

 private:
  struct Slot {
    std::uint64_t ring_seq = 0;
    std::uint32_t seq = 0;
    RecordKind kind = RecordKind::kEmpty;
  };
  explicit RingIndex(const RingIndexOptions& options);
  [[nodiscard]] bool locate(RecordKind kind, std::uint32_t seq, std::uint64_t& slot) const;
  [[nodiscard]] bool reachable(Time now) const;
  [[nodiscard]] std::uint32_t backfill_limit() const;

  // One back-fill (the scans', the poses'): where it is above the station's confirmation.
  struct Stream {
    std::uint32_t next = 0;  // the next seq to back-fill (0: from the confirmed one)
    Time confirmed_moved{};  // monotonic: the confirmation last moved (or the back-fill started)
    Time sent{};             // monotonic: the last record handed out
  };
  // The next record of `kind` for `st` above `confirmed` (the station's) up to `limit`: within
  // backfill_window above the confirmation or what the ring no longer holds (below `oldest`), from the
  // confirmation again when it did not move for resend_after after a send; a run of seqs the ring lacks
  // is skipped 64 at a time (bounded work per call). False: none now.
  bool next_in(Stream& st, RecordKind kind, std::uint32_t confirmed, std::uint32_t oldest, std::uint32_t limit,
               Time now, std::uint64_t& slot, std::uint32_t& seq);

  RingIndexOptions options_;
  std::unique_ptr<Slot[]> slots_;
  std::unique_ptr<std::uint64_t[]> scan_pos_;  // [seq % slots] = ring_seq + 1 of that scan (0: none)
  std::unique_ptr<std::uint64_t[]> pose_pos_;  // the same for poses
  std::uint64_t head_ = 0;                     // ring_seq of the next record
  bool any_scan_ = false;
  std::uint32_t newest_scan_seq_ = 0, newest_pose_seq_ = 0, oldest_scan_seq_ = 0;

  bool ever_confirmed_ = false;
  std::uint32_t confirmed_seq_ = 0;
  Time last_confirmation_{};  // monotonic
  Stream scan_stream_;
  std::uint32_t backfill_total_ = 0;
  Duration last_shadow_{0};
  std::uint32_t rejoin_limit_ = 0;   // at the last return: the newest scan the live writer no longer offers
  // The newest scan and pose the start-up recovery found: no live writer of this process ever held them.
  std::uint32_t recovered_scan_limit_ = 0, recovered_pose_limit_ = 0;
  double tokens_ = 0.0;
  Time tokens_at_{};
  std::uint32_t turn_left_ = 0;

  bool any_pose_ = false;
  std::uint32_t oldest_pose_seq_ = 0;
  bool pose_ever_confirmed_ = false;
  std::uint32_t pose_confirmed_seq_ = 0;
  Stream pose_stream_;
  std::uint32_t pose_turn_left_ = 0;
  RingCounters counters_{};
};

}  // namespace teamscan::onboard::ring
