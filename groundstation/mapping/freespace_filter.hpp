// `freespace` (docs/beyond.md): free-space ray casting through a sparse voxel grid with the
// Amanatides–Woo traversal. Each voxel counts the points that hit it and the rays that passed through
// it; a point is transient when its voxel was seen empty (DUFOMap's void evidence, ANCHORS.md §2) often
// enough. insert() is the same code live and offline; decide() only reads.
#pragma once

#include <algorithm>
#include <array>
#include <cstdint>
#include <cstdlib>
#include <memory>
#include <span>
#include <vector>

#include "groundstation/mapping/freespace_tracked_options.hpp"
#include "groundstation/mapping/filter.hpp"
#include "common/flat_key_map.hpp"

namespace teamscan::mapping {

// One voxel's evidence: points that fell in it, rays that crossed it (both saturate at 65535: a
// voxel hit more than 65535 / free_per_hit times is solid whatever crossed it; 4 bytes a voxel keeps the
// dense blocks, the station's largest state, at half the size of 32-bit counts).
struct FreeCell {
  std::uint16_t hits = 0;
  std::uint16_t free = 0;
};

class FreespaceGrid {
 public:
  explicit FreespaceGrid(const FreespaceOptions& options);
  [[nodiscard]] VoxelKey key_of(double x, double y, double z) const;
  // Folds one scan in: every point's voxel +1 hit, every cast ray's traversed voxels +1 free. The rays
  // cast are every ray_stride-th from point (scan mod ray_stride) (FreespaceOptions::ray_stride).
  void insert_scan(const Vec3& origin_m, std::span<const MapPoint> points, std::uint32_t scan = 0);
  // Marks the voxels of one ray (origin → hit, shortened as the options say) as passed.
  void cast_ray(const Vec3& origin_m, const MapPoint& hit);
  // The same for points first, first + stride, … of a scan, software-pipelined (see ray_cells): the
  // cells of ray i are found and prefetched while ray i − 1's are counted. Counts as cast_ray per
  // point, in any order.
  void cast_rays(const Vec3& origin_m, std::span<const MapPoint> points, std::size_t first = 0, std::size_t stride = 1);
  [[nodiscard]] FreeCell cell(VoxelKey key) const;
  // The last block looked up: the points of one scan are near each other, so classify() pays the
  // block index's hash once per block, not once per point (as cast_ray does).
  struct Lookup {
    std::uint64_t block_key = ~std::uint64_t{0};
    std::int64_t block = -1;  // index in blocks_, -1: no such block
  };
  [[nodiscard]] FreeCell cell(VoxelKey key, Lookup& lookup) const;
  [[nodiscard]] bool transient(const MapPoint& p) const {
    Lookup lookup;
    return transient(p, lookup);
  }
  [[nodiscard]] bool transient(const MapPoint& p, Lookup& lookup) const;
  // The voxel's own evidence says void (free passes enough, see FreespaceOptions).
  [[nodiscard]] bool void_voxel(VoxelKey k) const {
    Lookup lookup;
    return void_voxel(k, lookup);
  }
  [[nodiscard]] bool void_voxel(VoxelKey k, Lookup& lookup) const;
  // The rays that crossed the voxel, as the per-hit rules count them: each cast pass stands for
  // ray_stride rays of its scan (FreespaceOptions::ray_stride).
  [[nodiscard]] double rays_through(FreeCell c) const { return static_cast<double>(c.free) * ray_stride_; }
  [[nodiscard]] std::size_t voxels() const { return voxels_; }
  [[nodiscard]] std::uint64_t traversed() const { return traversed_; }
  [[nodiscard]] std::size_t memory_bytes() const {
    return block_index_.memory_bytes() + pages_.capacity() * sizeof(pages_[0]) + pages_.size() * kBlocksPerPage * sizeof(Block);
  }
  void clear();

 private:
  // Voxels live in dense 16³ blocks found through a sparse block index: a ray walks mostly within
  // one block, so the hash lookup is paid once per block, not once per voxel.
  static constexpr int kBlockBits = 4;
  static constexpr std::int32_t kBlockMask = (1 << kBlockBits) - 1;
  using Block = std::array<FreeCell, 1u << (3 * kBlockBits)>;
  [[nodiscard]] static std::size_t offset_in_block(VoxelKey k) {
    return static_cast<std::size_t>(((k.z & kBlockMask) << (2 * kBlockBits)) | ((k.y & kBlockMask) << kBlockBits) | (k.x & kBlockMask));
  }
  [[nodiscard]] static std::uint64_t block_key(VoxelKey k) {
    return VoxelMap::pack({k.x >> kBlockBits, k.y >> kBlockBits, k.z >> kBlockBits});
  }
  // The cell of voxel k, its block created if needed; the cell is not read (it may not be cached yet:
  // callers prefetch it and count it later).
  FreeCell* cell_in_block(VoxelKey k);
  // The cells one ray marks, in walk order, each prefetched for writing, into `cells` (resized as
  // needed); returns how many. The walk: cast_ray's (Amanatides–Woo, x on ties, then y).
  std::size_t ray_cells(const Vec3& origin_m, const MapPoint& hit, std::vector<FreeCell*>& cells);
  void mark_free(std::span<FreeCell* const> cells);  // +1 free (saturating), counting new voxels
  // Blocks live in pages of kBlocksPerPage, zeroed by calloc (fresh pages from the kernel, not memset):
  // a new block never moves the others (no copy of the grid as it grows, pointers into it stay valid).
  static constexpr std::size_t kBlocksPerPage = 64;  // 1 MiB
  struct FreePage {
    void operator()(Block* p) const { std::free(p); }
  };
  [[nodiscard]] Block& block(std::uint32_t i) const { return pages_[i / kBlocksPerPage][i % kBlocksPerPage]; }

  FreespaceOptions options_;
  double inverse_resolution_;
  double ray_stride_;  // max(1, options_.ray_stride)
  FlatKeyMap<std::uint32_t> block_index_;  // block key -> block index (block())
  std::vector<std::unique_ptr<Block[], FreePage>> pages_;
  std::uint32_t blocks_ = 0;
  std::uint64_t cached_block_key_ = ~std::uint64_t{0};
  Block* cached_block_ = nullptr;
  // The cached block's coordinates (voxel key >> kBlockBits): a ray's next voxel is compared with
  // them directly, so the block key is packed only when the ray enters another block.
  std::int32_t cached_bx_ = INT32_MIN, cached_by_ = INT32_MIN, cached_bz_ = INT32_MIN;
  std::size_t voxels_ = 0;
  std::uint64_t traversed_ = 0;
  std::vector<FreeCell*> ray_[2];  // cast_rays' two rays in flight
};

class FreespaceFilter final : public Filter {
 public:
  explicit FreespaceFilter(FreespaceOptions options) : options_{options}, grid_{options} {}
  [[nodiscard]] std::string method() const override { return "freespace"; }
  [[nodiscard]] FilterParams params() const override;
  void point_bits(const ScanView&, std::span<std::uint8_t> bits) const override { std::fill(bits.begin(), bits.end(), 0); }
  void insert(const ScanView& scan, std::span<const std::uint8_t>) override { grid_.insert_scan(scan.origin_m, scan.points, scan.scan); }
  void decide(std::span<const MapPoint> points, std::span<const std::uint8_t> bits,
              std::span<std::uint8_t> removed) const override;
  void reset() override { grid_.clear(); }
  [[nodiscard]] std::size_t memory_bytes() const override { return grid_.memory_bytes(); }
  [[nodiscard]] const FreespaceGrid& grid() const { return grid_; }

 private:
  FreespaceOptions options_;
  FreespaceGrid grid_;
};

}  // namespace teamscan::mapping
