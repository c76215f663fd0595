// The fuzz input format of fuzz_cdr_samples and its seed generator: byte 0 selects the teamscan type
// (0 pose, 1 scan, 2 status, 3 team, 4 map, 5 stored; modulo 6), bytes 1..4 are the CDR encapsulation header as on
// the wire (00 00: XCDR1 big-endian, 00 01: XCDR1 little-endian), the rest is the serialised sample.
#pragma once

#include <cstdint>

#include <dds/dds.h>

#include "teamscan.h"

namespace teamscan::fuzz {

inline constexpr int kCdrTypes = 6;

inline const dds_topic_descriptor_t& cdr_descriptor(int type) {
  switch (type % kCdrTypes) {
    case 0: return teamscan_msg_RobotPose_desc;
    case 1: return teamscan_msg_ScanPoints_desc;
    case 2: return teamscan_msg_RobotStatus_desc;
    case 3: return teamscan_msg_TeamState_desc;
    case 4: return teamscan_msg_MapUpdate_desc;
    default: return teamscan_msg_StoredState_desc;
  }
}

}  // namespace teamscan::fuzz
