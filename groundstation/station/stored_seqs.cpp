// One robot's stored scan seqs (stored_seqs.hpp).
#include "groundstation/station/stored_seqs.hpp"

#include <iterator>

namespace teamscan::station {

bool StoredSeqs::insert(std::uint32_t seq) {
  if (!any_) {
    any_ = true;
    first_ = contiguous_ = seq;
    count_ = 1;
    return true;
  }
  if (seq >= first_ && seq <= contiguous_) return false;
  if (seq > contiguous_) {
    if (seq == contiguous_ + 1) {
      contiguous_ = seq;
      // The hole closed: the stored run above it joins.
      while (!above_.empty() && *above_.begin() == contiguous_ + 1) {
        contiguous_ = *above_.begin();
        above_.erase(above_.begin());
      }
    } else if (!above_.insert(seq).second) {
      return false;
    }
  } else {  // below first_
    if (seq + 1 == first_) {
      first_ = seq;
      while (!below_.empty() && *below_.rbegin() + 1 == first_) {
        first_ = *below_.rbegin();
        below_.erase(std::prev(below_.end()));
      }
    } else if (!below_.insert(seq).second) {
      return false;
    }
  }
  ++count_;
  return true;
}

std::uint64_t StoredSeqs::holes() const {
  if (!any_) return 0;
  const std::uint32_t low = below_.empty() ? first_ : *below_.begin();
  const std::uint32_t high = above_.empty() ? contiguous_ : *above_.rbegin();
  return static_cast<std::uint64_t>(high) - low + 1 - count_;
}

}  // namespace teamscan::station
