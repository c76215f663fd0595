// teamscan-onboard's store and forward (docs/onboard.md "The ring"): every scan and pose the robot publishes
// goes into a preallocated ring file on its storage (RingFile) as a fixed-size record (record.hpp), made
// durable by the flush policy of the config ([ring]); at start-up the ring is recovered by checking every
// slot's record (torn ones are counted and skipped); the station's confirmations and the back-fill of what
// it has not confirmed are RingIndex's. Everything is allocated in open(); append, flush, confirmation and
// back-fill allocate nothing.
#pragma once

#include <array>
#include <cstdint>
#include <memory>

#include "common/result.hpp"
#include "common/scan_points.hpp"
#include "common/time.hpp"
#include "onboard/core/config.hpp"
#include "onboard/core/messages.hpp"
#include "onboard/ring/record.hpp"
#include "onboard/ring/ring_file.hpp"
#include "onboard/ring/ring_index.hpp"

namespace teamscan::onboard::ring {

struct FlushCounters {
  std::uint64_t flushes = 0;
  std::uint64_t flush_errors = 0;
  std::uint32_t flush_max_us = 0;  // longest fdatasync since the last take_flush_max()
  std::uint64_t unflushed = 0;     // records written since the last flush
};

class ScanRing {
 public:
  // Opens or creates config.path, recovers it (reads every slot; docs/onboard.md gives its time) and
  // prepares the tables. live_window: the live writer's scan history depth (dds.scan_history_depth);
  // rejoin_window: its late-joiner depth (RingIndexOptions).
  [[nodiscard]] static Result<std::unique_ptr<ScanRing>> open(const RingConfig& config, std::uint32_t robot_id,
                                                              std::uint32_t live_window, std::uint32_t rejoin_window = 0);

  // One published sample into the ring (a file error is counted in RingCounters::write_errors and returned).
  [[nodiscard]] Status append_scan(const ScanPoints& scan, Time now);
  [[nodiscard]] Status append_pose(const OnboardPose& pose, Time now);
  // fdatasync when flush_records records are unflushed or the oldest unflushed one is flush_period old.
  [[nodiscard]] Status flush_if_due(Time now);
  [[nodiscard]] Status flush();
  // When the flush period ends for the records written so far (valid while flush_counters().unflushed > 0).
  [[nodiscard]] Time flush_due() const { return oldest_unflushed_ + config_.flush_period; }

  Confirmation on_confirmation(std::uint32_t robot_id, std::uint32_t contiguous_seq, Time now, bool fresh = true,
                               std::uint32_t pose_contiguous_seq = 0) {
    return index_->on_confirmation(robot_id, contiguous_seq, now, fresh, pose_contiguous_seq);
  }
  // Back-fill: start_turn once per loop turn, then next_backfill until false; each true fills `out` with a
  // scan read back from the ring.
  void on_live_reader_matched(Time now) { index_->on_live_reader_matched(now); }
  void start_turn(Time now) { index_->start_turn(now); }
  [[nodiscard]] bool next_backfill(Time now, ScanPoints& out);
  // The same for poses (RingIndex::next_backfill_pose), after the turn's scans.
  [[nodiscard]] bool next_backfill_pose(Time now, OnboardPose& out);

  [[nodiscard]] const RingIndex& index() const { return *index_; }
  [[nodiscard]] const FlushCounters& flush_counters() const { return flush_; }
  std::uint32_t take_flush_max_us();
  [[nodiscard]] bool created() const { return file_.created(); }
  [[nodiscard]] double recovery_s() const { return recovery_s_; }

 private:
  ScanRing(RingFile file, std::unique_ptr<RingIndex> index, const RingConfig& config)
      : file_{std::move(file)}, index_{std::move(index)}, config_{config} {}
  Status write(std::size_t bytes, RecordKind kind, std::uint32_t seq, Time now);

  RingFile file_;
  std::unique_ptr<RingIndex> index_;
  RingConfig config_;
  FlushCounters flush_{};
  Time oldest_unflushed_{};
  double recovery_s_ = 0.0;
  alignas(64) std::array<std::uint8_t, kSlotBytes> out_{};
  alignas(64) std::array<std::uint8_t, kSlotBytes> in_{};
};

}  // namespace teamscan::onboard::ring
