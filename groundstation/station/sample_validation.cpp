// SampleValidator: the station's checks of every received sample (sample_validation.hpp).
#include "groundstation/station/sample_validation.hpp"

#include <cinttypes>
#include <cmath>
#include <cstdio>
#include <cstdlib>

#include "common/odom_correction.hpp"
#include "common/scan_points.hpp"
#include "common/units.hpp"
#include "teamscan.h"

namespace teamscan::station {

namespace {

constexpr const char* kReasonNames[kRejectReasons] = {
    "accepted",   "robot_id", "beam_count",   "beam_index",  "outside_site", "yaw",
    "velocity",   "clock_unset", "stamp_behind", "stamp_ahead", "seq_jump", "identity",
    "correction",
};

constexpr std::int64_t kOneDayNs = 86'400'000'000'000;

}  // namespace

const char* reject_name(Reject r) {
  const auto i = static_cast<std::size_t>(r);
  return i < kRejectReasons ? kReasonNames[i] : "unknown";
}

const char* topic_name(SampleTopic t) {
  switch (t) {
    case SampleTopic::kPose: return "pose";
    case SampleTopic::kScan: return "scan";
    case SampleTopic::kStatus: return "status";
    case SampleTopic::kBackfill: return "backfill";
    case SampleTopic::kBackfillPose: return "backfill_pose";
  }
  return "?";
}

SampleValidator::SampleValidator(const ValidationOptions& o)
    : options_{o},
      min_x_mm_{to_mm_as<std::int64_t>(o.site_min_x_m)},
      max_x_mm_{to_mm_as<std::int64_t>(o.site_max_x_m)},
      min_y_mm_{to_mm_as<std::int64_t>(o.site_min_y_m)},
      max_y_mm_{to_mm_as<std::int64_t>(o.site_max_y_m)},
      min_z_mm_{to_mm_as<std::int64_t>(o.site_min_z_m)},
      max_z_mm_{to_mm_as<std::int64_t>(o.site_max_z_m)} {}

bool SampleValidator::inside_site_xy(std::int64_t x, std::int64_t y) const {
  return x >= min_x_mm_ && x <= max_x_mm_ && y >= min_y_mm_ && y <= max_y_mm_;
}

bool SampleValidator::inside_site(std::int64_t x, std::int64_t y, std::int64_t z) const {
  return inside_site_xy(x, y) && z >= min_z_mm_ && z <= max_z_mm_;
}

void SampleValidator::observe_clock(std::uint32_t id, std::int64_t stamp_ns, Time received) {
  RobotClock& c = clocks_[id];
  c.any = true;
  c.unset = stamp_ns < options_.clock_set_after_ns;
  // A clock that was never set says so; a stamp more than a day from the receive time is no clock
  // reading at all (INT64_MAX, a corrupt sample): refused, but it does not move the robot's offset.
  if (c.unset) return;
  if (stamp_ns > received.ns() + kOneDayNs || stamp_ns < received.ns() - kOneDayNs) return;
  const std::int64_t offset = received.ns() - stamp_ns;  // within ±1 day here: no overflow
  if (!c.window_any) {
    c.window_any = true;
    c.window_start = received;
    c.window_min_ns = offset;
  } else if (offset < c.window_min_ns) {
    c.window_min_ns = offset;
  }
  const bool window_done = received - c.window_start >= options_.clock_window;
  if (window_done || !c.window_complete) c.offset_ns = c.window_min_ns;
  if (window_done) {
    c.window_any = false;
    c.window_complete = true;
  }
  const std::int64_t warn = options_.clock_offset_warn.count();
  c.off = !c.unset && (c.offset_ns > warn || c.offset_ns < -warn);
}

Verdict SampleValidator::check_header(SampleTopic topic, std::uint32_t id, std::int64_t stamp_ns, Time received) {
  if (id == 0 || id > kMaxRobots) return {Reject::kRobotId, static_cast<std::int64_t>(id)};
  const bool backfill = topic == SampleTopic::kBackfill || topic == SampleTopic::kBackfillPose;
  if (!backfill) observe_clock(id, stamp_ns, received);
  if (stamp_ns < options_.clock_set_after_ns) return {Reject::kClockUnset, stamp_ns};
  // Compared as differences from the receive time: stamps are past 2020 here, so no overflow.
  const std::int64_t age_ns = received.ns() - stamp_ns;
  if (stamp_ns > received.ns() && stamp_ns - received.ns() > options_.max_stamp_ahead.count()) {
    return {Reject::kStampAhead, stamp_ns - received.ns()};
  }
  if (age_ns > (backfill ? options_.max_backfill_age : options_.max_stamp_age).count()) return {Reject::kStampBehind, age_ns};
  return {};
}

Verdict SampleValidator::check_seq(SampleTopic topic, std::uint32_t id, std::uint32_t seq) {
  SeqState& s = seq_[id][static_cast<std::size_t>(topic)];
  if (!s.any) {
    s = SeqState{};
    s.any = true;
    s.last = seq;
    return {};
  }
  const auto d = static_cast<std::int32_t>(seq - s.last);  // modulo 2^32: a wrap is progress
  if (d > 0 && static_cast<std::uint32_t>(d) <= options_.max_seq_jump) {
    s.last = seq;
    s.pending = false;
    return {};
  }
  if (d <= 0 && static_cast<std::uint64_t>(-static_cast<std::int64_t>(d)) <= options_.replay_window) return {};
  if (d < 0 && seq <= options_.restart_seq_max) {
    ++counters_.seq_restarts;
    s.last = seq;
    s.pending = false;
    return {};
  }
  // A jump: refused until resync_after samples in a row continue the new numbering.
  const auto from_pending = static_cast<std::int32_t>(seq - s.pending_last);
  if (s.pending && from_pending > 0 && static_cast<std::uint32_t>(from_pending) <= options_.max_seq_jump) {
    s.pending_last = seq;
    if (++s.pending_run >= options_.resync_after) {
      ++counters_.seq_resyncs;
      s.last = seq;
      s.pending = false;
      return {};
    }
  } else {
    s.pending = true;
    s.pending_last = seq;
    s.pending_run = 1;
  }
  return {Reject::kSeqJump, static_cast<std::int64_t>(seq)};
}

Verdict SampleValidator::count(SampleTopic topic, std::uint32_t id, Verdict v) {
  const auto r = static_cast<std::size_t>(v.reason);
  const std::size_t robot = id <= kMaxRobots ? id : 0;
  ++counters_.by_reason[r];
  ++counters_.by_robot[robot][r];
  if (!v.ok()) {
    ++counters_.rejected;
    ++counters_.rejected_by_topic[static_cast<std::size_t>(topic)];
  }
  return v;
}

Verdict SampleValidator::check_pose(const teamscan_msg_RobotPose& p, Time received) {
  constexpr SampleTopic t = SampleTopic::kPose;
  Verdict v = check_header(t, p.robot_id, p.stamp_ns, received);
  if (!v.ok()) return count(t, p.robot_id, v);
  v = check_pose_body(p);
  if (!v.ok()) return count(t, p.robot_id, v);
  return count(t, p.robot_id, check_seq(t, p.robot_id, p.seq));
}

Verdict SampleValidator::check_backfill_pose(const teamscan_msg_RobotPose& p, Time received) {
  constexpr SampleTopic t = SampleTopic::kBackfillPose;
  Verdict v = check_header(t, p.robot_id, p.stamp_ns, received);
  if (!v.ok()) return count(t, p.robot_id, v);
  return count(t, p.robot_id, check_pose_body(p));
}

Verdict SampleValidator::check_pose_body(const teamscan_msg_RobotPose& p) const {
  if (!inside_site_xy(p.x_mm, p.y_mm)) {
    const std::int64_t x = p.x_mm, y = p.y_mm;
    return {Reject::kOutsideSite, std::llabs(x) > std::llabs(y) ? x : y};
  }
  if (p.yaw_urad <= -kPiUrad - 1 || p.yaw_urad > kPiUrad) return {Reject::kYaw, p.yaw_urad};
  const double speed_mps = std::hypot(static_cast<double>(p.vx_mmps), static_cast<double>(p.vy_mmps)) * 1e-3;
  if (!(speed_mps <= options_.max_speed_mps)) return {Reject::kVelocity, static_cast<std::int64_t>(speed_mps * 1000.0)};
  if (std::abs(static_cast<double>(p.yaw_rate_mradps)) * 1e-3 > options_.max_yaw_rate_radps) {
    return {Reject::kVelocity, p.yaw_rate_mradps};
  }
  return {};
}

Verdict SampleValidator::check_scan(const teamscan_msg_ScanPoints& s, Time received) {
  constexpr SampleTopic t = SampleTopic::kScan;
  Verdict v = check_header(t, s.robot_id, s.stamp_ns, received);
  if (!v.ok()) return count(t, s.robot_id, v);
  v = check_scan_body(s);
  if (!v.ok()) return count(t, s.robot_id, v);
  return count(t, s.robot_id, check_seq(t, s.robot_id, s.seq));
}

Verdict SampleValidator::check_backfill(const teamscan_msg_ScanPoints& s, Time received) {
  constexpr SampleTopic t = SampleTopic::kBackfill;
  Verdict v = check_header(t, s.robot_id, s.stamp_ns, received);
  if (!v.ok()) return count(t, s.robot_id, v);
  return count(t, s.robot_id, check_scan_body(s));
}

Verdict SampleValidator::check_scan_body(const teamscan_msg_ScanPoints& s) {
  if (s.count > kMaxBeams) return {Reject::kBeamCount, s.count};
  const OdomCorrection applied{s.corr_x_mm, s.corr_y_mm, s.corr_yaw_urad, s.corr_seq};
  if (applied.none() ? (applied.x_mm != 0 || applied.y_mm != 0 || applied.yaw_urad != 0)
                     : (!applied.yaw_in_range() || std::llabs(std::int64_t{applied.x_mm}) > max_x_mm_ - min_x_mm_ ||
                        std::llabs(std::int64_t{applied.y_mm}) > max_y_mm_ - min_y_mm_)) {
    return {Reject::kCorrection, applied.yaw_in_range() ? applied.x_mm : applied.yaw_urad};
  }
  if (!inside_site(s.origin_x_mm, s.origin_y_mm, s.origin_z_mm)) return {Reject::kOutsideSite, s.origin_x_mm};
  for (std::uint16_t i = 0; i < s.count; ++i) {
    const teamscan_msg_ScanPoint& q = s.points[i];
    if (q.beam >= kMaxBeams) return {Reject::kBeamIndex, q.beam};
    // Beams without a 3-D point (no echo, dazzled, unplaced) carry no coordinates the map uses.
    if ((q.flags & kPointUnplaced) == 0 && !inside_site(q.x_mm, q.y_mm, q.z_mm)) return {Reject::kOutsideSite, q.x_mm};
  }
  return {};
}

Verdict SampleValidator::check_status(const teamscan_msg_RobotStatus& s, Time received) {
  constexpr SampleTopic t = SampleTopic::kStatus;
  Verdict v = check_header(t, s.robot_id, s.stamp_ns, received);
  if (!v.ok()) return count(t, s.robot_id, v);
  return count(t, s.robot_id, check_seq(t, s.robot_id, s.seq));
}

std::string SampleValidator::log_line(const Verdict& v, SampleTopic topic, std::uint32_t robot_id, Time now) {
  const auto r = static_cast<std::size_t>(v.reason);
  if (v.ok() || r >= kRejectReasons) return {};
  if (logged_once_[r] && now - last_log_[r] < options_.log_interval) {
    ++unlogged_[r];
    return {};
  }
  char text[256];
  std::snprintf(text, sizeof text,
                "refused a %s sample of robot %" PRIu32 ": %s (value %" PRId64
                "); stored raw, not fused; %" PRIu64 " more refused for this reason since the last line",
                topic_name(topic), robot_id, reject_name(v.reason), v.value, unlogged_[r]);
  logged_once_[r] = true;
  last_log_[r] = now;
  unlogged_[r] = 0;
  return text;
}

std::string describe_clock(const RobotClock& c) {
  if (c.unset) return "clock never set (stamps before 2020)";
  char text[128];
  const double s = static_cast<double>(c.offset_ns) * 1e-9;
  std::snprintf(text, sizeof text, "stamps %.3f s %s the station's receive times", std::fabs(s),
                s >= 0 ? "behind" : "ahead of");
  return text;
}

std::string SampleValidator::status_text() const {
  std::string out;
  if (counters_.rejected > 0) {
    out = "rejected " + std::to_string(counters_.rejected) + " (";
    bool first = true;
    for (std::size_t r = 1; r < kRejectReasons; ++r) {
      if (counters_.by_reason[r] == 0) continue;
      out += (first ? "" : ", ") + std::string(kReasonNames[r]) + " " + std::to_string(counters_.by_reason[r]);
      first = false;
    }
    out += ")";
  }
  std::string clocks;
  for (std::uint32_t id = 1; id <= kMaxRobots; ++id) {
    const RobotClock& c = clocks_[id];
    if (!c.any || !(c.unset || c.off)) continue;
    char one[48];
    if (c.unset) {
      std::snprintf(one, sizeof one, "r%u unset", id);
    } else {
      std::snprintf(one, sizeof one, "r%u %+.1f s", id, static_cast<double>(-c.offset_ns) * 1e-9);
    }
    clocks += (clocks.empty() ? "" : ", ") + std::string(one);
  }
  if (!clocks.empty()) out += (out.empty() ? "" : "; ") + std::string("clock off: ") + clocks;
  return out;
}

std::string SampleValidator::csv() const {
  std::string o = "# samples refused at the edge per robot and reason (robot 0: robot id out of range), "
                  "docs/validation.md\nrobot,reason,count\n";
  for (std::size_t id = 0; id <= kMaxRobots; ++id) {
    for (std::size_t r = 0; r < kRejectReasons; ++r) {
      const std::uint64_t n = counters_.by_robot[id][r];
      if (n != 0) o += std::to_string(id) + "," + kReasonNames[r] + "," + std::to_string(n) + "\n";
    }
  }
  o += "# clock: receive time − stamp, minimum over the window (positive: the robot's stamps are behind)\n"
       "clock_robot,offset_ms,state\n";
  for (std::uint32_t id = 1; id <= kMaxRobots; ++id) {
    const RobotClock& c = clocks_[id];
    if (!c.any) continue;
    char line[96];
    std::snprintf(line, sizeof line, "%u,%.3f,%s\n", id, static_cast<double>(c.offset_ns) * 1e-6,
                  c.unset ? "unset" : c.off ? "off" : "ok");
    o += line;
  }
  o += "seq_resyncs," + std::to_string(counters_.seq_resyncs) + "\nseq_restarts," +
       std::to_string(counters_.seq_restarts) + "\n";
  return o;
}

}  // namespace teamscan::station
