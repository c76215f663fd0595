// QoS recipes of the teamscan topics (DDS_SYSTEMD.md 1.3; liveliness per 3.2).
#include "dds/qos.hpp"

#include "dds/security/credentials.hpp"

namespace teamscan::dds {
namespace {

dds_duration_t to_dds(Duration d) { return static_cast<dds_duration_t>(d.count()); }

dds_qos_t* reliable(Duration max_blocking) {
  dds_qos_t* q = dds_create_qos();
  dds_qset_reliability(q, DDS_RELIABILITY_RELIABLE, to_dds(max_blocking));
  return q;
}

}  // namespace

dds_qos_t* make_state_writer_qos(std::uint32_t robot_id, Duration liveliness_lease, Duration max_blocking) {
  dds_qos_t* q = reliable(max_blocking);
  dds_qset_partition1(q, security::robot_identity(robot_id).c_str());
  dds_qset_history(q, DDS_HISTORY_KEEP_LAST, 1);
  dds_qset_durability(q, DDS_DURABILITY_TRANSIENT_LOCAL);
  // Automatic: Cyclone asserts it with participant-message heartbeats at 80 % of the lease, so a
  // process that dies is seen as not alive one lease later (DDS_SYSTEMD.md 3.2).
  dds_qset_liveliness(q, DDS_LIVELINESS_AUTOMATIC, to_dds(liveliness_lease));
  return q;
}

dds_qos_t* make_state_reader_qos() {
  dds_qos_t* q = reliable(std::chrono::milliseconds(100));
  dds_qset_partition1(q, kRobotsPartition);
  dds_qset_history(q, DDS_HISTORY_KEEP_ALL, 0);
  dds_qset_durability(q, DDS_DURABILITY_TRANSIENT_LOCAL);
  return q;
}

dds_qos_t* make_scan_writer_qos(std::uint32_t robot_id, std::uint32_t depth, Duration liveliness_lease,
                                Duration max_blocking, std::uint32_t late_joiner_depth) {
  const auto d = static_cast<std::int32_t>(depth == 0 ? 1 : depth);
  const auto late = late_joiner_depth == 0 || late_joiner_depth > depth ? d : static_cast<std::int32_t>(late_joiner_depth);
  dds_qos_t* q = reliable(max_blocking);
  dds_qset_partition1(q, security::robot_identity(robot_id).c_str());
  // Keep-last on the writer never blocks the robot's loop: a reader that falls more than `depth`
  // sweeps behind sees gaps (DDS_SYSTEMD.md 1.3), which the ground station counts from seq.
  dds_qset_history(q, DDS_HISTORY_KEEP_LAST, d);
  dds_qset_durability(q, DDS_DURABILITY_TRANSIENT_LOCAL);
  // The durability-service depth is what a reader that (re)joins gets at once; `d` what an unacknowledged
  // sample has to be repaired in before newer ones replace it.
  dds_qset_durability_service(q, 0, DDS_HISTORY_KEEP_LAST, late, DDS_LENGTH_UNLIMITED, DDS_LENGTH_UNLIMITED,
                              DDS_LENGTH_UNLIMITED);
  dds_qset_liveliness(q, DDS_LIVELINESS_AUTOMATIC, to_dds(liveliness_lease));
  return q;
}

// The station reads scans as it reads poses and status: every robot's partition, keep-all.
dds_qos_t* make_scan_reader_qos() { return make_state_reader_qos(); }

dds_qos_t* make_team_writer_qos(Duration liveliness_lease) {
  dds_qos_t* q = reliable(std::chrono::milliseconds(10));
  dds_qset_history(q, DDS_HISTORY_KEEP_LAST, 1);
  dds_qset_durability(q, DDS_DURABILITY_TRANSIENT_LOCAL);
  dds_qset_liveliness(q, DDS_LIVELINESS_AUTOMATIC, to_dds(liveliness_lease));
  return q;
}

dds_qos_t* make_team_reader_qos() {
  dds_qos_t* q = reliable(std::chrono::milliseconds(100));
  dds_qset_history(q, DDS_HISTORY_KEEP_LAST, 1);
  dds_qset_durability(q, DDS_DURABILITY_TRANSIENT_LOCAL);
  return q;
}

dds_qos_t* make_map_qos() {
  dds_qos_t* q = reliable(std::chrono::milliseconds(100));
  dds_qset_history(q, DDS_HISTORY_KEEP_LAST, 1);
  return q;
}

}  // namespace teamscan::dds
