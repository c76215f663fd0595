// Fuzz target of the ring's record decoder (onboard/ring/record.hpp): whatever bytes a slot holds after a
// power cut, check_record names them or accepts them, never reads outside the slot; an accepted record
// decodes into a message within its capacities and encodes back to the same bytes.
#include <array>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <span>

#include "onboard/ring/record.hpp"

using namespace teamscan::onboard::ring;

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::span<const std::uint8_t> slot(data, size);
  RecordHeader h;
  const RecordError e = check_record(slot, h);
  if (e != RecordError::kNone) {
    if (record_error_name(e)[0] == '?') __builtin_trap();
    return 0;
  }
  static std::array<std::uint8_t, kSlotBytes> again{};
  std::size_t n = 0;
  if (h.kind == RecordKind::kScan) {
    static teamscan::ScanPoints scan;
    decode_scan_payload(slot, h, scan);
    if (scan.count > teamscan::kMaxBeams) __builtin_trap();
    n = encode_scan_record(scan, h.ring_seq, again);
  } else if (h.kind == RecordKind::kPose) {
    teamscan::onboard::OnboardPose pose;
    decode_pose_payload(slot, h, pose);
    n = encode_pose_record(pose, h.ring_seq, again);
  } else {
    __builtin_trap();  // check_record accepts scans and poses only
  }
  // Encoding what was decoded gives the record's bytes again, but for the scan's two padding bytes
  // (payload 38..39, written as zero) and therefore the CRC.
  if (n != kHeaderBytes + h.payload_bytes) __builtin_trap();
  if (h.kind == RecordKind::kScan) {
    if (std::memcmp(again.data(), data, kHeaderBytes - 4) != 0) __builtin_trap();
    if (std::memcmp(again.data() + kHeaderBytes, data + kHeaderBytes, 38) != 0) __builtin_trap();
    if (std::memcmp(again.data() + kHeaderBytes + 40, data + kHeaderBytes + 40, n - kHeaderBytes - 40) != 0)
      __builtin_trap();
  } else if (std::memcmp(again.data(), data, n) != 0) {
    __builtin_trap();
  }
  return 0;
}
