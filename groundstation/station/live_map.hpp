// The live map the station publishes (teamscan/map, the browser view, ROS 2 map_cloud): the fused
// model's points (the core's corrected positions, only the points its model store keeps) binned at the
// map resolution; per voxel the points, the points kept at release (its class: every point removed ->
// a removed ghost voxel), the robot whose point made it, and the voxels changed since the last
// publication. It is the model at a known instant of the core: release() is the number of scans the
// core had released when the last of them went in. One table and one hash lookup per point.
#pragma once

#include <algorithm>
#include <cstdint>
#include <span>
#include <vector>

#include "common/flat_key_map.hpp"
#include "groundstation/mapping/voxel_map.hpp"
#include "teamscan.h"

namespace teamscan::station {

class LiveMap {
 public:
  explicit LiveMap(double resolution_m);

  // One fused point and its decision at release. Points beyond the index range are counted, not mapped.
  void add(const mapping::MapPoint& p, bool removed, std::uint8_t robot = 0);
  // add() for every point of a released scan in order (removed[i]: its decision; stored: empty, or one
  // per point, only the points with stored[i] != 0 go in), the voxels' table slots prefetched first so
  // that their cache misses overlap. `robot`: the scan's; `release`: the core's release counter after it.
  void add_all(std::span<const mapping::MapPoint> points, std::span<const std::uint8_t> removed,
               std::span<const std::uint8_t> stored = {}, std::uint8_t robot = 0, std::uint64_t release = 0);

  // Every occupied voxel as teamscan/map voxels (flags 1: every point in it was removed at release).
  // `robots` (if given): the robot of each voxel, in the same order.
  void voxels(std::vector<teamscan_msg_MapVoxel>& out, std::vector<std::uint8_t>* robots = nullptr) const;
  // The voxels changed since the last call or forget_changes(), with their whole counts (a viewer
  // replaces its voxel); then forgets them.
  void changed_voxels(std::vector<teamscan_msg_MapVoxel>& out, std::vector<std::uint8_t>* robots = nullptr);
  void forget_changes();

  [[nodiscard]] std::size_t occupied_voxels() const { return cells_.size(); }
  // Room for `voxels` occupied voxels (and as many changes) without growing (a map built again).
  void reserve(std::size_t voxels) {
    cells_.reserve(voxels);
    changed_.reserve(voxels);
  }
  // The core's release counter when the last scan went in (FusedScan::release; 0: none).
  [[nodiscard]] std::uint64_t release() const { return release_; }
  // A map built again from the model (a rigid follow of the pose graph) shows the core's instant of the
  // map it replaces, at least.
  void advance_release(std::uint64_t release) { release_ = std::max(release_, release); }
  // The packed voxel key (mapping::VoxelMap::pack) of a map-frame point; kOutOfRange beyond the index.
  [[nodiscard]] std::uint64_t key_of(const mapping::MapPoint& p) const;
  static constexpr std::uint64_t kOutOfRange = FlatKeyMap<std::uint32_t>::kEmpty;
  [[nodiscard]] double resolution_m() const { return resolution_m_; }
  [[nodiscard]] std::uint64_t rejected_points() const { return rejected_; }
  [[nodiscard]] std::size_t memory_bytes() const {
    return cells_.memory_bytes() + changed_.capacity() * sizeof(std::uint64_t);
  }

 private:
  struct Cell {
    std::uint32_t hits = 0;
    std::uint16_t kept = 0;     // saturates: only "none kept" is published
    std::uint8_t changed = 0;   // 1: in changed_
    std::uint8_t robot = 0;     // the robot of the voxel's first point
  };
  [[nodiscard]] teamscan_msg_MapVoxel message(std::uint64_t key, const Cell& c) const;
  void add_keyed(std::uint64_t key, bool removed, std::uint8_t robot);

  double resolution_m_;
  double inverse_resolution_;
  FlatKeyMap<Cell> cells_;
  std::vector<std::uint64_t> changed_;  // keys, in the order they changed
  std::uint64_t rejected_ = 0;
  std::uint64_t release_ = 0;
  std::vector<std::uint64_t> batch_keys_;  // add_all's scratch
};

}  // namespace teamscan::station
