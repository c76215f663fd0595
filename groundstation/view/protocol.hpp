// The view's wire protocol (docs/view.md "Protocol"): over one WebSocket, binary voxel messages (the
// whole map first, then the changed voxels) and JSON text state messages (every robot's pose, track,
// covariance and state). Pure encoders and a decoder, no I/O.
//
// Voxel message, little-endian, 24-byte header then `count` 16-byte voxels:
//   u32 magic "TSVX" | u16 version 1 | u16 kind (1 whole map, 2 changed voxels) | u32 seq | u32 count |
//   u32 resolution_mm | u32 total_voxels ||  i32 x_mm | i32 y_mm | i32 z_mm | u16 hits | u8 flags
//   (bit 0: removed as a ghost) | u8 robot (the robot whose scan first hit the voxel; 0 unknown)
#pragma once

#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "common/result.hpp"
#include "groundstation/view/snapshot.hpp"

namespace teamscan::view {

inline constexpr std::uint32_t kProtocolVersion = 1;
inline constexpr std::size_t kVoxelHeaderBytes = 24;
inline constexpr std::size_t kVoxelBytes = 16;

enum class VoxelKind : std::uint16_t { kWholeMap = 1, kChanged = 2 };

// A voxel as the view sends it.
struct WireVoxel {
  std::int32_t x_mm = 0;
  std::int32_t y_mm = 0;
  std::int32_t z_mm = 0;
  std::uint16_t hits = 0;
  std::uint8_t flags = 0;  // bit 0: removed
  std::uint8_t robot = 0;
  friend bool operator==(const WireVoxel&, const WireVoxel&) = default;
};

// One message to a client, encoded once and shared by every client's queue.
struct Message {
  bool binary = false;
  std::string bytes;
};
using SharedMessage = std::shared_ptr<const Message>;

struct VoxelMessage {
  VoxelKind kind = VoxelKind::kChanged;
  std::uint32_t seq = 0;
  std::uint32_t resolution_mm = 0;
  std::uint32_t total_voxels = 0;
  std::vector<WireVoxel> voxels;
};

[[nodiscard]] std::string encode_voxels(const VoxelMessage& m);
// Errors name what is wrong (short, bad magic, version, kind, length).
[[nodiscard]] Result<VoxelMessage> decode_voxels(std::string_view bytes);

// A robot in a state message: the station's state plus what the view derives (scan rate, track).
struct RobotView {
  RobotState state;
  double scan_rate_hz = 0.0;
  // Track points (x, y metres, flat) to send: the whole track when `track_whole`, else the points added
  // since the previous state message.
  std::span<const float> track_xy;
  bool track_whole = false;
};

struct StateHeader {
  std::uint64_t seq = 0;
  std::int64_t stamp_ns = 0;
  bool whole = false;  // a whole state (tracks complete), sent first and after a skip
  std::uint32_t map_voxels = 0;
  std::uint32_t map_resolution_mm = 0;
  std::uint64_t map_release = 0;  // the fusion core's release counter of the map (TeamSnapshot)
};

// {"type":"state","whole":..,"seq":..,"stamp_ns":..,"map_voxels":..,"map_release":..,"resolution_m":..,"robots":[{"id":..,
//  "lost":..,"x_m":..,"y_m":..,"yaw_rad":..,"cov_xx_m2":..,"cov_xy_m2":..,"cov_yy_m2":..,"scans":..,
//  "scan_rate_hz":..,"scans_lost":..,"latency_ms":..,"ghosts_removed":..,"shadow_s":..,"scans_buffered":..,
//  "backfill_pct":..,"last_shadow_s":..,"whole_again_ns":..,"track":[x,y,..] | "track_add":[..]}]}
// With include_tracks false (the /api/state endpoint) no track field is written.
[[nodiscard]] std::string encode_state(const StateHeader& h, std::span<const RobotView> robots, bool include_tracks);

// {"type":"error","error":"..."}: the answer to anything a client sends (the view is read-only).
[[nodiscard]] std::string encode_error(std::string_view what);

// A JSON string's contents, escaped by nlohmann-json (quotes, backslash, control characters; invalid
// UTF-8 replaced by U+FFFD), without its quotes.
[[nodiscard]] std::string json_escape(std::string_view s);

}  // namespace teamscan::view
