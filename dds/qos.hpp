// QoS of every teamscan topic, in one place so that the robots, the ground station and the tests agree
// (DESIGN.md "DDS topics", DDS_SYSTEMD.md 1.3 and 3.2). Each function returns a new dds_qos_t that the
// caller deletes with dds_delete_qos.
#pragma once

#include <cstdint>

#include <dds/dds.h>

#include "common/time.hpp"

namespace teamscan::dds {

// Partitions: robot N writes its pose, scan and status in partition "robotN" (its identity name, the one
// partition its DDS Security permissions let it publish in: dds/security/credentials.hpp); the readers of
// those topics read partition "robot*" (the ground station's grant). The team state and the map stay in
// the default partition. So the partition a sample arrived in names its sender, authenticated when the
// domain is secured (groundstation/station/sender_identity.hpp).
inline constexpr const char* kRobotsPartition = "robot*";

// Per-robot state topics (pose, status): the writer is reliable, keep-last 1, transient-local, so a
// ground station that (re)starts gets each robot's latest value at once. The reader keeps all: the
// station stores every pose it is sent, even when two arrive between its takes.
[[nodiscard]] dds_qos_t* make_state_writer_qos(std::uint32_t robot_id, Duration liveliness_lease, Duration max_blocking);
[[nodiscard]] dds_qos_t* make_state_reader_qos();

// teamscan/scan and teamscan/pose: the writer keeps the last `depth` samples per robot, transient-local with the same
// durability-service depth: a reader that joins late (a restarted ground station) receives the last
// `depth` sweeps. Without the durability-service depth Cyclone keeps only 1 sample for late joiners.
// late_joiner_depth (1..depth; 0: depth): a reader that joins late, or matches again after a radio shadow,
// receives only the newest late_joiner_depth samples; `depth` stays the repair window of a matched reader.
// A robot with a ring gives its live writer 1: what a returning station missed comes from the back-fill, and
// the live scans are not queued behind seconds of history on a slow link (docs/radio.md).
[[nodiscard]] dds_qos_t* make_scan_writer_qos(std::uint32_t robot_id, std::uint32_t depth, Duration liveliness_lease,
                                              Duration max_blocking, std::uint32_t late_joiner_depth = 0);
// The reader keeps all (reliable, transient-local): a sample the writer delivered is never overwritten
// in the reader's cache because the taking thread was slow; only the writer's bounded history decides
// what a reader that is away for too long misses.
[[nodiscard]] dds_qos_t* make_scan_reader_qos();

// teamscan/team (ground station -> robots): reliable, transient-local, keep-last 1, keyless.
[[nodiscard]] dds_qos_t* make_team_writer_qos(Duration liveliness_lease);
[[nodiscard]] dds_qos_t* make_team_reader_qos();

// Store and forward (docs/onboard.md "The ring"): teamscan/backfill takes the scan QoS above, teamscan/stored
// the team state's (keep-last 1, transient-local).
// The back-fill goes out on kBackfillLanes writers of the one topic, scan seq modulo the lanes: each writer
// is its own reliable stream with its own repairs. Cyclone 0.10's reader asks, per acknowledgement, for the
// fragments of only the first partly received sample of a writer (ddsi_acknack.c), so on a lossy link, where
// most scans lose a fragment, one writer repairs about one scan per heartbeat round; the lanes repair in
// parallel (docs/radio.md "The back-fill's lanes").
inline constexpr std::uint32_t kBackfillLanes = 4;
// Each lane's history: a back-filled scan whose fragments are lost must be repaired before this many newer
// ones of its lane replace it (at the back-fill's 300 Hz over four lanes, 2 s; docs/radio.md).
inline constexpr std::uint32_t kBackfillHistoryDepth = 150;

// teamscan/map (ground station -> viewers): reliable, keep-last 1, volatile.
[[nodiscard]] dds_qos_t* make_map_qos();

}  // namespace teamscan::dds
