// Which robot sent a sample: the robot named by the partition ("robot<N>") its publication was published
// in. Under DDS Security the station's access control checked that partition against the publishing
// participant's CA-signed grant before matching it (DDS_SECURITY.md 6c, 6e), so the partition is the
// sender's authenticated identity and a sample whose robot_id differs is a robot publishing as another
// (refused, counted, logged). Pure bookkeeping: the DDS lookup of a publication's partition is injected.
#pragma once

#include <array>
#include <cstdint>
#include <functional>

#include "common/capacities.hpp"
#include "dds/qos.hpp"

namespace teamscan::station {

class SenderIdentity {
 public:
  // The robot id of publication `handle` on reader `topic` (0 = unknown: not matched, or its partition
  // is not a robot's). Called once per publication.
  using Lookup = std::function<std::uint32_t(int topic, std::uint64_t handle)>;
  explicit SenderIdentity(Lookup lookup) : lookup_{std::move(lookup)} {}

  // Resolves a newly matched publication ahead of its first sample (the lookup fails once its writer
  // has gone, and its last samples may still be waiting in the reader).
  void matched(int topic, std::uint64_t handle) { (void)robot_of(topic, handle); }
  // The robot that sent the sample published by `handle` (cached), 0 if unknown.
  std::uint32_t robot_of(int topic, std::uint64_t handle);
  // True if the sample's robot_id is the sender's own.
  bool accepts(int topic, std::uint64_t handle, std::uint32_t claimed_robot_id) {
    const std::uint32_t sender = robot_of(topic, handle);
    return sender != 0 && sender == claimed_robot_id;
  }

  // Publications remembered: a robot's writers (pose, scan, status, the back-fill's lanes and its pose
  // back-fill) x 32 robots, twice over for restarts and intruders; the oldest entry is forgotten first (it is
  // looked up again if it still sends).
  static constexpr std::size_t kCapacity = (4 + dds::kBackfillLanes) * kMaxRobots * 2;

 private:
  struct Entry {
    std::uint64_t handle = 0;
    std::uint32_t robot_id = 0;
  };
  Lookup lookup_;
  std::array<Entry, kCapacity> entries_{};
  std::size_t next_ = 0;
};

inline std::uint32_t SenderIdentity::robot_of(int topic, std::uint64_t handle) {
  if (handle == 0) return 0;
  for (const Entry& e : entries_)
    if (e.handle == handle) return e.robot_id;
  const std::uint32_t id = lookup_ ? lookup_(topic, handle) : 0;
  if (id == 0) return 0;  // not remembered: a later lookup may succeed
  entries_[next_] = Entry{handle, id};
  next_ = (next_ + 1) % kCapacity;
  return id;
}

}  // namespace teamscan::station
