// The fused model's points, bounded by the mapped space (DESIGN.md "groundstation/fusion"):
// at most `max_points_per_voxel` points per voxel of `resolution_m`, each with its identity (robot, seq,
// beam) and its decision's point part. Beyond the cap a voxel's points are counted, not stored (the
// session files keep every point). Storage is a paged arena of small chunks: no per-voxel allocation,
// no reallocation that copies or doubles the store while the receive loop runs, and the bytes a point
// costs are the record's plus at most one chunk's slack per voxel.
#pragma once

#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <memory>
#include <span>
#include <type_traits>
#include <vector>

#include "common/flat_key_map.hpp"
#include "groundstation/mapping/voxel_map.hpp"

namespace teamscan::fusion {

// A point of the model store: 20 bytes.
struct ModelPoint {
  mapping::MapPoint p;
  std::uint32_t seq = 0;
  std::uint16_t beam = 0;
  std::uint8_t bits = 0;                    // the point part of its decision (mapping::Filter::point_bits)
  std::uint8_t robot : 7 = 0;               // 1..kMaxRobots
  std::uint8_t removed_at_release : 1 = 0;  // the decision when its scan was released
};
static_assert(sizeof(ModelPoint) == 20, "the model store's memory bound counts 20 bytes a point");
static_assert(std::is_trivially_copyable_v<ModelPoint>, "model points are copied into malloc'd pages");

class ModelStore {
 public:
  // max_points_per_voxel 0: nothing is stored.
  ModelStore(double resolution_m, std::uint32_t max_points_per_voxel);

  // Stores `m` in its voxel; false when the voxel already holds max_points_per_voxel (counted) or the
  // point is not finite.
  bool add(const ModelPoint& m);
  // add() for each point of `points` in order (the same stores, the same voxel numbering), the voxels'
  // index slots, records and chunks prefetched first so their cache misses overlap (a scan's points
  // land in voxels all over a map of hundreds of MiB). Returns how many were stored; `stored` (empty, or
  // one per point) is set to 1 for each point stored, 0 for each capped or not finite.
  std::size_t add_all(std::span<const ModelPoint> points, std::span<std::uint8_t> stored = {});

  // Room for `voxels` voxels without growing the index (a store about to take another's points: a
  // rigid move of the model, which would otherwise grow it step by step within the receive loop).
  void reserve(std::size_t voxels) {
    index_.reserve(voxels);
    slots_.reserve(voxels);
  }
  [[nodiscard]] std::size_t voxels() const { return slots_.size(); }
  [[nodiscard]] std::uint64_t points() const { return points_; }
  [[nodiscard]] std::uint64_t capped_points() const { return capped_; }
  [[nodiscard]] std::size_t memory_bytes() const;

  // The points of voxel `k` (0 <= k < voxels(), in the order the voxels were first hit; a voxel keeps
  // its index for good) in the order they were stored: f(const ModelPoint&).
  template <class F>
  void for_each_in_voxel(std::size_t k, F&& f) const {
    const Slot& s = slots_[k];
    std::uint32_t left = s.count;
    for (std::uint32_t c = s.first; left > 0; c = chunk(c).next) {
      const Chunk& ch = chunk(c);
      const std::uint32_t n = left < kChunkPoints ? left : kChunkPoints;
      for (std::uint32_t i = 0; i < n; ++i) f(ch.points[i]);
      left -= n;
    }
  }
  [[nodiscard]] std::uint32_t voxel_points(std::size_t k) const { return slots_[k].count; }

 private:
  static constexpr std::uint32_t kChunkPoints = 4;
  static constexpr std::uint32_t kChunksPerPage = 4096;
  static constexpr std::uint32_t kNoChunk = ~std::uint32_t{0};
  struct Chunk {
    ModelPoint points[kChunkPoints];
    std::uint32_t next;  // set when the voxel takes its next chunk (read only up to the voxel's count)
  };
  // Pages are malloc'd, not value-initialised: a chunk is written before it is read, and a page's
  // memory is touched only as its chunks are taken.
  struct FreePage {
    void operator()(Chunk* p) const { std::free(p); }
  };
  struct Slot {
    std::uint32_t first = kNoChunk, last = kNoChunk;
    std::uint32_t count = 0;
  };
  [[nodiscard]] const Chunk& chunk(std::uint32_t c) const { return pages_[c / kChunksPerPage][c % kChunksPerPage]; }
  [[nodiscard]] Chunk& chunk(std::uint32_t c) { return pages_[c / kChunksPerPage][c % kChunksPerPage]; }
  std::uint32_t new_chunk();
  // The packed voxel key of a finite point (kNoKey otherwise).
  static constexpr std::uint64_t kNoKey = FlatKeyMap<std::uint32_t>::kEmpty;
  [[nodiscard]] std::uint64_t key_of(const ModelPoint& m) const;
  bool add_keyed(const ModelPoint& m, std::uint64_t key);

  double inverse_resolution_;
  std::uint32_t cap_;
  FlatKeyMap<std::uint32_t> index_;  // packed voxel key -> index in slots_
  std::vector<Slot> slots_;
  std::uint64_t last_key_ = FlatKeyMap<std::uint32_t>::kEmpty;  // the voxel of the last add
  std::uint32_t last_slot_ = 0;
  std::vector<std::unique_ptr<Chunk[], FreePage>> pages_;
  std::uint32_t chunks_ = 0;
  std::uint64_t points_ = 0, capped_ = 0;
  std::vector<std::uint64_t> batch_keys_;  // add_all's scratch
  std::vector<std::uint32_t> batch_slots_;
};

}  // namespace teamscan::fusion
