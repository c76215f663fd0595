// The view's wire protocol: voxel messages and JSON state (protocol.hpp).
#include "groundstation/view/protocol.hpp"

#include <cmath>
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

// A figure for the page, to the given fraction (1e4: 0.1 mm in metres): shorter messages, the same
// figures the page shows. Not a number stays one (written as null).
double rounded(double v, double per_unit) { return std::isfinite(v) ? std::round(v * per_unit) / per_unit : v; }

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
  const nlohmann::json j{{"type", "error"}, {"error", std::string{what}}};
  return j.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
}

std::string encode_state(const StateHeader& h, std::span<const RobotView> robots, bool include_tracks) {
  nlohmann::json rs = nlohmann::json::array();
  for (const RobotView& r : robots) {
    const RobotState& s = r.state;
    nlohmann::json o{{"id", s.robot_id},
                     {"lost", s.lost},
                     {"x_m", rounded(s.x_m, 1e4)},
                     {"y_m", rounded(s.y_m, 1e4)},
                     {"yaw_rad", rounded(s.yaw_rad, 1e4)},
                     {"cov_xx_m2", s.cov_xx_m2},
                     {"cov_xy_m2", s.cov_xy_m2},
                     {"cov_yy_m2", s.cov_yy_m2},
                     {"scans", s.scans},
                     {"scan_rate_hz", rounded(r.scan_rate_hz, 10)},
                     {"scans_lost", s.scans_lost},
                     {"latency_ms", rounded(s.latency_ms, 10)},
                     {"ghosts_removed", s.ghosts_removed},
                     {"shadow_s", rounded(s.shadow_s, 10)},
                     {"scans_buffered", s.scans_buffered},
                     {"backfill_pct", rounded(s.backfill_pct, 10)},
                     {"last_shadow_s", rounded(s.last_shadow_s, 10)},
                     {"whole_again_ns", s.whole_again_ns}};
    if (include_tracks) {
      nlohmann::json track = nlohmann::json::array();
      for (const float v : r.track_xy) track.push_back(rounded(static_cast<double>(v), 1e3));
      o[r.track_whole ? "track" : "track_add"] = std::move(track);
    }
    rs.push_back(std::move(o));
  }
  const nlohmann::json j{{"type", "state"},
                         {"whole", h.whole},
                         {"seq", h.seq},
                         {"stamp_ns", h.stamp_ns},
                         {"map_voxels", h.map_voxels},
                         {"map_release", h.map_release},
                         {"resolution_m", rounded(h.map_resolution_mm * 1e-3, 1e3)},
                         {"robots", std::move(rs)}};
  return j.dump();  // a value that is not a number (a NaN latency) is written as null
}

}  // namespace teamscan::view
