// Sparse voxel map: packed integer keys in open-addressing tables (PAPER_NOTES eqs. 2–3).
#include "groundstation/mapping/voxel_map.hpp"

#include <cmath>

#include "common/result.hpp"

namespace teamscan::mapping {
namespace {
constexpr std::uint64_t kFieldMask = (std::uint64_t{1} << 21) - 1;
std::int32_t to_index(double v, double inverse_resolution) {
  const double scaled = std::floor(v * inverse_resolution);
  // Clamp before the cast so NaN or huge values cannot overflow; in_range() rejects them after.
  if (!(scaled > -2.0 * VoxelMap::kIndexLimit)) return -2 * VoxelMap::kIndexLimit;
  if (scaled > 2.0 * VoxelMap::kIndexLimit) return 2 * VoxelMap::kIndexLimit;
  return static_cast<std::int32_t>(scaled);
}
}  // namespace

VoxelKey voxel_key(const MapPoint& p, double inverse_resolution, double origin_z_m) {
  return {to_index(p.x, inverse_resolution), to_index(p.y, inverse_resolution),
          to_index(static_cast<double>(p.z) - origin_z_m, inverse_resolution)};
}

VoxelMap::VoxelMap(double resolution_m, double origin_z_m)
    : resolution_m_{resolution_m}, origin_z_m_{origin_z_m}, inverse_resolution_{1.0 / resolution_m} {
  TEAMSCAN_EXPECTS(resolution_m > 0.0);
}

VoxelKey VoxelMap::key_of(const MapPoint& p) const { return voxel_key(p, inverse_resolution_, origin_z_m_); }

bool VoxelMap::in_range(VoxelKey k) {
  auto ok = [](std::int32_t v) { return v >= -kIndexLimit && v < kIndexLimit; };
  return ok(k.x) && ok(k.y) && ok(k.z);
}

std::uint64_t VoxelMap::pack(VoxelKey k) {
  auto field = [](std::int32_t v) { return static_cast<std::uint64_t>(v + kIndexLimit) & kFieldMask; };
  return (field(k.x) << 42) | (field(k.y) << 21) | field(k.z);
}

VoxelKey VoxelMap::unpack(std::uint64_t packed) {
  auto field = [](std::uint64_t v) { return static_cast<std::int32_t>(v & kFieldMask) - kIndexLimit; };
  return {field(packed >> 42), field(packed >> 21), field(packed)};
}

void VoxelMap::insert(const MapPoint& p) {
  const VoxelKey k = key_of(p);
  if (!in_range(k)) {
    ++rejected_;
    return;
  }
  std::uint32_t& c = voxels_.get_or_insert(pack(k), 0u);
  sum_counts_ += 1;
  sum_counts_sq_ += 2ull * c + 1ull;  // (c+1)² − c²
  ++c;
  ++points_;
  bool inserted = false;
  std::int32_t& lowest = columns_.get_or_insert(pack({k.x, k.y, 0}), k.z, &inserted);
  if (!inserted && k.z < lowest) lowest = k.z;
}

void VoxelMap::insert(std::span<const MapPoint> points) {
  // No reserve: the tables grow a few slots per insert (FlatKeyMap), a reserve would rehash at once.
  for (const MapPoint& p : points) insert(p);
}

std::uint32_t VoxelMap::count(VoxelKey key) const {
  if (!in_range(key)) return 0;
  const std::uint32_t* c = voxels_.find(pack(key));
  return c ? *c : 0u;
}

std::optional<std::int32_t> VoxelMap::column_lowest_z(std::int32_t x, std::int32_t y) const {
  if (!in_range({x, y, 0})) return std::nullopt;
  const std::int32_t* z = columns_.find(pack({x, y, 0}));
  if (!z) return std::nullopt;
  return *z;
}

double VoxelMap::mean_count() const {
  if (voxels_.size() == 0) return 0.0;
  return static_cast<double>(sum_counts_) / static_cast<double>(voxels_.size());
}

double VoxelMap::stddev_count() const {
  if (voxels_.size() == 0) return 0.0;
  const double n = static_cast<double>(voxels_.size());
  const double mean = static_cast<double>(sum_counts_) / n;
  const double var = static_cast<double>(sum_counts_sq_) / n - mean * mean;
  return var > 0.0 ? std::sqrt(var) : 0.0;
}

void VoxelMap::clear() {
  voxels_.clear();
  columns_.clear();
  points_ = rejected_ = sum_counts_ = sum_counts_sq_ = 0;
}

}  // namespace teamscan::mapping
