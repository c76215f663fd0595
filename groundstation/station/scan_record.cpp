// scans.bin record encoding and decoding (format in scan_record.hpp).
#include "groundstation/station/scan_record.hpp"

#include <algorithm>
#include <array>
#include <cstring>

#include "common/point_flags.hpp"
#include "common/scan_points.hpp"
#include "common/units.hpp"

namespace teamscan::station {
namespace {

constexpr std::array<std::uint32_t, 256> make_crc_table() {
  std::array<std::uint32_t, 256> t{};
  for (std::uint32_t i = 0; i < 256; ++i) {
    std::uint32_t c = i;
    for (int k = 0; k < 8; ++k) c = (c & 1u) ? (0xEDB88320u ^ (c >> 1)) : (c >> 1);
    t[i] = c;
  }
  return t;
}
constexpr auto kCrcTable = make_crc_table();

// Body bytes before the points (format in scan_record.hpp): version 2, and version 1 (no corr_*).
constexpr std::uint32_t kBodyBeforePoints = 64;
constexpr std::uint32_t kBodyBeforePointsV1 = 48;
static_assert(kScanRecordFixedBytes == 8 + kBodyBeforePoints + 4);

class Writer {
 public:
  explicit Writer(std::uint8_t* p) : p_{p} {}
  void u16(std::uint16_t v) { for (int i = 0; i < 2; ++i) *p_++ = static_cast<std::uint8_t>(v >> (8 * i)); }
  void u32(std::uint32_t v) { for (int i = 0; i < 4; ++i) *p_++ = static_cast<std::uint8_t>(v >> (8 * i)); }
  void u64(std::uint64_t v) { for (int i = 0; i < 8; ++i) *p_++ = static_cast<std::uint8_t>(v >> (8 * i)); }
  void i32(std::int32_t v) { u32(static_cast<std::uint32_t>(v)); }
  void i64(std::int64_t v) { u64(static_cast<std::uint64_t>(v)); }
  [[nodiscard]] std::uint8_t* at() const { return p_; }

 private:
  std::uint8_t* p_;
};

class Reader {
 public:
  explicit Reader(const std::uint8_t* p) : p_{p} {}
  std::uint16_t u16() { std::uint16_t v = 0; for (int i = 0; i < 2; ++i) v = static_cast<std::uint16_t>(v | (p_[i] << (8 * i))); p_ += 2; return v; }
  std::uint32_t u32() { std::uint32_t v = 0; for (int i = 0; i < 4; ++i) v |= static_cast<std::uint32_t>(p_[i]) << (8 * i); p_ += 4; return v; }
  std::uint64_t u64() { std::uint64_t v = 0; for (int i = 0; i < 8; ++i) v |= static_cast<std::uint64_t>(p_[i]) << (8 * i); p_ += 8; return v; }
  std::int32_t i32() { return static_cast<std::int32_t>(u32()); }
  std::int64_t i64() { return static_cast<std::int64_t>(u64()); }

 private:
  const std::uint8_t* p_;
};

}  // namespace

std::uint32_t crc32_ieee(std::span<const std::uint8_t> bytes, std::uint32_t crc) {
  crc = ~crc;
  for (const std::uint8_t b : bytes) crc = kCrcTable[(crc ^ b) & 0xFFu] ^ (crc >> 8);
  return ~crc;
}

void encode_scan_file_header(std::uint8_t (&out)[kScanFileHeaderBytes]) {
  std::memcpy(out, kScanFileMagic, 8);
  Writer w(out + 8);
  w.u32(kScanFileVersion);
  w.u32(static_cast<std::uint32_t>(kScanFileHeaderBytes));
}

std::uint32_t scan_file_version(std::span<const std::uint8_t> header) {
  if (header.size() < kScanFileHeaderBytes || !std::equal(kScanFileMagic, kScanFileMagic + 8, header.begin())) return 0;
  return Reader(header.data() + 8).u32();
}

void undo_applied_correction(ScanPoints& scan) {
  if (scan.applied.none()) return;
  const Pose2 odom_from_map = scan.applied.map_from_odom().inverse();
  const auto move = [&](std::int32_t& x_mm, std::int32_t& y_mm) {
    const Vec2 p = odom_from_map.apply(Vec2{x_mm * 1e-3, y_mm * 1e-3});
    x_mm = to_mm(p.x);
    y_mm = to_mm(p.y);
  };
  move(scan.origin_x_mm, scan.origin_y_mm);
  const std::uint16_t n = std::min<std::uint16_t>(scan.count, static_cast<std::uint16_t>(kMaxBeams));
  for (std::uint16_t i = 0; i < n; ++i) {
    ScanPoint& p = scan.points[i];
    // A beam without an echo (invalid, dazzled) sits at the laser's centre: it moves with the origin.
    if ((p.flags & kPointNoPose) == 0) move(p.x_mm, p.y_mm);
  }
}

std::size_t encode_scan_record(const ScanPoints& scan, const Receipt& receipt, std::span<std::uint8_t> out) {
  const std::uint16_t count = std::min<std::uint16_t>(scan.count, static_cast<std::uint16_t>(kMaxBeams));
  const std::size_t total = kScanRecordFixedBytes + count * kScanPointBytes;
  if (out.size() < total) return 0;
  Writer w(out.data());
  w.u32(kScanRecordMagic);
  w.u32(static_cast<std::uint32_t>(kBodyBeforePoints + count * kScanPointBytes));
  w.i64(receipt.recv_realtime_ns);
  w.i64(receipt.recv_monotonic_ns);
  w.u32(scan.robot_id);
  w.u32(scan.seq);
  w.i64(scan.stamp.ns());
  w.i32(scan.origin_x_mm);
  w.i32(scan.origin_y_mm);
  w.i32(scan.origin_z_mm);
  w.i32(scan.applied.x_mm);
  w.i32(scan.applied.y_mm);
  w.i32(scan.applied.yaw_urad);
  w.u32(scan.applied.seq);
  w.u16(count);
  w.u16(receipt.rejected);
  for (std::uint16_t i = 0; i < count; ++i) {
    w.i32(scan.points[i].x_mm);
    w.i32(scan.points[i].y_mm);
    w.i32(scan.points[i].z_mm);
    w.u16(scan.points[i].beam);
    w.u16(scan.points[i].flags);
  }
  const std::size_t crc_at = total - 4;
  const std::uint32_t crc = crc32_ieee(out.first(crc_at));
  Writer(out.data() + crc_at).u32(crc);
  return total;
}

long decode_scan_record(std::span<const std::uint8_t> bytes, ScanPoints& out, Receipt& receipt,
                        ScanDecodeStats& stats, std::uint32_t version) {
  if (bytes.size() < 8) return 0;
  Reader h(bytes.data());
  if (h.u32() != kScanRecordMagic) return -1;
  const std::uint32_t body = h.u32();
  const std::uint32_t fixed = version == 1 ? kBodyBeforePointsV1 : kBodyBeforePoints;
  if (body < fixed || (body - fixed) % kScanPointBytes != 0 || (body - fixed) / kScanPointBytes > kMaxBeams) {
    ++stats.bad_length;
    return -1;
  }
  const std::size_t total = 8 + body + 4;
  if (bytes.size() < total) return 0;
  Reader c(bytes.data() + 8 + body);
  if (c.u32() != crc32_ieee(bytes.first(8 + body))) {
    ++stats.bad_crc;
    return -1;
  }
  Reader r(bytes.data() + 8);
  receipt.recv_realtime_ns = r.i64();
  receipt.recv_monotonic_ns = r.i64();
  out.robot_id = r.u32();
  out.seq = r.u32();
  out.stamp = Time::from_ns(r.i64());
  out.origin_x_mm = r.i32();
  out.origin_y_mm = r.i32();
  out.origin_z_mm = r.i32();
  out.applied = OdomCorrection{};
  if (version != 1) {
    out.applied.x_mm = r.i32();
    out.applied.y_mm = r.i32();
    out.applied.yaw_urad = r.i32();
    out.applied.seq = r.u32();
  }
  out.count = r.u16();
  receipt.rejected = r.u16();
  if (out.count != (body - fixed) / kScanPointBytes) {
    ++stats.bad_length;
    return -1;
  }
  for (std::uint16_t i = 0; i < out.count; ++i) {
    out.points[i].x_mm = r.i32();
    out.points[i].y_mm = r.i32();
    out.points[i].z_mm = r.i32();
    out.points[i].beam = r.u16();
    out.points[i].flags = r.u16();
  }
  // Not in the record: the projection's result.
  out.map_from_robot = Pose2{};
  out.pose_ok = false;
  out.unplaced = 0;
  return static_cast<long>(total);
}

}  // namespace teamscan::station
