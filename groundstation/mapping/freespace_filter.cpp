// Free-space ray casting: Amanatides & Woo, "A fast voxel traversal algorithm for ray
// tracing" (1987), on the VoxelMap key layout (21-bit fields, VoxelMap::pack).
#include "groundstation/mapping/freespace_filter.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <new>
#include <type_traits>

#include "common/result.hpp"

namespace teamscan::mapping {

static_assert(std::is_trivially_copyable_v<FreeCell> && sizeof(FreeCell) == 4, "calloc'd blocks are empty cells");

namespace {
constexpr std::uint16_t kSaturate = std::numeric_limits<std::uint16_t>::max();
bool in_range(VoxelKey k) {
  return k.x > -VoxelMap::kIndexLimit && k.x < VoxelMap::kIndexLimit && k.y > -VoxelMap::kIndexLimit &&
         k.y < VoxelMap::kIndexLimit && k.z > -VoxelMap::kIndexLimit && k.z < VoxelMap::kIndexLimit;
}
}  // namespace

FreespaceGrid::FreespaceGrid(const FreespaceOptions& options)
    : options_{options},
      inverse_resolution_{1.0 / options.resolution_m},
      ray_stride_{static_cast<double>(std::max<std::uint32_t>(1, options.ray_stride))} {}

VoxelKey FreespaceGrid::key_of(double x, double y, double z) const {
  return {static_cast<std::int32_t>(std::floor(x * inverse_resolution_)),
          static_cast<std::int32_t>(std::floor(y * inverse_resolution_)),
          static_cast<std::int32_t>(std::floor((z - options_.grid_origin_z_m) * inverse_resolution_))};
}

void FreespaceGrid::clear() {
  block_index_.clear();
  pages_.clear();
  blocks_ = 0;
  cached_block_key_ = ~std::uint64_t{0};
  cached_block_ = nullptr;
  cached_bx_ = cached_by_ = cached_bz_ = INT32_MIN;
  voxels_ = 0;
  traversed_ = 0;
}

FreeCell FreespaceGrid::cell(VoxelKey key) const {
  if (!in_range(key)) return {};
  const std::uint32_t* b = block_index_.find(block_key(key));
  return b ? block(*b)[offset_in_block(key)] : FreeCell{};
}

FreeCell FreespaceGrid::cell(VoxelKey key, Lookup& lookup) const {
  if (!in_range(key)) return {};
  const std::uint64_t bk = block_key(key);
  if (bk != lookup.block_key) {
    const std::uint32_t* b = block_index_.find(bk);
    lookup.block_key = bk;
    lookup.block = b ? static_cast<std::int64_t>(*b) : -1;
  }
  return lookup.block >= 0 ? block(static_cast<std::uint32_t>(lookup.block))[offset_in_block(key)] : FreeCell{};
}

bool FreespaceGrid::void_voxel(VoxelKey k, Lookup& lookup) const {
  const FreeCell c = cell(k, lookup);
  return c.free > 0 && std::uint32_t{c.free} >= options_.min_free && rays_through(c) >= options_.free_per_hit * static_cast<double>(c.hits);
}

bool FreespaceGrid::transient(const MapPoint& p, Lookup& lookup) const {
  const VoxelKey k = key_of(p.x, p.y, p.z);
  if (!void_voxel(k, lookup)) return false;
  if (!options_.solid_neighbour_guard) return true;
  static constexpr std::int32_t kFaces[6][3] = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
  for (const auto& f : kFaces) {
    const VoxelKey n{k.x + f[0], k.y + f[1], k.z + f[2]};
    if (cell(n, lookup).hits > 0 && !void_voxel(n, lookup)) return false;
  }
  if (options_.guard_neighbours < 26) return true;
  for (std::int32_t dz = -1; dz <= 1; ++dz)
    for (std::int32_t dy = -1; dy <= 1; ++dy)
      for (std::int32_t dx = -1; dx <= 1; ++dx) {
        if (std::abs(dx) + std::abs(dy) + std::abs(dz) < 2) continue;  // itself and the faces: done
        const VoxelKey n{k.x + dx, k.y + dy, k.z + dz};
        if (cell(n, lookup).hits > 0 && !void_voxel(n, lookup)) return false;
      }
  return true;
}

void FreespaceGrid::insert_scan(const Vec3& origin_m, std::span<const MapPoint> points, std::uint32_t scan) {
  std::vector<FreeCell*>& hits = ray_[0];
  hits.clear();
  for (const MapPoint& p : points) {
    const double dx = p.x - origin_m.x, dy = p.y - origin_m.y, dz = p.z - origin_m.z;
    const double range = std::sqrt(dx * dx + dy * dy + dz * dz);
    // ANCHORS.md §6.2: a return at the sensor is an ego point, not a surface; it marks nothing.
    if (!(range >= options_.min_range_m)) continue;
    const VoxelKey k = key_of(p.x, p.y, p.z);
    if (!in_range(k)) continue;
    // Found and prefetched first, counted below: the hit voxels' misses overlap as the rays' do.
    FreeCell* c = cell_in_block(k);
    __builtin_prefetch(c, 1);
    hits.push_back(c);
  }
  for (FreeCell* c : hits) {
    if (c->hits == 0 && c->free == 0) ++voxels_;
    if (c->hits != kSaturate) ++c->hits;
  }
  const std::size_t stride = static_cast<std::size_t>(ray_stride_);
  cast_rays(origin_m, points, scan % stride, stride);
}

void FreespaceGrid::cast_ray(const Vec3& origin_m, const MapPoint& hit) {
  const std::size_t n = ray_cells(origin_m, hit, ray_[0]);
  mark_free({ray_[0].data(), n});
}

void FreespaceGrid::cast_rays(const Vec3& origin_m, std::span<const MapPoint> points, std::size_t first, std::size_t stride) {
  // A ray's cells are mostly not in the cache (the grid is hundreds of MiB at 32 robots, and 31 other
  // robots' scans came between this robot's two): walked one by one, every cell is a miss that waits
  // for memory. Found one ray ahead and prefetched, the misses of a ray overlap each other.
  std::size_t pending = 0;
  int ahead = 0;
  for (std::size_t i = first; i < points.size(); i += stride) {
    const std::size_t n = ray_cells(origin_m, points[i], ray_[ahead]);
    mark_free({ray_[1 - ahead].data(), pending});
    pending = n;
    ahead = 1 - ahead;
  }
  mark_free({ray_[1 - ahead].data(), pending});
}

void FreespaceGrid::mark_free(std::span<FreeCell* const> cells) {
  for (FreeCell* c : cells) {
    if (c->hits == 0 && c->free == 0) ++voxels_;
    if (c->free != kSaturate) ++c->free;
  }
}

FreeCell* FreespaceGrid::cell_in_block(VoxelKey k) {
  const std::int32_t bx = k.x >> kBlockBits, by = k.y >> kBlockBits, bz = k.z >> kBlockBits;
  if (bx != cached_bx_ || by != cached_by_ || bz != cached_bz_ || cached_block_ == nullptr) {
    const std::uint64_t bk = block_key(k);
    bool inserted = false;
    std::uint32_t& index = block_index_.get_or_insert(bk, 0, &inserted);
    if (inserted) {
      if (blocks_ % kBlocksPerPage == 0) {
        // FreeCell is all zero bytes when empty: calloc's pages are the blocks' initial state.
        auto* page = static_cast<Block*>(std::calloc(kBlocksPerPage, sizeof(Block)));
        if (page == nullptr) throw std::bad_alloc();
        pages_.emplace_back(page);
      }
      index = blocks_++;
    }
    cached_block_key_ = bk;
    cached_block_ = &block(index);
    cached_bx_ = bx;
    cached_by_ = by;
    cached_bz_ = bz;
  }
  return &(*cached_block_)[offset_in_block(k)];
}

std::size_t FreespaceGrid::ray_cells(const Vec3& origin_m, const MapPoint& hit, std::vector<FreeCell*>& cells) {
  const double dx = hit.x - origin_m.x, dy = hit.y - origin_m.y, dz = hit.z - origin_m.z;
  const double range = std::sqrt(dx * dx + dy * dy + dz * dz);
  if (!(range >= options_.min_range_m) || range > options_.max_range_m) return 0;
  // Where the ray stops: end_margin short of the hit, further for grazing rays (see the options).
  const double sin_elev = std::abs(dz) / range;
  double stop_short = options_.end_margin_m;
  if (sin_elev * options_.grazing_cap_m > options_.clearance_m)
    stop_short = std::max(stop_short, options_.clearance_m / sin_elev);
  else
    stop_short = std::max(stop_short, options_.grazing_cap_m);
  const double t0 = options_.min_range_m / range, t1 = (range - stop_short) / range;
  if (!(t1 > t0)) return 0;

  // Segment in grid units (voxel size 1, z from the grid origin).
  const double r = inverse_resolution_;
  const double sx = (origin_m.x + dx * t0) * r, sy = (origin_m.y + dy * t0) * r;
  const double sz = (origin_m.z + dz * t0 - options_.grid_origin_z_m) * r;
  const double ex = (origin_m.x + dx * t1) * r, ey = (origin_m.y + dy * t1) * r;
  const double ez = (origin_m.z + dz * t1 - options_.grid_origin_z_m) * r;
  const double vx = ex - sx, vy = ey - sy, vz = ez - sz;
  VoxelKey k{static_cast<std::int32_t>(std::floor(sx)), static_cast<std::int32_t>(std::floor(sy)),
             static_cast<std::int32_t>(std::floor(sz))};
  const VoxelKey end{static_cast<std::int32_t>(std::floor(ex)), static_cast<std::int32_t>(std::floor(ey)),
                     static_cast<std::int32_t>(std::floor(ez))};
  if (!in_range(k) || !in_range(end)) return 0;
  constexpr double kInf = std::numeric_limits<double>::infinity();
  // Per axis: the step, the parameter t (0..1 along the segment) of the next boundary, and the t
  // between boundaries (Amanatides–Woo tMax / tDelta).
  auto axis = [&](double s, double v, std::int32_t idx, std::int32_t& step, double& t_max, double& t_delta) {
    if (v > 0) {
      step = 1;
      t_max = (static_cast<double>(idx) + 1.0 - s) / v;
      t_delta = 1.0 / v;
    } else if (v < 0) {
      step = -1;
      t_max = (static_cast<double>(idx) - s) / v;
      t_delta = -1.0 / v;
    } else {
      step = 0;
      t_max = kInf;
      t_delta = kInf;
    }
  };
  std::int32_t step[3];
  double t_max[3], t_delta[3];
  axis(sx, vx, k.x, step[0], t_max[0], t_delta[0]);
  axis(sy, vy, k.y, step[1], t_max[1], t_delta[1]);
  axis(sz, vz, k.z, step[2], t_max[2], t_delta[2]);
  // The voxel count is bounded by the Manhattan distance between the end voxels.
  const std::int64_t n = std::int64_t{1} + std::abs(std::int64_t{end.x} - k.x) + std::abs(std::int64_t{end.y} - k.y) +
                         std::abs(std::int64_t{end.z} - k.z);
  if (cells.size() < static_cast<std::size_t>(n)) cells.resize(static_cast<std::size_t>(n));
  // The walk keeps a pointer into the current 16³ block and the voxel's offsets within it: a step
  // moves the pointer by the axis' stride, and only a step out of the block (an offset leaving 0..15)
  // looks the next block up. The axis is chosen as Amanatides–Woo do (x on ties, then y), by index,
  // so the visited voxels and the counts are those of the plain per-voxel walk (test
  // FreespaceGrid.TheBlockWalkCountsLikeAPlainPerVoxelWalk).
  // One branch per axis, so that the walk's state stays in registers (indexing small arrays by the
  // chosen axis kept it on the stack: a store-to-load round trip on every step).
  std::int32_t kx = k.x, ky = k.y, kz = k.z;
  std::int32_t ox = k.x & kBlockMask, oy = k.y & kBlockMask, oz = k.z & kBlockMask;
  double tx = t_max[0], ty = t_max[1], tz = t_max[2];
  const double dtx = t_delta[0], dty = t_delta[1], dtz = t_delta[2];
  const std::int32_t stx = step[0], sty = step[1], stz = step[2];
  const std::ptrdiff_t cx = stx, cy = sty * (std::ptrdiff_t{1} << kBlockBits), cz = stz * (std::ptrdiff_t{1} << (2 * kBlockBits));
  constexpr auto kOut = [](std::int32_t o) { return static_cast<std::uint32_t>(o) > static_cast<std::uint32_t>(kBlockMask); };
  FreeCell* c = cell_in_block(k);
  std::size_t count = 0;
  for (std::int64_t i = 0;;) {
    __builtin_prefetch(c, 1);
    cells[count++] = c;
    if (kx == end.x && ky == end.y && kz == end.z) break;  // stopped early: only the visited
    if (++i >= n) break;
    if (tx <= ty && tx <= tz) {
      kx += stx;
      tx += dtx;
      ox += stx;
      if (kOut(ox)) {
        ox &= kBlockMask;
        c = cell_in_block({kx, ky, kz});
      } else {
        c += cx;
      }
    } else if (ty <= tz) {
      ky += sty;
      ty += dty;
      oy += sty;
      if (kOut(oy)) {
        oy &= kBlockMask;
        c = cell_in_block({kx, ky, kz});
      } else {
        c += cy;
      }
    } else {
      kz += stz;
      tz += dtz;
      oz += stz;
      if (kOut(oz)) {
        oz &= kBlockMask;
        c = cell_in_block({kx, ky, kz});
      } else {
        c += cz;
      }
    }
  }
  traversed_ += count;
  return count;
}

FilterParams FreespaceFilter::params() const {
  return {{"resolution_m", options_.resolution_m},   {"grid_origin_z_m", options_.grid_origin_z_m},
          {"min_range_m", options_.min_range_m},     {"max_range_m", options_.max_range_m},
          {"end_margin_m", options_.end_margin_m},   {"clearance_m", options_.clearance_m},
          {"grazing_cap_m", options_.grazing_cap_m}, {"min_free", static_cast<double>(options_.min_free)},
          {"free_per_hit", options_.free_per_hit},   {"solid_neighbour_guard", options_.solid_neighbour_guard ? 1.0 : 0.0},
          {"guard_neighbours", static_cast<double>(options_.guard_neighbours)},
          {"ray_stride", static_cast<double>(std::max<std::uint32_t>(1, options_.ray_stride))}};
}

void FreespaceFilter::decide(std::span<const MapPoint> points, std::span<const std::uint8_t>,
                             std::span<std::uint8_t> removed) const {
  TEAMSCAN_EXPECTS(removed.size() == points.size());
  FreespaceGrid::Lookup lookup;
  for (std::size_t i = 0; i < points.size(); ++i) removed[i] = grid_.transient(points[i], lookup) ? 1 : 0;
}

}  // namespace teamscan::mapping
