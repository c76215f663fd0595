// The ring's state without I/O (ring_index.hpp).
#include "onboard/ring/ring_index.hpp"

#include <algorithm>
#include <new>

#include "common/capacities.hpp"

namespace teamscan::onboard::ring {

Result<std::unique_ptr<RingIndex>> RingIndex::create(const RingIndexOptions& options) {
  if (options.slots < 16) return Error{"ring: fewer than 16 records", 0, static_cast<long>(options.slots)};
  if (options.robot_id == 0 || options.robot_id > kMaxRobots) return Error{"ring: robot id outside 1..32"};
  if (!(options.backfill_rate_hz > 0.0)) return Error{"ring: back-fill rate must be > 0"};
  std::unique_ptr<RingIndex> r{new (std::nothrow) RingIndex(options)};
  if (!r) return Error{"ring: out of memory"};
  r->slots_.reset(new (std::nothrow) Slot[options.slots]);
  r->scan_pos_.reset(new (std::nothrow) std::uint64_t[options.slots]);
  r->pose_pos_.reset(new (std::nothrow) std::uint64_t[options.slots]);
  if (!r->slots_ || !r->scan_pos_ || !r->pose_pos_)
    return Error{"ring: out of memory for the slot tables", 0, static_cast<long>(options.slots)};
  std::fill_n(r->scan_pos_.get(), options.slots, 0);
  std::fill_n(r->pose_pos_.get(), options.slots, 0);
  return r;
}

RingIndex::RingIndex(const RingIndexOptions& options) : options_{options} {}

void RingIndex::recover_slot(std::uint64_t slot, RecordError error, const RecordHeader& header) {
  if (slot >= options_.slots) return;
  if (error == RecordError::kEmpty) {
    ++counters_.recovered_empty;
    return;
  }
  if (error != RecordError::kNone) {
    ++counters_.torn;
    return;
  }
  if (header.robot_id != options_.robot_id) {
    ++counters_.foreign;
    return;
  }
  if (header.ring_seq % options_.slots != slot) {
    ++counters_.misplaced;
    return;
  }
  slots_[slot] = Slot{header.ring_seq, header.seq, header.kind};
}

void RingIndex::finish_recovery() {
  head_ = 0;
  for (std::uint64_t i = 0; i < options_.slots; ++i)
    if (slots_[i].kind != RecordKind::kEmpty) head_ = std::max(head_, slots_[i].ring_seq + 1);
  std::uint64_t newest_scan = 0, oldest_scan = UINT64_MAX, newest_pose = 0, oldest_pose = UINT64_MAX;
  for (std::uint64_t i = 0; i < options_.slots; ++i) {
    Slot& s = slots_[i];
    if (s.kind == RecordKind::kEmpty) continue;
    // A record older than one lap is left from a write that failed since: not part of the ring.
    if (s.ring_seq + options_.slots < head_) {
      ++counters_.misplaced;
      s = Slot{};
      continue;
    }
    if (s.kind == RecordKind::kPose) {
      ++counters_.recovered_poses;
      std::uint64_t& pos = pose_pos_[s.seq % options_.slots];
      if (pos == 0 || pos - 1 < s.ring_seq) pos = s.ring_seq + 1;
      if (!any_pose_ || s.ring_seq >= newest_pose) {
        newest_pose = s.ring_seq;
        newest_pose_seq_ = s.seq;
      }
      if (!any_pose_ || s.ring_seq < oldest_pose) {
        oldest_pose = s.ring_seq;
        oldest_pose_seq_ = s.seq;
      }
      any_pose_ = true;
      continue;
    }
    ++counters_.recovered_scans;
    std::uint64_t& pos = scan_pos_[s.seq % options_.slots];
    if (pos == 0 || pos - 1 < s.ring_seq) pos = s.ring_seq + 1;
    if (!any_scan_ || s.ring_seq >= newest_scan) {
      newest_scan = s.ring_seq;
      newest_scan_seq_ = s.seq;
    }
    if (!any_scan_ || s.ring_seq < oldest_scan) {
      oldest_scan = s.ring_seq;
      oldest_scan_seq_ = s.seq;
    }
    any_scan_ = true;
  }
  // Whatever the recovery found was written by an earlier process: its live writers' DDS histories died
  // with it, so the back-fill may take every recovered record, however recent.
  recovered_scan_limit_ = any_scan_ ? newest_scan_seq_ : 0;
  recovered_pose_limit_ = any_pose_ ? newest_pose_seq_ : 0;
}

void RingIndex::written(RecordKind kind, std::uint32_t seq, bool ok) {
  const std::uint64_t slot = head_ % options_.slots;
  Slot& s = slots_[slot];
  if (s.kind == RecordKind::kScan) {
    std::uint64_t& pos = scan_pos_[s.seq % options_.slots];
    if (pos == s.ring_seq + 1) pos = 0;
    if (!ever_confirmed_ || s.seq > confirmed_seq_) ++counters_.dropped_unconfirmed;
    if (s.seq >= oldest_scan_seq_) oldest_scan_seq_ = s.seq + 1;
  } else if (s.kind == RecordKind::kPose) {
    std::uint64_t& pos = pose_pos_[s.seq % options_.slots];
    if (pos == s.ring_seq + 1) pos = 0;
    if (s.seq >= oldest_pose_seq_) oldest_pose_seq_ = s.seq + 1;
  }
  if (ok) {
    s = Slot{head_, seq, kind};
    if (kind == RecordKind::kScan) {
      scan_pos_[seq % options_.slots] = head_ + 1;
      if (!any_scan_) oldest_scan_seq_ = seq;
      any_scan_ = true;
      newest_scan_seq_ = seq;
      ++counters_.scans_written;
    } else {
      pose_pos_[seq % options_.slots] = head_ + 1;
      if (!any_pose_) oldest_pose_seq_ = seq;
      any_pose_ = true;
      newest_pose_seq_ = seq;
      ++counters_.poses_written;
    }
  } else {
    s = Slot{};
    ++counters_.write_errors;
  }
  ++head_;
}

bool RingIndex::locate(RecordKind kind, std::uint32_t seq, std::uint64_t& slot) const {
  const std::uint64_t pos = (kind == RecordKind::kScan ? scan_pos_ : pose_pos_)[seq % options_.slots];
  if (pos == 0) return false;
  const std::uint64_t i = (pos - 1) % options_.slots;
  const Slot& s = slots_[i];
  if (s.kind != kind || s.seq != seq || s.ring_seq != pos - 1) return false;
  slot = i;
  return true;
}

bool RingIndex::reachable(Time now) const {
  return ever_confirmed_ && now - last_confirmation_ <= options_.reachable_timeout;
}

std::uint32_t RingIndex::backfill_limit() const {
  const std::uint32_t live = newest_scan_seq_ > options_.live_window ? newest_scan_seq_ - options_.live_window : 0;
  return std::max({live, rejoin_limit_, recovered_scan_limit_});
}

Confirmation RingIndex::on_confirmation(std::uint32_t robot_id, std::uint32_t contiguous_seq, Time now, bool fresh,
                                        std::uint32_t pose_contiguous_seq) {
  if (robot_id == 0 || robot_id > kMaxRobots) {
    ++counters_.confirmations_unknown_robot;
    return Confirmation::kUnknownRobot;
  }
  if (robot_id != options_.robot_id) return Confirmation::kOtherRobot;
  if (contiguous_seq > newest_scan_seq_ || (!any_scan_ && contiguous_seq > 0)) {
    ++counters_.confirmations_future;
    return Confirmation::kFuture;
  }
  ++counters_.confirmations;
  const bool back = fresh && !reachable(now);
  const bool was_confirmed = ever_confirmed_;
  if (back && ever_confirmed_) last_shadow_ = now - last_confirmation_;  // the shadow that ends here
  if (!ever_confirmed_ || contiguous_seq != confirmed_seq_) scan_stream_.confirmed_moved = now;
  if (!fresh && !ever_confirmed_) last_confirmation_ = now - options_.reachable_timeout - Duration{1};
  ever_confirmed_ = true;
  confirmed_seq_ = contiguous_seq;
  if (fresh) last_confirmation_ = now;
  if (pose_contiguous_seq > 0) {
    if (!any_pose_ || pose_contiguous_seq > newest_pose_seq_) {
      ++counters_.pose_confirmations_future;
    } else {
      if (!pose_ever_confirmed_ || pose_contiguous_seq != pose_confirmed_seq_) pose_stream_.confirmed_moved = now;
      pose_ever_confirmed_ = true;
      pose_confirmed_seq_ = pose_contiguous_seq;
    }
  }
  if (back) {
    pose_stream_.next = 0;
    pose_stream_.confirmed_moved = now;
    // The station is back (or heard for the first time): back-fill from its confirmed scan on. After a
    // shadow the live writer offers the returning station only its newest rejoin_window scans.
    const std::uint32_t rejoin = options_.rejoin_window == 0 ? options_.live_window : options_.rejoin_window;
    if (was_confirmed) rejoin_limit_ = std::max(rejoin_limit_, newest_scan_seq_ > rejoin ? newest_scan_seq_ - rejoin : 0);
    const std::uint32_t limit = backfill_limit();
    backfill_total_ = limit > confirmed_seq_ ? limit - confirmed_seq_ : 0;
    scan_stream_.next = 0;
    scan_stream_.confirmed_moved = now;  // the back-fill starts now: resend_after counts from here
  }
  return Confirmation::kAccepted;
}

void RingIndex::on_live_reader_matched(Time now) {
  const std::uint32_t rejoin = options_.rejoin_window == 0 ? options_.live_window : options_.rejoin_window;
  rejoin_limit_ = std::max(rejoin_limit_, newest_scan_seq_ > rejoin ? newest_scan_seq_ - rejoin : 0);
  // The resend rule's clock starts at the match, not at the last station's last move.
  scan_stream_.confirmed_moved = now;
}

void RingIndex::start_turn(Time now) {
  const double dt = std::max(0.0, to_seconds(now - tokens_at_));
  tokens_ = std::min(static_cast<double>(options_.backfill_burst), tokens_ + dt * options_.backfill_rate_hz);
  tokens_at_ = now;
  turn_left_ = options_.backfill_burst;
  pose_turn_left_ = options_.backfill_burst;
}

bool RingIndex::next_in(Stream& st, RecordKind kind, std::uint32_t confirmed, std::uint32_t oldest, std::uint32_t limit,
                        Time now, std::uint64_t& slot, std::uint32_t& seq) {
  // The window opens above the confirmation, or above what the ring no longer holds (a full ring dropped it).
  const std::uint32_t base = std::max(confirmed, oldest > 0 ? oldest - 1 : 0);
  if (options_.backfill_window > 0 && base + options_.backfill_window < limit) limit = base + options_.backfill_window;
  // Sent, but the confirmations have not followed for resend_after: a back-filled record went missing on
  // the way (or the station restarted without it); send again from the confirmed one.
  if (st.next > confirmed + 1 && now - st.confirmed_moved >= options_.resend_after &&
      now - st.sent < options_.resend_after * 4) {
    st.next = confirmed + 1;
    st.confirmed_moved = now;
    ++counters_.backfill_rewinds;
  }
  std::uint32_t s = std::max({st.next, confirmed + 1, oldest});
  for (int k = 0; k < 64 && s <= limit; ++k, ++s) {
    if (locate(kind, s, slot)) {
      seq = s;
      st.next = s + 1;
      st.sent = now;
      return true;
    }
    ++counters_.backfill_missing;
  }
  st.next = s;
  return false;
}

bool RingIndex::next_backfill(Time now, std::uint64_t& slot, std::uint32_t& seq) {
  if (!reachable(now) || turn_left_ == 0 || tokens_ < 1.0 || !any_scan_) return false;
  if (!next_in(scan_stream_, RecordKind::kScan, confirmed_seq_, oldest_scan_seq_, backfill_limit(), now, slot, seq))
    return false;
  tokens_ -= 1.0;
  --turn_left_;
  ++counters_.backfilled;
  return true;
}

void RingIndex::backfill_failed() { ++counters_.backfill_missing; }

bool RingIndex::next_backfill_pose(Time now, std::uint64_t& slot, std::uint32_t& seq) {
  if (!reachable(now) || pose_turn_left_ == 0 || !any_pose_ || !pose_ever_confirmed_) return false;
  const std::uint32_t live =
      newest_pose_seq_ > options_.pose_live_window ? newest_pose_seq_ - options_.pose_live_window : 0;
  if (!next_in(pose_stream_, RecordKind::kPose, pose_confirmed_seq_, oldest_pose_seq_,
               std::max(live, recovered_pose_limit_), now, slot, seq))
    return false;
  --pose_turn_left_;
  ++counters_.poses_backfilled;
  return true;
}

ShadowState RingIndex::shadow(Time now) const {
  ShadowState st;
  st.reachable = reachable(now);
  st.ever_confirmed = ever_confirmed_;
  st.confirmed_seq = confirmed_seq_;
  st.newest_seq = newest_scan_seq_;
  if (any_scan_) {
    const std::uint32_t lower = std::max(ever_confirmed_ ? confirmed_seq_ + 1 : oldest_scan_seq_, oldest_scan_seq_);
    st.unconfirmed = newest_scan_seq_ >= lower ? newest_scan_seq_ - lower + 1 : 0;
  }
  st.shadow_since = ever_confirmed_ && !st.reachable ? last_confirmation_ : Time{};
  st.backfill_total = backfill_total_;
  st.last_shadow = last_shadow_;
  const std::uint32_t limit = backfill_limit();
  st.backfill_remaining =
      ever_confirmed_ && limit > confirmed_seq_ ? std::min(limit - confirmed_seq_, backfill_total_) : 0;
  return st;
}

}  // namespace teamscan::onboard::ring
