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

std::uint64_t ModelStore::key_of(const ModelPoint& m) const {
  if (!std::isfinite(m.p.x) || !std::isfinite(m.p.y) || !std::isfinite(m.p.z)) return kNoKey;
  auto index = [&](float v) {
    const double k = std::floor(static_cast<double>(v) * inverse_resolution_);
    return static_cast<std::int32_t>(std::clamp(k, -double(mapping::VoxelMap::kIndexLimit), double(mapping::VoxelMap::kIndexLimit - 1)));
  };
  return mapping::VoxelMap::pack({index(m.p.x), index(m.p.y), index(m.p.z)});
}

bool ModelStore::add(const ModelPoint& m) {
  if (cap_ == 0) return false;
  return add_keyed(m, key_of(m));
}

std::size_t ModelStore::add_all(std::span<const ModelPoint> points, std::span<std::uint8_t> stored_out) {
  std::fill(stored_out.begin(), stored_out.end(), std::uint8_t{0});
  if (cap_ == 0) return 0;
  const std::size_t n = points.size();
  batch_keys_.resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    batch_keys_[i] = key_of(points[i]);
    if (batch_keys_[i] != kNoKey && batch_keys_[i] != (i > 0 ? batch_keys_[i - 1] : last_key_)) index_.prefetch(batch_keys_[i]);
  }
  // The records of the voxels that are already there, and their last chunks (new voxels are added by
  // add_keyed in order, so the numbering is add()'s).
  batch_slots_.resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    const std::uint32_t* at = batch_keys_[i] == kNoKey ? nullptr : index_.find(batch_keys_[i]);
    batch_slots_[i] = at ? *at : ~std::uint32_t{0};
    if (at) __builtin_prefetch(&slots_[*at]);
  }
  for (std::size_t i = 0; i < n; ++i) {
    if (batch_slots_[i] == ~std::uint32_t{0}) continue;
    const Slot& s = slots_[batch_slots_[i]];
    if (s.count < cap_ && s.count % kChunkPoints != 0) __builtin_prefetch(&chunk(s.last), 1);
  }
  std::size_t stored = 0;
  for (std::size_t i = 0; i < n; ++i) {
    const bool in = add_keyed(points[i], batch_keys_[i]);
    stored += in ? 1 : 0;
    if (i < stored_out.size()) stored_out[i] = in ? 1 : 0;
  }
  return stored;
}

bool ModelStore::add_keyed(const ModelPoint& m, std::uint64_t key) {
  if (cap_ == 0 || key == kNoKey) return false;
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
