// The live map the station publishes (teamscan/map, the browser view, ROS 2 map_cloud): per voxel of
// the map resolution the points fused and the points kept at release, and the voxels changed since the
// last publication. One table and one hash lookup per point (it used to be three voxel maps: all
// points, kept points, changed voxels, the last freed and regrown at every publication).
#pragma once

#include <cstdint>
#include <span>
#include <vector>

#include "groundstation/mapping/flat_key_map.hpp"
#include "groundstation/mapping/voxel_map.hpp"
#include "teamscan.h"

namespace teamscan::station {

class LiveMap {
 public:
  explicit LiveMap(double resolution_m);

  // One fused point and its decision at release. Points beyond the index range are counted, not mapped.
  void add(const mapping::MapPoint& p, bool removed);
  // add() for every point of a released scan in order (removed[i]: its decision), the voxels' table
  // slots prefetched first so that their cache misses overlap.
  void add_all(std::span<const mapping::MapPoint> points, std::span<const std::uint8_t> removed);

  // Every occupied voxel as teamscan/map voxels (flags 1: every point in it was removed at release).
  void voxels(std::vector<teamscan_msg_MapVoxel>& out) const;
  // The voxels changed since the last call or forget_changes(), with their whole counts (a viewer
  // replaces its voxel); then forgets them.
  void changed_voxels(std::vector<teamscan_msg_MapVoxel>& out);
  void forget_changes();

  [[nodiscard]] std::size_t occupied_voxels() const { return cells_.size(); }
  [[nodiscard]] double resolution_m() const { return resolution_m_; }
  [[nodiscard]] std::uint64_t rejected_points() const { return rejected_; }
  [[nodiscard]] std::size_t memory_bytes() const {
    return cells_.memory_bytes() + changed_.capacity() * sizeof(std::uint64_t);
  }

 private:
  struct Cell {
    std::uint32_t hits = 0;
    std::uint16_t kept = 0;     // saturates: only "none kept" is published
    std::uint16_t changed = 0;  // 1: in changed_
  };
  [[nodiscard]] teamscan_msg_MapVoxel message(std::uint64_t key, const Cell& c) const;
  static constexpr std::uint64_t kOutOfRange = mapping::FlatKeyMap<Cell>::kEmpty;
  [[nodiscard]] std::uint64_t key_of(const mapping::MapPoint& p) const;
  void add_keyed(std::uint64_t key, bool removed);

  double resolution_m_;
  double inverse_resolution_;
  mapping::FlatKeyMap<Cell> cells_;
  std::vector<std::uint64_t> changed_;  // keys, in the order they changed
  std::uint64_t rejected_ = 0;
  std::vector<std::uint64_t> batch_keys_;  // add_all's scratch
};

}  // namespace teamscan::station
