// A fixed-capacity ring of odometry samples (time, planar pose of the robot) and the pose at any
// time inside it: each laser beam is placed with the pose at its own time (DESIGN.md "Frames, units,
// time"). Header-only and firmware-clean: no heap, no exceptions, faults as Result values.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>

#include "common/laser_geometry.hpp"
#include "common/pose.hpp"
#include "common/result.hpp"
#include "common/time.hpp"

namespace teamscan {

// SIPs arrive at 10 Hz; 64 samples cover 6.4 s, far more than a scan's 13.3–53.3 ms sweep plus the
// serial and scheduling latency between a SIP and the scan that needs it.
inline constexpr std::size_t kOdometryHistoryDepth = 64;

// How far past either end of the covered span interpolate() extrapolates by default. A scan usually
// ends after the newest SIP: SIPs come every 100 ms and arrive one transmission late (a 43-byte SIP
// takes 45 ms at 9600 baud, and its stamp is back-dated by that), so the newest SIP can be ~150 ms
// older than a scan. 200 ms covers that plus scheduling jitter; anything further is a stalled odometry
// stream and is refused.
inline constexpr Duration kDefaultMaxExtrapolation = 200ms;

struct OdometrySample {
  Time stamp;             // CLOCK_REALTIME of the pose (the SIP's arrival, back-dated)
  Pose2 pose;             // planar robot pose (odometry frame; the map frame when the registration is identity)
};

// The pose at t from consecutive samples b and c (b.stamp < c.stamp; t outside [b, c] extrapolates at
// their constant velocity): the position on the chord from b to c, the heading along the shorter arc,
// on the parabola in time through `before` (the sample before b), b and c when it is given. That is
// the heading of a robot whose turn rate changes steadily over the two SIP cycles: linear between b
// and c, a robot swinging through a sharp corner (a few radians a second, the rate reversing within a
// cycle) is placed up to degrees off its heading, while the chord between two SIPs is off the arc by
// millimetres. Linear when `before` lies much further back than c lies ahead (the odometry stream
// paused): the parabola would not describe one steady turn.
[[nodiscard]] inline Pose2 pose_between(const OdometrySample* before, const OdometrySample& b, const OdometrySample& c, Time t) {
  const double bc = static_cast<double>((c.stamp - b.stamp).count()), tt = static_cast<double>((t - b.stamp).count());
  Pose2 pose = interpolate(b.pose, c.pose, tt / bc);
  if (before == nullptr) return pose;
  const double ab = static_cast<double>((b.stamp - before->stamp).count());
  if (ab > 2.0 * bc || bc > 2.0 * ab) return pose;
  // Time from b; the headings relative to b's along the shorter arcs (Lagrange's parabola through them).
  const double ya = -normalize_angle(b.pose.theta_rad - before->pose.theta_rad), yc = normalize_angle(c.pose.theta_rad - b.pose.theta_rad);
  const double turned = ya * tt * (tt - bc) / (-ab * (-ab - bc)) + yc * tt * (tt + ab) / (bc * (bc + ab));
  pose.theta_rad = normalize_angle(b.pose.theta_rad + turned);
  return pose;
}

template <std::size_t Capacity = kOdometryHistoryDepth>
class OdometryHistory {
  static_assert(Capacity >= 2, "interpolation needs two samples");

 public:
  // Appends a sample. Samples must arrive in strictly increasing time: a sample not newer than the
  // newest one is refused (returns false, counted in rejected()) so the ring stays sorted. When the
  // ring is full the oldest sample is overwritten (counted in overwritten()); that is the normal
  // steady state and still returns true.
  bool push(Time stamp, const Pose2& pose) {
    if (size_ > 0 && stamp <= newest().stamp) {
      ++rejected_;
      return false;
    }
    if (size_ == Capacity) {
      head_ = (head_ + 1) % Capacity;
      --size_;
      ++overwritten_;
    }
    samples_[(head_ + size_) % Capacity] = OdometrySample{stamp, pose};
    ++size_;
    return true;
  }

  void clear() { head_ = 0; size_ = 0; }

  // The pose at time t:
  //  - inside [oldest, newest]: linear interpolation between the two samples around t (heading along
  //    the shorter arc, common/laser_geometry.hpp interpolate), the heading on the parabola through
  //    them and the sample before when there is one (pose_between);
  //  - within max_extrapolation outside that span: constant-velocity extrapolation from the two
  //    samples at that end (a single sample is held constant);
  //  - further out, or an empty history: an Error ("odometry: time before history",
  //    "odometry: time after history", "odometry: no samples"), with `detail` the distance in µs.
  [[nodiscard]] Result<Pose2> interpolate(Time t, Duration max_extrapolation = kDefaultMaxExtrapolation) const {
    if (size_ == 0) return Error{"odometry: no samples"};
    const OdometrySample& first = at(0);
    const OdometrySample& last = newest();
    if (t < first.stamp) {
      const Duration gap = first.stamp - t;
      if (gap > max_extrapolation) return Error{"odometry: time before history", 0, static_cast<long>(gap.count() / 1000)};
      if (size_ == 1) return first.pose;
      return pose_between(nullptr, first, at(1), t);
    }
    if (t > last.stamp) {
      const Duration gap = t - last.stamp;
      if (gap > max_extrapolation) return Error{"odometry: time after history", 0, static_cast<long>(gap.count() / 1000)};
      if (size_ == 1) return last.pose;
      return pose_between(nullptr, at(size_ - 2), last, t);
    }
    // Binary search for the first sample at or after t; the ring is sorted by push().
    std::size_t lo = 0, hi = size_ - 1;
    while (lo < hi) {
      const std::size_t mid = lo + (hi - lo) / 2;
      if (at(mid).stamp < t) lo = mid + 1; else hi = mid;
    }
    if (at(lo).stamp == t || lo == 0) return at(lo).pose;
    return pose_between(lo >= 2 ? &at(lo - 2) : nullptr, at(lo - 1), at(lo), t);
  }

  [[nodiscard]] std::size_t size() const { return size_; }
  [[nodiscard]] static constexpr std::size_t capacity() { return Capacity; }
  [[nodiscard]] bool empty() const { return size_ == 0; }
  // i = 0 is the oldest sample. Contract: i < size().
  [[nodiscard]] const OdometrySample& at(std::size_t i) const {
    TEAMSCAN_EXPECTS(i < size_);
    return samples_[(head_ + i) % Capacity];
  }
  [[nodiscard]] const OdometrySample& newest() const { return at(size_ - 1); }
  [[nodiscard]] std::uint64_t rejected() const { return rejected_; }
  [[nodiscard]] std::uint64_t overwritten() const { return overwritten_; }

 private:
  std::array<OdometrySample, Capacity> samples_{};
  std::size_t head_ = 0;
  std::size_t size_ = 0;
  std::uint64_t rejected_ = 0;
  std::uint64_t overwritten_ = 0;
};

}  // namespace teamscan
