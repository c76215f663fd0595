// Fuzz target: the scans.bin decoder (groundstation/station/scan_record.hpp) on arbitrary bytes, with
// and without a valid file header. It must never crash, never read out of bounds, and every record it
// accepts must re-encode to the same bytes.
#include <cstdint>
#include <cstring>
#include <vector>

#include "groundstation/station/scan_record.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace teamscan::station;
  std::vector<std::uint8_t> file(kScanFileHeaderBytes);
  std::uint8_t header[kScanFileHeaderBytes];
  encode_scan_file_header(header);
  std::memcpy(file.data(), header, sizeof header);
  if (size > 0) file.insert(file.end(), data, data + size);
  static std::uint8_t again[kScanRecordMaxBytes];
  for (const auto& bytes : {std::span<const std::uint8_t>(file), std::span<const std::uint8_t>(data, size)}) {
    (void)decode_scan_file(bytes, [](const teamscan::ScanPoints& s, const Receipt& receipt) {
      if (s.count > teamscan::kMaxBeams) __builtin_trap();
      const std::size_t n = encode_scan_record(s, receipt, std::span<std::uint8_t>(again, sizeof again));
      if (n != kScanRecordFixedBytes + s.count * kScanPointBytes) __builtin_trap();
    });
  }
  return 0;
}
