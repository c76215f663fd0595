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
  //    the shorter arc, common/laser_geometry.hpp interpolate);
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
      return between(first, at(1), t);
    }
    if (t > last.stamp) {
      const Duration gap = t - last.stamp;
      if (gap > max_extrapolation) return Error{"odometry: time after history", 0, static_cast<long>(gap.count() / 1000)};
      if (size_ == 1) return last.pose;
      return between(at(size_ - 2), last, t);
    }
    // Binary search for the first sample at or after t; the ring is sorted by push().
    std::size_t lo = 0, hi = size_ - 1;
    while (lo < hi) {
      const std::size_t mid = lo + (hi - lo) / 2;
      if (at(mid).stamp < t) lo = mid + 1; else hi = mid;
    }
    if (at(lo).stamp == t || lo == 0) return at(lo).pose;
    return between(at(lo - 1), at(lo), t);
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
  // Linear in time through a and b (a.stamp < b.stamp); s outside [0, 1] extrapolates.
  static Pose2 between(const OdometrySample& a, const OdometrySample& b, Time t) {
    const double s = static_cast<double>((t - a.stamp).count()) / static_cast<double>((b.stamp - a.stamp).count());
    return teamscan::interpolate(a.pose, b.pose, s);
  }

  std::array<OdometrySample, Capacity> samples_{};
  std::size_t head_ = 0;
  std::size_t size_ = 0;
  std::uint64_t rejected_ = 0;
  std::uint64_t overwritten_ = 0;
};

}  // namespace teamscan
