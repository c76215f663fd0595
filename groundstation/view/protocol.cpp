// The view's wire protocol: voxel messages and JSON state (protocol.hpp).
#include "groundstation/view/protocol.hpp"

#include <cstdio>
#include <cstring>

#include <nlohmann/json.hpp>

namespace teamscan::view {
namespace {

constexpr char kMagic[4] = {'T', 'S', 'V', 'X'};

void put_u16(std::string& o, std::uint16_t v) {
  o.push_back(static_cast<char>(v & 0xFF));
  o.push_back(static_cast<char>(v >> 8));
}
void put_u32(std::string& o, std::uint32_t v) {
  for (int i = 0; i < 4; ++i) o.push_back(static_cast<char>((v >> (8 * i)) & 0xFF));
}
std::uint16_t get_u16(const unsigned char* p) { return static_cast<std::uint16_t>(p[0] | (p[1] << 8)); }
std::uint32_t get_u32(const unsigned char* p) {
  return static_cast<std::uint32_t>(p[0]) | (static_cast<std::uint32_t>(p[1]) << 8) |
         (static_cast<std::uint32_t>(p[2]) << 16) | (static_cast<std::uint32_t>(p[3]) << 24);
}

void append_number(std::string& o, const char* format, double v) {
  char b[48];
  const int n = std::snprintf(b, sizeof b, format, v);
  o.append(b, static_cast<std::size_t>(n));
}
void append_u64(std::string& o, std::uint64_t v) { o += std::to_string(v); }

}  // namespace

std::string encode_voxels(const VoxelMessage& m) {
  std::string o;
  o.reserve(kVoxelHeaderBytes + kVoxelBytes * m.voxels.size());
  o.append(kMagic, 4);
  put_u16(o, static_cast<std::uint16_t>(kProtocolVersion));
  put_u16(o, static_cast<std::uint16_t>(m.kind));
  put_u32(o, m.seq);
  put_u32(o, static_cast<std::uint32_t>(m.voxels.size()));
  put_u32(o, m.resolution_mm);
  put_u32(o, m.total_voxels);
  for (const WireVoxel& v : m.voxels) {
    put_u32(o, static_cast<std::uint32_t>(v.x_mm));
    put_u32(o, static_cast<std::uint32_t>(v.y_mm));
    put_u32(o, static_cast<std::uint32_t>(v.z_mm));
    put_u16(o, v.hits);
    o.push_back(static_cast<char>(v.flags));
    o.push_back(static_cast<char>(v.robot));
  }
  return o;
}

Result<VoxelMessage> decode_voxels(std::string_view bytes) {
  if (bytes.size() < kVoxelHeaderBytes) return Error{"view: voxel message shorter than its header"};
  const auto* p = reinterpret_cast<const unsigned char*>(bytes.data());
  if (std::memcmp(p, kMagic, 4) != 0) return Error{"view: voxel message: bad magic"};
  if (get_u16(p + 4) != kProtocolVersion) return Error{"view: voxel message: unknown version"};
  VoxelMessage m;
  const std::uint16_t kind = get_u16(p + 6);
  if (kind != static_cast<std::uint16_t>(VoxelKind::kWholeMap) &&
      kind != static_cast<std::uint16_t>(VoxelKind::kChanged)) {
    return Error{"view: voxel message: unknown kind"};
  }
  m.kind = static_cast<VoxelKind>(kind);
  m.seq = get_u32(p + 8);
  const std::uint32_t count = get_u32(p + 12);
  m.resolution_mm = get_u32(p + 16);
  m.total_voxels = get_u32(p + 20);
  if ((bytes.size() - kVoxelHeaderBytes) != static_cast<std::uint64_t>(count) * kVoxelBytes) {
    return Error{"view: voxel message: length does not match its count"};
  }
  m.voxels.resize(count);
  for (std::uint32_t i = 0; i < count; ++i) {
    const unsigned char* q = p + kVoxelHeaderBytes + static_cast<std::size_t>(i) * kVoxelBytes;
    WireVoxel& v = m.voxels[i];
    v.x_mm = static_cast<std::int32_t>(get_u32(q));
    v.y_mm = static_cast<std::int32_t>(get_u32(q + 4));
    v.z_mm = static_cast<std::int32_t>(get_u32(q + 8));
    v.hits = get_u16(q + 12);
    v.flags = q[14];
    v.robot = q[15];
  }
  return m;
}

std::string json_escape(std::string_view s) {
  // nlohmann-json escapes (quotes, backslash, control characters; invalid UTF-8 replaced by U+FFFD).
  const std::string quoted = nlohmann::json(std::string{s}).dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
  return quoted.substr(1, quoted.size() - 2);
}

std::string encode_error(std::string_view what) {
  return "{\"type\":\"error\",\"error\":\"" + json_escape(what) + "\"}";
}

std::string encode_state(const StateHeader& h, std::span<const RobotView> robots, bool include_tracks) {
  std::string o;
  o.reserve(256 + robots.size() * 320);
  o += "{\"type\":\"state\",\"whole\":";
  o += h.whole ? "true" : "false";
  o += ",\"seq\":";
  append_u64(o, h.seq);
  o += ",\"stamp_ns\":";
  o += std::to_string(h.stamp_ns);
  o += ",\"map_voxels\":";
  append_u64(o, h.map_voxels);
  o += ",\"map_release\":";
  append_u64(o, h.map_release);
  o += ",\"resolution_m\":";
  append_number(o, "%.3f", h.map_resolution_mm * 1e-3);
  o += ",\"robots\":[";
  bool first = true;
  for (const RobotView& r : robots) {
    const RobotState& s = r.state;
    if (!first) o.push_back(',');
    first = false;
    o += "{\"id\":";
    append_u64(o, s.robot_id);
    o += ",\"lost\":";
    o += s.lost ? "true" : "false";
    o += ",\"x_m\":";
    append_number(o, "%.4f", s.x_m);
    o += ",\"y_m\":";
    append_number(o, "%.4f", s.y_m);
    o += ",\"yaw_rad\":";
    append_number(o, "%.4f", s.yaw_rad);
    o += ",\"cov_xx_m2\":";
    append_number(o, "%.6g", s.cov_xx_m2);
    o += ",\"cov_xy_m2\":";
    append_number(o, "%.6g", s.cov_xy_m2);
    o += ",\"cov_yy_m2\":";
    append_number(o, "%.6g", s.cov_yy_m2);
    o += ",\"scans\":";
    append_u64(o, s.scans);
    o += ",\"scan_rate_hz\":";
    append_number(o, "%.1f", r.scan_rate_hz);
    o += ",\"scans_lost\":";
    append_u64(o, s.scans_lost);
    o += ",\"latency_ms\":";
    append_number(o, "%.1f", s.latency_ms);
    o += ",\"ghosts_removed\":";
    append_u64(o, s.ghosts_removed);
    o += ",\"shadow_s\":";
    append_number(o, "%.1f", s.shadow_s);
    o += ",\"scans_buffered\":";
    append_u64(o, s.scans_buffered);
    o += ",\"backfill_pct\":";
    append_number(o, "%.1f", s.backfill_pct);
    o += ",\"last_shadow_s\":";
    append_number(o, "%.1f", s.last_shadow_s);
    o += ",\"whole_again_ns\":";
    o += std::to_string(s.whole_again_ns);
    if (include_tracks) {
      o += r.track_whole ? ",\"track\":[" : ",\"track_add\":[";
      for (std::size_t i = 0; i < r.track_xy.size(); ++i) {
        if (i) o.push_back(',');
        append_number(o, "%.3f", static_cast<double>(r.track_xy[i]));
      }
      o.push_back(']');
    }
    o.push_back('}');
  }
  o += "]}";
  return o;
}

}  // namespace teamscan::view
