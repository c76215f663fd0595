// Which scans of one robot the session holds, by the robot's scan seq: each seq is stored once (a DDS
// history replay or a back-fill of a scan the station already has is a duplicate, never stored twice),
// and the highest seq up to which every scan from the first one is stored is what the station confirms
// on teamscan/stored (store and forward, docs/onboard.md "The ring"). Pure bookkeeping.
#pragma once

#include <cstdint>
#include <set>

namespace teamscan::station {

class StoredSeqs {
 public:
  // False: the seq is stored already (a duplicate).
  bool insert(std::uint32_t seq);
  // A robot that restarted its numbering (its ring lost): everything known so far is forgotten.
  void reset() { *this = StoredSeqs{}; }

  [[nodiscard]] bool any() const { return any_; }
  [[nodiscard]] std::uint32_t first() const { return first_; }            // the lowest contiguous one
  [[nodiscard]] std::uint32_t contiguous() const { return contiguous_; }  // every seq first..this stored
  [[nodiscard]] std::uint64_t count() const { return count_; }
  [[nodiscard]] std::uint64_t holes() const;  // seqs between first and the newest not stored

 private:
  bool any_ = false;
  std::uint32_t first_ = 0, contiguous_ = 0;
  std::uint64_t count_ = 0;
  std::set<std::uint32_t> above_;  // stored seqs above contiguous_ + 1
  std::set<std::uint32_t> below_;  // stored seqs below first_ - 1 (older than the first one heard)
};

}  // namespace teamscan::station
