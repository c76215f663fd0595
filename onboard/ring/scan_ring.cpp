// The ring file with its index and flush policy (scan_ring.hpp).
#include "onboard/ring/scan_ring.hpp"

#include <algorithm>
#include <new>
#include <utility>
#include <vector>

#include "common/clock.hpp"

namespace teamscan::onboard::ring {

Result<std::unique_ptr<ScanRing>> ScanRing::open(const RingConfig& config, std::uint32_t robot_id,
                                                 std::uint32_t live_window, std::uint32_t rejoin_window) {
  RingIndexOptions o;
  o.slots = config.slots();
  o.robot_id = robot_id;
  o.live_window = live_window;
  o.rejoin_window = rejoin_window;
  o.pose_live_window = kPoseHistoryDepth;
  o.backfill_rate_hz = config.backfill_rate_hz;
  Result<std::unique_ptr<RingIndex>> index = RingIndex::create(o);
  if (!index.ok()) return index.error();
  const Time t0 = now_monotonic();
  Result<RingFile> file = RingFile::open(config.path, o.slots, kSlotBytes);
  if (!file.ok()) return file.error();
  // Recovery (start-up, allocation allowed): every slot's record checked, 256 slots per read.
  constexpr std::uint64_t kChunk = 256;
  std::vector<std::uint8_t> buf(kChunk * kSlotBytes);
  for (std::uint64_t first = 0; first < o.slots; first += kChunk) {
    const std::uint64_t n = std::min(kChunk, o.slots - first);
    const Status s = file->read_slots(first, n, buf);
    if (!s.ok()) return s.error();
    for (std::uint64_t i = 0; i < n; ++i) {
      RecordHeader h;
      const std::span<const std::uint8_t> slot(buf.data() + i * kSlotBytes, kSlotBytes);
      index.value()->recover_slot(first + i, check_record(slot, h), h);
    }
  }
  index.value()->finish_recovery();
  std::unique_ptr<ScanRing> ring{new (std::nothrow)
                                     ScanRing(std::move(file.value()), std::move(index.value()), config)};
  if (!ring) return Error{"ring: out of memory"};
  ring->recovery_s_ = to_seconds(now_monotonic() - t0);
  return ring;
}

Status ScanRing::write(std::size_t bytes, RecordKind kind, std::uint32_t seq, Time now) {
  const Status s = bytes == 0
                       ? Status{Error{"ring: record does not fit its slot"}}
                       : file_.write_slot(index_->next_slot(), std::span<const std::uint8_t>(out_.data(), bytes));
  index_->written(kind, seq, s.ok());
  if (s.ok() && flush_.unflushed++ == 0) oldest_unflushed_ = now;
  return s;
}

Status ScanRing::append_scan(const ScanPoints& scan, Time now) {
  return write(encode_scan_record(scan, index_->next_ring_seq(), out_), RecordKind::kScan, scan.seq, now);
}

Status ScanRing::append_pose(const OnboardPose& pose, Time now) {
  return write(encode_pose_record(pose, index_->next_ring_seq(), out_), RecordKind::kPose, pose.seq, now);
}

Status ScanRing::flush_if_due(Time now) {
  if (flush_.unflushed == 0) return ok_status();
  if (flush_.unflushed < config_.flush_records && now - oldest_unflushed_ < config_.flush_period) return ok_status();
  return flush();
}

Status ScanRing::flush() {
  const Time t0 = now_monotonic();
  const Status s = file_.sync();
  const auto us = static_cast<std::uint64_t>((now_monotonic() - t0).count() / 1000);
  flush_.flush_max_us =
      std::max(flush_.flush_max_us, static_cast<std::uint32_t>(std::min<std::uint64_t>(us, UINT32_MAX)));
  if (!s.ok()) {
    ++flush_.flush_errors;
    return s;
  }
  ++flush_.flushes;
  flush_.unflushed = 0;
  return ok_status();
}

std::uint32_t ScanRing::take_flush_max_us() { return std::exchange(flush_.flush_max_us, 0u); }

bool ScanRing::next_backfill(Time now, ScanPoints& out) {
  std::uint64_t slot = 0;
  std::uint32_t seq = 0;
  while (index_->next_backfill(now, slot, seq)) {
    RecordHeader h;
    if (file_.read_slots(slot, 1, in_).ok() && check_record(in_, h) == RecordError::kNone &&
        h.kind == RecordKind::kScan && h.seq == seq) {
      decode_scan_payload(in_, h, out);
      return true;
    }
    index_->backfill_failed();  // torn since it was written (the disk): skipped
  }
  return false;
}

bool ScanRing::next_backfill_pose(Time now, OnboardPose& out) {
  std::uint64_t slot = 0;
  std::uint32_t seq = 0;
  while (index_->next_backfill_pose(now, slot, seq)) {
    RecordHeader h;
    if (file_.read_slots(slot, 1, in_).ok() && check_record(in_, h) == RecordError::kNone &&
        h.kind == RecordKind::kPose && h.seq == seq) {
      decode_pose_payload(in_, h, out);
      return true;
    }
    index_->backfill_failed();
  }
  return false;
}

}  // namespace teamscan::onboard::ring
