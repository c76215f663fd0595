// ModelStore: the capped per-voxel model in a paged chunk arena (model_store.hpp).
#include "groundstation/fusion/model_store.hpp"

#include <algorithm>
#include <cmath>
#include <new>

namespace teamscan::fusion {

ModelStore::ModelStore(double resolution_m, std::uint32_t max_points_per_voxel)
    : inverse_resolution_{resolution_m > 0.0 ? 1.0 / resolution_m : 20.0}, cap_{max_points_per_voxel} {}

std::uint32_t ModelStore::new_chunk() {
  if (chunks_ % kChunksPerPage == 0) {
    auto* page = static_cast<Chunk*>(std::malloc(kChunksPerPage * sizeof(Chunk)));
    if (page == nullptr) throw std::bad_alloc();
    pages_.emplace_back(page);
  }
  return chunks_++;
}

bool ModelStore::add(const ModelPoint& m) {
  if (cap_ == 0) return false;
  if (!std::isfinite(m.p.x) || !std::isfinite(m.p.y) || !std::isfinite(m.p.z)) return false;
  auto index = [&](float v) {
    const double k = std::floor(static_cast<double>(v) * inverse_resolution_);
    return static_cast<std::int32_t>(std::clamp(k, -double(mapping::VoxelMap::kIndexLimit), double(mapping::VoxelMap::kIndexLimit - 1)));
  };
  const std::uint64_t key = mapping::VoxelMap::pack({index(m.p.x), index(m.p.y), index(m.p.z)});
  // A scan's neighbouring beams often land in one voxel: the last voxel is remembered.
  if (key != last_key_) {
    bool inserted = false;
    std::uint32_t& at = index_.get_or_insert(key, 0, &inserted);
    if (inserted) {
      at = static_cast<std::uint32_t>(slots_.size());
      slots_.emplace_back();
    }
    last_key_ = key;
    last_slot_ = at;
  }
  Slot& s = slots_[last_slot_];
  if (s.count >= cap_) {
    ++capped_;
    return false;
  }
  if (s.count % kChunkPoints == 0) {
    const std::uint32_t c = new_chunk();
    if (s.first == kNoChunk) s.first = c;
    else chunk(s.last).next = c;
    s.last = c;
  }
  chunk(s.last).points[s.count % kChunkPoints] = m;
  ++s.count;
  ++points_;
  return true;
}

std::size_t ModelStore::memory_bytes() const {
  return index_.memory_bytes() + slots_.capacity() * sizeof(Slot) + pages_.capacity() * sizeof(pages_[0]) +
         pages_.size() * std::size_t{kChunksPerPage} * sizeof(Chunk);
}

}  // namespace teamscan::fusion
