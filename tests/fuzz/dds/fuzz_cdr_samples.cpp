// Fuzz target: random CDR for each teamscan type through the receive path of the station and of the
// onboard daemon. As Cyclone does for a received sample: the encapsulation header picks the
// byte order, dds_stream_normalize_data checks (and byte-swaps) the bytes against the type's ops from
// the idlc-generated descriptor, and only a sample that passes is read with dds_stream_read. Then the
// station's SampleValidator (pose, scan, status), its stored form (stored_from: the robot's applied
// correction undone) and scans.bin encoding, and the daemon's decode_team + check_team and its own
// correction's step check (team), and its decode_stored into its ring's confirmations and back-fill (stored).
// The map is read and freed (its bounded sequence allocates).
#include <cstdint>
#include <cstring>
#include <memory>
#include <vector>

#include <dds/ddsi/ddsi_cdrstream.h>
#include <dds/ddsi/q_protocol.h>

#include "groundstation/station/sample_validation.hpp"
#include "groundstation/station/scan_record.hpp"
#include "groundstation/station/station.hpp"
#include "onboard/core/team_validation.hpp"
#include "onboard/bridge/bridge.hpp"
#include "onboard/ring/ring_index.hpp"
#include "tests/fuzz/dds/cdr_input.hpp"

namespace {

using namespace teamscan;

union Sample {
  teamscan_msg_RobotPose pose;
  teamscan_msg_ScanPoints scan;
  teamscan_msg_RobotStatus status;
  teamscan_msg_TeamState team;
  teamscan_msg_MapUpdate map;
  teamscan_msg_StoredState stored;
};

bool host_little_endian() {
  const std::uint16_t one = 1;
  std::uint8_t b = 0;
  std::memcpy(&b, &one, 1);
  return b == 1;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size < 5 || size > (1u << 24)) return 0;
  const int type = data[0] % fuzz::kCdrTypes;
  if (data[1] != 0 || data[2] > 1) return 0;  // CDR_BE / CDR_LE (XCDR1) only, as the types are @final
  const bool little = data[2] == 1;
  const auto n = static_cast<std::uint32_t>(size - 5);
  static std::vector<std::uint64_t> aligned;  // 8-byte aligned copy: normalisation swaps in place
  aligned.assign(n / 8 + 1, 0);
  auto* buf = reinterpret_cast<char*>(aligned.data());
  if (n > 0) std::memcpy(buf, data + 5, n);
  const dds_topic_descriptor_t& desc = fuzz::cdr_descriptor(type);
  std::uint32_t off = 0;
  if (dds_stream_normalize_data(buf, &off, n, little != host_little_endian(), CDR_ENC_VERSION_1, desc.m_ops) == nullptr) {
    return 0;  // refused by Cyclone before any reader sees it
  }
  static Sample sample;
  std::memset(&sample, 0, sizeof sample);
  dds_istream_t is;
  dds_istream_init(&is, n, buf, CDR_ENC_VERSION_1);
  (void)dds_stream_read(&is, reinterpret_cast<char*>(&sample), desc.m_ops);
  dds_istream_fini(&is);

  static station::SampleValidator validator;
  const Time received = Time::from_ns(1'800'000'000'000'000'000);
  switch (type) {
    case 0:
      (void)validator.check_pose(sample.pose, received);
      (void)validator.check_backfill_pose(sample.pose, received);
      break;
    case 1: {
      const station::Verdict verdict = validator.check_scan(sample.scan, received);
      // The station stores every scan, whatever its count (the record clamps to MAX_BEAMS): an accepted
      // one with the robot's applied correction undone, a refused one raw.
      static ScanPoints stored;
      station::Receipt receipt = station::stored_from(sample.scan, station::ReceiveTime{received, received}, verdict.reason, stored);
      static std::uint8_t record[station::kScanRecordMaxBytes];
      const std::size_t len = station::encode_scan_record(stored, receipt, record);
      station::ScanDecodeStats stats;
      if (len == 0 || station::decode_scan_record(std::span<const std::uint8_t>(record, len), stored, receipt, stats) <= 0) {
        __builtin_trap();  // a record the station wrote must read back
      }
      break;
    }
    case 2: (void)validator.check_status(sample.status, received); break;
    case 3: {
      static onboard::TeamSnapshot snapshot;
      if (onboard::decode_team(sample.team, snapshot)) {
        if (onboard::check_team(snapshot, received, onboard::TeamCheckLimits{}).ok() && snapshot.count > 0) {
          (void)onboard::correction_step_ok(OdomCorrection{}, snapshot.members[0].correction, onboard::TeamCheckLimits{});
        }
      }
      break;
    }
    case 4: dds_stream_free_sample(&sample.map, desc.m_ops); break;
    default: {
      // The robot's side of store and forward: the station's confirmations into its ring's index (robot 3,
      // scans and poses 1..100 written).
      static std::unique_ptr<onboard::ring::RingIndex> index = [] {
        onboard::ring::RingIndexOptions o;
        o.slots = 256;
        o.robot_id = 3;
        auto r = std::move(onboard::ring::RingIndex::create(o).value());
        for (std::uint32_t s = 1; s <= 100; ++s) {
          r->written(onboard::ring::RecordKind::kScan, s, true);
          r->written(onboard::ring::RecordKind::kPose, s, true);
        }
        return r;
      }();
      static onboard::StoredSnapshot snapshot;
      if (onboard::decode_stored(sample.stored, snapshot)) {
        for (std::uint32_t i = 0; i < snapshot.count; ++i) {
          const onboard::RobotStoredState& r = snapshot.robots[i];
          (void)index->on_confirmation(r.robot_id, r.contiguous_seq, received, true, r.pose_contiguous_seq);
        }
        index->start_turn(received);
        std::uint64_t slot = 0;
        std::uint32_t seq = 0;
        while (index->next_backfill(received, slot, seq)) {
        }
        while (index->next_backfill_pose(received, slot, seq)) {
        }
      }
      break;
    }
  }
  return 0;
}
