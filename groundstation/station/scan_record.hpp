// scans.bin: the ground station's append-only record of every received scan, with its receive time.
//
// File   = header (16 bytes) + records. All integers little-endian.
// Header = "TSSCANS1" (8 bytes) | u32 version = 1 | u32 header_bytes = 16
// Record = u32 magic 0x52534354 ("TCSR") | u32 body_bytes (= 48 + 16*count)
//          | i64 recv_realtime_ns | i64 recv_monotonic_ns                      (ground station clocks)
//          | u32 robot_id | u32 seq | i64 stamp_ns | i32 origin_x_mm | i32 origin_y_mm | i32 origin_z_mm
//          | u16 count | u16 rejected (0: accepted; else the station refused the scan at receipt, the
//            Reject code of sample_validation.hpp: stored raw, never fused)
//          | count x (i32 x_mm | i32 y_mm | i32 z_mm | u16 beam | u16 flags)      (map frame, as received)
//          | u32 crc32 (IEEE 802.3, over magic .. last point)
// Each record is written with a single write(2), so a crash of the process (not of the kernel) never
// leaves half a record; a torn tail after power loss is detected by the CRC and reported, never crashes.
#pragma once

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <span>
#include <string>

#include "common/capacities.hpp"

namespace teamscan::station {

inline constexpr char kScanFileMagic[8] = {'T', 'S', 'S', 'C', 'A', 'N', 'S', '1'};
inline constexpr std::uint32_t kScanFileVersion = 1;
inline constexpr std::size_t kScanFileHeaderBytes = 16;
inline constexpr std::uint32_t kScanRecordMagic = 0x52534354u;  // "TCSR" little-endian
inline constexpr std::size_t kScanRecordFixedBytes = 8 + 48 + 4;  // magic+len, body before points, crc
inline constexpr std::size_t kScanPointBytes = 16;
inline constexpr std::size_t kScanRecordMaxBytes = kScanRecordFixedBytes + kMaxBeams * kScanPointBytes;

struct StoredPoint {
  std::int32_t x_mm = 0;
  std::int32_t y_mm = 0;
  std::int32_t z_mm = 0;
  std::uint16_t beam = 0;
  std::uint16_t flags = 0;
};

struct StoredScan {
  std::int64_t recv_realtime_ns = 0;
  std::int64_t recv_monotonic_ns = 0;
  std::uint32_t robot_id = 0;
  std::uint32_t seq = 0;
  std::int64_t stamp_ns = 0;
  std::int32_t origin_x_mm = 0;
  std::int32_t origin_y_mm = 0;
  std::int32_t origin_z_mm = 0;
  std::uint16_t count = 0;
  std::uint16_t rejected = 0;  // Reject code (sample_validation.hpp); 0 = accepted
  StoredPoint points[kMaxBeams];
};

[[nodiscard]] std::uint32_t crc32_ieee(std::span<const std::uint8_t> bytes, std::uint32_t crc = 0);

// The 16-byte file header.
void encode_scan_file_header(std::uint8_t (&out)[kScanFileHeaderBytes]);

// Encodes one record into `out` (at least kScanRecordMaxBytes); returns its length. count is clamped
// to kMaxBeams.
[[nodiscard]] std::size_t encode_scan_record(const StoredScan& scan, std::span<std::uint8_t> out);

struct ScanDecodeStats {
  std::uint64_t records = 0;
  std::uint64_t bad_crc = 0;
  std::uint64_t bad_length = 0;
  std::uint64_t bytes_skipped = 0;   // while hunting for the next record magic
  bool truncated_tail = false;       // the file ends inside a record
  bool bad_header = false;
};

// Decodes a whole scans.bin image: calls on_scan for every intact record, counts and skips the rest
// (resynchronising on the next magic). Pure: no file, no allocation beyond the caller's callback.
template <class F>
ScanDecodeStats decode_scan_file(std::span<const std::uint8_t> bytes, F&& on_scan);

// Decodes one record at the start of `bytes`. Returns the record length, 0 if more bytes are needed
// (truncated), or -1 if the bytes there are not a valid record.
[[nodiscard]] long decode_scan_record(std::span<const std::uint8_t> bytes, StoredScan& out, ScanDecodeStats& stats);

template <class F>
ScanDecodeStats decode_scan_file(std::span<const std::uint8_t> bytes, F&& on_scan) {
  ScanDecodeStats stats;
  if (bytes.size() < kScanFileHeaderBytes || !std::equal(kScanFileMagic, kScanFileMagic + 8, bytes.begin())) {
    stats.bad_header = true;
    return stats;
  }
  static thread_local StoredScan scan;
  std::size_t pos = kScanFileHeaderBytes;
  while (pos < bytes.size()) {
    const long n = decode_scan_record(bytes.subspan(pos), scan, stats);
    if (n > 0) {
      ++stats.records;
      on_scan(static_cast<const StoredScan&>(scan));
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
