// The store-and-forward ring's record format (docs/onboard.md "The ring"): every scan and pose the robot
// publishes, as one fixed-size slot of the ring file. Pure codec: byte spans in and out, no file, no clock,
// no allocation; decode validates everything (it reads what a power cut may have torn) and never trusts a
// length it has not checked (tests/fuzz/onboard ring_fuzz_record).
//
// A slot is kSlotBytes (13 sectors of 512 bytes, so a torn write never reaches a neighbouring record):
//   header, 32 bytes, little-endian:
//     0  u32 magic "TSRG"        4  u16 version (1)       6  u16 kind (1 scan, 2 pose)
//     8  u64 ring_seq: the record's number since the ring file was made (its slot is ring_seq % slots)
//    16  u32 payload_bytes       20  u32 robot_id          24  u32 seq (the scan's or the pose's own)
//    28  u32 crc: CRC-32C (Castagnoli) of bytes 0..27 and the payload
//   scan payload: i64 stamp_ns, i32 origin x/y/z mm, i32 corr x/y mm, i32 corr yaw µrad, u32 corr_seq,
//     u16 count, u16 0, then count points of 16 bytes (i32 x/y/z mm, u16 beam, u16 flags)
//   pose payload: i64 stamp_ns, i32 x/y mm, i32 yaw µrad, i32 vx/vy mm/s, i32 yaw rate mrad/s
// The rest of the slot is not written (its bytes are whatever was there).
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>

#include "common/capacities.hpp"
#include "common/scan_points.hpp"
#include "onboard/core/messages.hpp"

namespace teamscan::onboard::ring {

inline constexpr std::uint32_t kRecordMagic = 0x47525354u;  // "TSRG" little-endian
inline constexpr std::uint16_t kRecordVersion = 1;
inline constexpr std::size_t kHeaderBytes = 32;
inline constexpr std::size_t kScanFixedBytes = 40;
inline constexpr std::size_t kPointBytes = 16;
inline constexpr std::size_t kScanPayloadMaxBytes = kScanFixedBytes + kMaxBeams * kPointBytes;
inline constexpr std::size_t kPosePayloadBytes = 32;
inline constexpr std::size_t kSectorBytes = 512;
inline constexpr std::size_t kSlotBytes =
    (kHeaderBytes + kScanPayloadMaxBytes + kSectorBytes - 1) / kSectorBytes * kSectorBytes;
static_assert(kSlotBytes == 6656, "a slot is 13 sectors: docs/onboard.md gives the ring's size from it");

enum class RecordKind : std::uint16_t { kEmpty = 0, kScan = 1, kPose = 2 };

struct RecordHeader {
  RecordKind kind = RecordKind::kEmpty;
  std::uint64_t ring_seq = 0;
  std::uint32_t payload_bytes = 0;
  std::uint32_t robot_id = 0;
  std::uint32_t seq = 0;
};

// Why a slot did not hold a record. kEmpty: never written (its header is all zero bytes); anything else
// is a torn or foreign record (a power cut in the middle of a write, another file).
enum class RecordError : std::uint8_t {
  kNone = 0,
  kEmpty,
  kShort,  // fewer bytes than a header
  kMagic,
  kVersion,
  kKind,
  kLength,  // payload_bytes wrong for the kind, or beyond the slot
  kCount,   // a scan's count above kMaxBeams or not matching payload_bytes
  kCrc,
};
inline constexpr std::size_t kRecordErrors = 9;
[[nodiscard]] const char* record_error_name(RecordError e);

// CRC-32C (reflected polynomial 0x82F63B78, init and final xor 0xFFFFFFFF): "123456789" -> 0xE3069283.
// The SSE 4.2 instruction when the CPU has it, else slicing-by-8 tables.
[[nodiscard]] std::uint32_t crc32c(std::span<const std::uint8_t> bytes, std::uint32_t crc = 0);

// Writes one record into `slot` (at least kHeaderBytes + its payload); returns the bytes written (header
// and payload), 0 if the slot is too small or the scan's count is above kMaxBeams.
std::size_t encode_scan_record(const ScanPoints& scan, std::uint64_t ring_seq, std::span<std::uint8_t> slot);
std::size_t encode_pose_record(const OnboardPose& pose, std::uint64_t ring_seq, std::span<std::uint8_t> slot);

// Checks the header and the CRC of the record at the start of `slot`; kNone fills `header`.
[[nodiscard]] RecordError check_record(std::span<const std::uint8_t> slot, RecordHeader& header);
// The payload of a record check_record accepted (kind scan / pose): into the onboard message.
void decode_scan_payload(std::span<const std::uint8_t> slot, const RecordHeader& header, ScanPoints& out);
void decode_pose_payload(std::span<const std::uint8_t> slot, const RecordHeader& header, OnboardPose& out);

}  // namespace teamscan::onboard::ring
