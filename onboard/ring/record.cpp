// The ring's record codec (record.hpp).
#include "onboard/ring/record.hpp"

#include <array>
#include <bit>
#include <cstring>

#if defined(__x86_64__)
#include <cpuid.h>
#endif

namespace teamscan::onboard::ring {

static_assert(std::endian::native == std::endian::little,
              "the ring file is little-endian; this codec copies host words");
static_assert(sizeof(ScanPoint) == kPointBytes, "ScanPoint is the record's 16-byte point, copied as is");

namespace {

using Table = std::array<std::array<std::uint32_t, 256>, 8>;

constexpr Table make_table() {
  Table t{};
  for (std::uint32_t i = 0; i < 256; ++i) {
    std::uint32_t c = i;
    for (int k = 0; k < 8; ++k) c = (c & 1u) != 0 ? (c >> 1) ^ 0x82F63B78u : c >> 1;
    t[0][i] = c;
  }
  for (std::size_t s = 1; s < 8; ++s)
    for (std::size_t i = 0; i < 256; ++i) t[s][i] = (t[s - 1][i] >> 8) ^ t[0][t[s - 1][i] & 0xFFu];
  return t;
}
constexpr Table kTable = make_table();

std::uint32_t crc32c_soft(const std::uint8_t* p, std::size_t n, std::uint32_t c) {
  while (n >= 8) {
    std::uint64_t w;
    std::memcpy(&w, p, 8);
    w ^= c;
    c = kTable[7][w & 0xFF] ^ kTable[6][(w >> 8) & 0xFF] ^ kTable[5][(w >> 16) & 0xFF] ^ kTable[4][(w >> 24) & 0xFF] ^
        kTable[3][(w >> 32) & 0xFF] ^ kTable[2][(w >> 40) & 0xFF] ^ kTable[1][(w >> 48) & 0xFF] ^ kTable[0][w >> 56];
    p += 8;
    n -= 8;
  }
  while (n-- > 0) c = (c >> 8) ^ kTable[0][(c ^ *p++) & 0xFFu];
  return c;
}

#if defined(__x86_64__)
__attribute__((target("sse4.2"))) std::uint32_t crc32c_hw(const std::uint8_t* p, std::size_t n, std::uint32_t c) {
  std::uint64_t c64 = c;
  while (n >= 8) {
    std::uint64_t w;
    std::memcpy(&w, p, 8);
    c64 = __builtin_ia32_crc32di(c64, w);
    p += 8;
    n -= 8;
  }
  auto c32 = static_cast<std::uint32_t>(c64);
  while (n-- > 0) c32 = __builtin_ia32_crc32qi(c32, *p++);
  return c32;
}

bool cpu_has_sse42() {
  unsigned a = 0, b = 0, c = 0, d = 0;
  if (__get_cpuid(1, &a, &b, &c, &d) == 0) return false;
  return (c & bit_SSE4_2) != 0;
}
// Decided once, at start-up (static initialisation), never on the data path.
const bool kHardwareCrc = cpu_has_sse42();
#endif

void put_u16(std::uint8_t* p, std::uint16_t v) { std::memcpy(p, &v, 2); }
void put_u32(std::uint8_t* p, std::uint32_t v) { std::memcpy(p, &v, 4); }
void put_i32(std::uint8_t* p, std::int32_t v) { std::memcpy(p, &v, 4); }
void put_u64(std::uint8_t* p, std::uint64_t v) { std::memcpy(p, &v, 8); }
void put_i64(std::uint8_t* p, std::int64_t v) { std::memcpy(p, &v, 8); }
template <class T>
T get(const std::uint8_t* p) {
  T v;
  std::memcpy(&v, p, sizeof v);
  return v;
}

void put_header(std::uint8_t* p, RecordKind kind, std::uint64_t ring_seq, std::uint32_t payload_bytes,
                std::uint32_t robot_id, std::uint32_t seq) {
  put_u32(p + 0, kRecordMagic);
  put_u16(p + 4, kRecordVersion);
  put_u16(p + 6, static_cast<std::uint16_t>(kind));
  put_u64(p + 8, ring_seq);
  put_u32(p + 16, payload_bytes);
  put_u32(p + 20, robot_id);
  put_u32(p + 24, seq);
}

std::uint32_t record_crc(const std::uint8_t* p, std::size_t payload_bytes) {
  const std::uint32_t head = crc32c(std::span<const std::uint8_t>(p, 28));
  return crc32c(std::span<const std::uint8_t>(p + kHeaderBytes, payload_bytes), head);
}

}  // namespace

const char* record_error_name(RecordError e) {
  switch (e) {
    case RecordError::kNone:
      return "ok";
    case RecordError::kEmpty:
      return "empty";
    case RecordError::kShort:
      return "short";
    case RecordError::kMagic:
      return "magic";
    case RecordError::kVersion:
      return "version";
    case RecordError::kKind:
      return "kind";
    case RecordError::kLength:
      return "length";
    case RecordError::kCount:
      return "count";
    case RecordError::kCrc:
      return "crc";
  }
  return "?";
}

std::uint32_t crc32c(std::span<const std::uint8_t> bytes, std::uint32_t crc) {
  const std::uint32_t c = ~crc;
#if defined(__x86_64__)
  if (kHardwareCrc) return ~crc32c_hw(bytes.data(), bytes.size(), c);
#endif
  return ~crc32c_soft(bytes.data(), bytes.size(), c);
}

std::size_t encode_scan_record(const ScanPoints& scan, std::uint64_t ring_seq, std::span<std::uint8_t> slot) {
  if (scan.count > kMaxBeams) return 0;
  const std::size_t payload = kScanFixedBytes + scan.count * kPointBytes;
  if (slot.size() < kHeaderBytes + payload) return 0;
  std::uint8_t* p = slot.data();
  put_header(p, RecordKind::kScan, ring_seq, static_cast<std::uint32_t>(payload), scan.robot_id, scan.seq);
  std::uint8_t* q = p + kHeaderBytes;
  put_i64(q + 0, scan.stamp.ns());
  put_i32(q + 8, scan.origin_x_mm);
  put_i32(q + 12, scan.origin_y_mm);
  put_i32(q + 16, scan.origin_z_mm);
  put_i32(q + 20, scan.applied.x_mm);
  put_i32(q + 24, scan.applied.y_mm);
  put_i32(q + 28, scan.applied.yaw_urad);
  put_u32(q + 32, scan.applied.seq);
  put_u16(q + 36, scan.count);
  put_u16(q + 38, 0);
  if (scan.count > 0) std::memcpy(q + kScanFixedBytes, scan.points.data(), scan.count * kPointBytes);
  put_u32(p + 28, record_crc(p, payload));
  return kHeaderBytes + payload;
}

std::size_t encode_pose_record(const OnboardPose& pose, std::uint64_t ring_seq, std::span<std::uint8_t> slot) {
  if (slot.size() < kHeaderBytes + kPosePayloadBytes) return 0;
  std::uint8_t* p = slot.data();
  put_header(p, RecordKind::kPose, ring_seq, static_cast<std::uint32_t>(kPosePayloadBytes), pose.robot_id, pose.seq);
  std::uint8_t* q = p + kHeaderBytes;
  put_i64(q + 0, pose.stamp_ns);
  put_i32(q + 8, pose.x_mm);
  put_i32(q + 12, pose.y_mm);
  put_i32(q + 16, pose.yaw_urad);
  put_i32(q + 20, pose.vx_mmps);
  put_i32(q + 24, pose.vy_mmps);
  put_i32(q + 28, pose.yaw_rate_mradps);
  put_u32(p + 28, record_crc(p, kPosePayloadBytes));
  return kHeaderBytes + kPosePayloadBytes;
}

RecordError check_record(std::span<const std::uint8_t> slot, RecordHeader& header) {
  if (slot.size() < kHeaderBytes) return RecordError::kShort;
  const std::uint8_t* p = slot.data();
  const auto magic = get<std::uint32_t>(p);
  if (magic != kRecordMagic) {
    bool zero = true;
    for (std::size_t i = 0; i < kHeaderBytes && zero; ++i) zero = p[i] == 0;
    return zero ? RecordError::kEmpty : RecordError::kMagic;
  }
  if (get<std::uint16_t>(p + 4) != kRecordVersion) return RecordError::kVersion;
  const auto kind = get<std::uint16_t>(p + 6);
  const auto payload = get<std::uint32_t>(p + 16);
  const std::size_t room = slot.size() - kHeaderBytes;
  if (kind == static_cast<std::uint16_t>(RecordKind::kScan)) {
    if (payload < kScanFixedBytes || payload > kScanPayloadMaxBytes || payload > room) return RecordError::kLength;
    const auto count = get<std::uint16_t>(p + kHeaderBytes + 36);
    if (count > kMaxBeams || kScanFixedBytes + std::size_t{count} * kPointBytes != payload) return RecordError::kCount;
  } else if (kind == static_cast<std::uint16_t>(RecordKind::kPose)) {
    if (payload != kPosePayloadBytes || payload > room) return RecordError::kLength;
  } else {
    return RecordError::kKind;
  }
  if (get<std::uint32_t>(p + 28) != record_crc(p, payload)) return RecordError::kCrc;
  header.kind = static_cast<RecordKind>(kind);
  header.ring_seq = get<std::uint64_t>(p + 8);
  header.payload_bytes = payload;
  header.robot_id = get<std::uint32_t>(p + 20);
  header.seq = get<std::uint32_t>(p + 24);
  return RecordError::kNone;
}

void decode_scan_payload(std::span<const std::uint8_t> slot, const RecordHeader& header, ScanPoints& out) {
  const std::uint8_t* q = slot.data() + kHeaderBytes;
  out.robot_id = header.robot_id;
  out.seq = header.seq;
  out.stamp = Time::from_ns(get<std::int64_t>(q + 0));
  out.origin_x_mm = get<std::int32_t>(q + 8);
  out.origin_y_mm = get<std::int32_t>(q + 12);
  out.origin_z_mm = get<std::int32_t>(q + 16);
  out.applied = OdomCorrection{get<std::int32_t>(q + 20), get<std::int32_t>(q + 24), get<std::int32_t>(q + 28),
                               get<std::uint32_t>(q + 32)};
  const auto count = get<std::uint16_t>(q + 36);  // checked by check_record: <= kMaxBeams
  out.count = count;
  if (count > 0) std::memcpy(out.points.data(), q + kScanFixedBytes, std::size_t{count} * kPointBytes);
  out.pose_ok = false;
  out.unplaced = 0;
}

void decode_pose_payload(std::span<const std::uint8_t> slot, const RecordHeader& header, OnboardPose& out) {
  const std::uint8_t* q = slot.data() + kHeaderBytes;
  out.robot_id = header.robot_id;
  out.seq = header.seq;
  out.stamp_ns = get<std::int64_t>(q + 0);
  out.x_mm = get<std::int32_t>(q + 8);
  out.y_mm = get<std::int32_t>(q + 12);
  out.yaw_urad = get<std::int32_t>(q + 16);
  out.vx_mmps = get<std::int32_t>(q + 20);
  out.vy_mmps = get<std::int32_t>(q + 24);
  out.yaw_rate_mradps = get<std::int32_t>(q + 28);
}

}  // namespace teamscan::onboard::ring
