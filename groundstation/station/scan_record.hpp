// scans.bin: the ground station's append-only record of every received scan, with its receive time.
//
// File   = header (16 bytes) + records. All integers little-endian.
// Header = "TSSCANS1" (8 bytes) | u32 version = 2 | u32 header_bytes = 16
// Record = u32 magic 0x52534354 ("TCSR") | u32 body_bytes (= 64 + 16*count; version 1: 48 + 16*count)
//          | i64 recv_realtime_ns | i64 recv_monotonic_ns            (Receipt: ground station clocks)
//          | u32 robot_id | u32 seq | i64 stamp_ns | i32 origin_x_mm | i32 origin_y_mm | i32 origin_z_mm
//          | i32 corr_x_mm | i32 corr_y_mm | i32 corr_yaw_urad | u32 corr_seq  (version 2 only: the
//            correction the robot applied, ScanPoints::applied; version 1 files read as none)
//          | u16 count | u16 rejected (Receipt: 0 accepted; else the station refused the scan at
//            receipt, the Reject code of sample_validation.hpp: stored raw, never fused)
//          | count x (i32 x_mm | i32 y_mm | i32 z_mm | u16 beam | u16 flags)   (ScanPoints::points)
//          | u32 crc32 (IEEE 802.3, over magic .. last point)
// Frame of origin and points: an accepted scan is stored in the odometry-map frame (the frame of
// teamscan/pose, in which the registration matches): the robot's applied correction is undone at
// receipt (undo_applied_correction) and kept in corr_*; a refused scan is stored as received.
// Each record is written with a single write(2), so a crash of the process (not of the kernel) never
// leaves half a record; a torn tail after power loss is detected by the CRC and reported, never crashes.
#pragma once

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <span>
#include <string>

#include "common/capacities.hpp"
#include "common/odom_correction.hpp"
#include "common/scan_points.hpp"

namespace teamscan::station {

inline constexpr char kScanFileMagic[8] = {'T', 'S', 'S', 'C', 'A', 'N', 'S', '1'};
inline constexpr std::uint32_t kScanFileVersion = 2;  // written; 1 and 2 are read
inline constexpr std::size_t kScanFileHeaderBytes = 16;
inline constexpr std::uint32_t kScanRecordMagic = 0x52534354u;  // "TCSR" little-endian
inline constexpr std::size_t kScanRecordFixedBytes = 8 + 64 + 4;  // magic+len, body before points, crc
inline constexpr std::size_t kScanPointBytes = 16;
inline constexpr std::size_t kScanRecordMaxBytes = kScanRecordFixedBytes + kMaxBeams * kScanPointBytes;

// A record holds a scan as the robot's own ScanPoints (common/scan_points.hpp: the fields the wire
// carries, in the frame above; the projection's map_from_robot, pose_ok and unplaced are not stored and
// read back as none) and, beside it, the station's Receipt.

// The station's receipt of a scan: when it took the sample (its own clocks) and its verdict on it.
struct Receipt {
  std::int64_t recv_realtime_ns = 0;   // CLOCK_REALTIME
  std::int64_t recv_monotonic_ns = 0;  // CLOCK_MONOTONIC
  std::uint16_t rejected = 0;          // Reject code (sample_validation.hpp); 0 = accepted
};

[[nodiscard]] std::uint32_t crc32_ieee(std::span<const std::uint8_t> bytes, std::uint32_t crc = 0);

// The 16-byte file header.
void encode_scan_file_header(std::uint8_t (&out)[kScanFileHeaderBytes]);
// The version of a file header (0 if `header` is not one: too short or the wrong magic).
[[nodiscard]] std::uint32_t scan_file_version(std::span<const std::uint8_t> header);

// Moves the origin and the points (all but kPointNoPose ones, whose coordinates are 0) of a scan by the
// inverse of its applied correction: from the robot's corrected map frame back to the odometry-map
// frame. Rounded to the nearest millimetre, saturated to int32. No-op when none was applied.
void undo_applied_correction(ScanPoints& scan);

// Encodes one record (the scan and its receipt) into `out` (at least kScanRecordMaxBytes); returns its
// length. count is clamped to kMaxBeams.
[[nodiscard]] std::size_t encode_scan_record(const ScanPoints& scan, const Receipt& receipt,
                                             std::span<std::uint8_t> out);

struct ScanDecodeStats {
  std::uint64_t records = 0;
  std::uint64_t bad_crc = 0;
  std::uint64_t bad_length = 0;
  std::uint64_t bytes_skipped = 0;   // while hunting for the next record magic
  bool truncated_tail = false;       // the file ends inside a record
  bool bad_header = false;
};

// Decodes a whole scans.bin image: calls on_scan(const ScanPoints&, const Receipt&) for every intact
// record, counts and skips the rest (resynchronising on the next magic). Pure: no file, no allocation
// beyond the caller's callback.
template <class F>
ScanDecodeStats decode_scan_file(std::span<const std::uint8_t> bytes, F&& on_scan);

// Decodes one record of a file of `version` (1 or 2) at the start of `bytes`. Returns the record length,
// 0 if more bytes are needed (truncated), or -1 if the bytes there are not a valid record. `scan`'s
// fields not in the record (map_from_robot, pose_ok, unplaced) are reset.
[[nodiscard]] long decode_scan_record(std::span<const std::uint8_t> bytes, ScanPoints& scan, Receipt& receipt,
                                      ScanDecodeStats& stats, std::uint32_t version = kScanFileVersion);

template <class F>
ScanDecodeStats decode_scan_file(std::span<const std::uint8_t> bytes, F&& on_scan) {
  ScanDecodeStats stats;
  const std::uint32_t version = scan_file_version(bytes);
  if (version != 1 && version != kScanFileVersion) {
    stats.bad_header = true;
    return stats;
  }
  static thread_local ScanPoints scan;
  Receipt receipt;
  std::size_t pos = kScanFileHeaderBytes;
  while (pos < bytes.size()) {
    const long n = decode_scan_record(bytes.subspan(pos), scan, receipt, stats, version);
    if (n > 0) {
      ++stats.records;
      on_scan(static_cast<const ScanPoints&>(scan), static_cast<const Receipt&>(receipt));
      pos += static_cast<std::size_t>(n);
    } else if (n == 0) {
      stats.truncated_tail = true;
      break;
    } else {
      ++pos;
      ++stats.bytes_skipped;
    }
  }
  return stats;
}

// Reads a scans.bin file from disk; false (with a message) if it cannot be read at all.
template <class F>
bool read_scan_file(const std::string& path, F&& on_scan, ScanDecodeStats& stats, std::string& error);

}  // namespace teamscan::station

#include "groundstation/station/scan_record_read.hpp"
