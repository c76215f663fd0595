// LiveMap: the station's published map in one table (live_map.hpp).
#include "groundstation/station/live_map.hpp"

#include <algorithm>
#include <cmath>

#include "common/units.hpp"

namespace teamscan::station {

LiveMap::LiveMap(double resolution_m) : resolution_m_{resolution_m}, inverse_resolution_{1.0 / resolution_m} {}

std::uint64_t LiveMap::key_of(const mapping::MapPoint& p) const {
  const mapping::VoxelKey k = mapping::voxel_key(p, inverse_resolution_);
  return mapping::VoxelMap::in_range(k) ? mapping::VoxelMap::pack(k) : kOutOfRange;
}

void LiveMap::add(const mapping::MapPoint& p, bool removed, std::uint8_t robot) { add_keyed(key_of(p), removed, robot); }

void LiveMap::add_all(std::span<const mapping::MapPoint> points, std::span<const std::uint8_t> removed,
                      std::span<const std::uint8_t> stored, std::uint8_t robot, std::uint64_t release) {
  constexpr std::uint64_t kSkip = kOutOfRange - 1;  // not a model point: not mapped, not counted
  batch_keys_.resize(points.size());
  for (std::size_t i = 0; i < points.size(); ++i) {
    if (!stored.empty() && (i >= stored.size() || stored[i] == 0)) {
      batch_keys_[i] = kSkip;
      continue;
    }
    batch_keys_[i] = key_of(points[i]);
    if (batch_keys_[i] != kOutOfRange) cells_.prefetch(batch_keys_[i]);
  }
  for (std::size_t i = 0; i < points.size(); ++i) {
    if (batch_keys_[i] != kSkip) add_keyed(batch_keys_[i], i < removed.size() && removed[i] != 0, robot);
  }
  if (release > release_) release_ = release;
}

void LiveMap::add_keyed(std::uint64_t key, bool removed, std::uint8_t robot) {
  if (key == kOutOfRange) {
    ++rejected_;
    return;
  }
  Cell& c = cells_.get_or_insert(key, Cell{});
  if (c.hits < UINT32_MAX) ++c.hits;
  if (!removed && c.kept < UINT16_MAX) ++c.kept;
  if (c.robot == 0) c.robot = robot;
  if (c.changed == 0) {
    c.changed = 1;
    changed_.push_back(key);
  }
}

teamscan_msg_MapVoxel LiveMap::message(std::uint64_t key, const Cell& c) const {
  const mapping::VoxelKey k = mapping::VoxelMap::unpack(key);
  teamscan_msg_MapVoxel v{};
  v.x_mm = to_mm((k.x + 0.5) * resolution_m_);
  v.y_mm = to_mm((k.y + 0.5) * resolution_m_);
  v.z_mm = to_mm((k.z + 0.5) * resolution_m_);
  v.hits = static_cast<std::uint16_t>(std::min<std::uint32_t>(c.hits, 0xFFFFu));
  v.flags = c.kept == 0 ? 1 : 0;
  return v;
}

void LiveMap::voxels(std::vector<teamscan_msg_MapVoxel>& out, std::vector<std::uint8_t>* robots) const {
  out.clear();
  out.reserve(cells_.size());
  if (robots != nullptr) robots->clear();
  cells_.for_each([&](std::uint64_t key, const Cell& c) {
    out.push_back(message(key, c));
    if (robots != nullptr) robots->push_back(c.robot);
  });
}

void LiveMap::changed_voxels(std::vector<teamscan_msg_MapVoxel>& out, std::vector<std::uint8_t>* robots) {
  out.clear();
  out.reserve(changed_.size());
  if (robots != nullptr) robots->clear();
  for (std::uint64_t key : changed_) {
    Cell& c = cells_.get_or_insert(key, Cell{});
    out.push_back(message(key, c));
    if (robots != nullptr) robots->push_back(c.robot);
    c.changed = 0;
  }
  changed_.clear();
}

void LiveMap::forget_changes() {
  for (std::uint64_t key : changed_) cells_.get_or_insert(key, Cell{}).changed = 0;
  changed_.clear();
}

}  // namespace teamscan::station
