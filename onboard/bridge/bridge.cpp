// DdsBridge: the robot's side of teamscan/pose, /scan, /status and /team over Cyclone DDS' C API.
// Allocation discipline (DDS_SYSTEMD.md 1.8): every sample lives in Samples, allocated once in create();
// each writer registers this robot's instance once, so a write serialises into Cyclone's pools only.
#include "onboard/bridge/bridge.hpp"

#include <cstring>
#include <utility>

#include <dds/dds.h>

#include "dds/qos.hpp"

namespace teamscan::onboard {

namespace {

Error dds_error(const char* what, dds_return_t rc) {
  return Error{what, 0, static_cast<long>(rc)};
}

}  // namespace

void encode_pose(const OnboardPose& in, teamscan_msg_RobotPose& out) {
  out.robot_id = in.robot_id;
  out.seq = in.seq;
  out.stamp_ns = in.stamp_ns;
  out.x_mm = in.x_mm;
  out.y_mm = in.y_mm;
  out.yaw_urad = in.yaw_urad;
  out.vx_mmps = in.vx_mmps;
  out.vy_mmps = in.vy_mmps;
  out.yaw_rate_mradps = in.yaw_rate_mradps;
}

void encode_scan(const ScanPoints& in, teamscan_msg_ScanPoints& out) {
  out.robot_id = in.robot_id;
  out.seq = in.seq;
  out.stamp_ns = in.stamp.ns();
  out.origin_x_mm = in.origin_x_mm;
  out.origin_y_mm = in.origin_y_mm;
  out.origin_z_mm = in.origin_z_mm;
  out.corr_x_mm = in.applied.x_mm;
  out.corr_y_mm = in.applied.y_mm;
  out.corr_yaw_urad = in.applied.yaw_urad;
  out.corr_seq = in.applied.seq;
  // The wire carries the whole array (fixed size); clamp so a bad count never reads past the end.
  const std::uint16_t n = in.count <= kMaxBeams ? in.count : static_cast<std::uint16_t>(kMaxBeams);
  out.count = n;
  for (std::uint16_t i = 0; i < n; ++i) {
    const ScanPoint& p = in.points[i];
    teamscan_msg_ScanPoint& q = out.points[i];
    q.x_mm = p.x_mm;
    q.y_mm = p.y_mm;
    q.z_mm = p.z_mm;
    q.beam = p.beam;
    q.flags = p.flags;
  }
  // Zero the unused tail: deterministic bytes on the wire, no stale points from a longer sweep.
  if (n < kMaxBeams) {
    std::memset(&out.points[n], 0, (kMaxBeams - n) * sizeof(teamscan_msg_ScanPoint));
  }
}

void encode_status(const OnboardStatus& in, teamscan_msg_RobotStatus& out) {
  out.robot_id = in.robot_id;
  out.seq = in.seq;
  out.stamp_ns = in.stamp_ns;
  out.arcos_state = in.arcos_state;
  out.lms_state = in.lms_state;
  out.team_fresh = in.team_fresh ? 1 : 0;
  out.clock_sync = in.clock_sync;
  out.sip_rate_mhz = in.sip_rate_mhz;
  out.scan_rate_mhz = in.scan_rate_mhz;
  out.arcos_bad_packets = in.arcos_bad_packets;
  out.lms_bad_telegrams = in.lms_bad_telegrams;
  out.lms_resyncs = in.lms_resyncs;
  out.scans_published = in.scans_published;
  out.points_direction_filtered = in.points_direction_filtered;
  out.dds_write_errors = in.dds_write_errors;
  out.uptime_s = in.uptime_s;
  out.arcos_reopens = in.arcos_reopens;
  out.lms_reopens = in.lms_reopens;
  out.points_team_stale = in.points_team_stale;
  out.points_no_pose = in.points_no_pose;
  out.loop_max_us = in.loop_max_us;
  out.teams_rejected = in.teams_rejected;
  out.last_team_reject = in.last_team_reject;
  out.corrections_applied = in.corrections_applied;
  out.corrections_rejected = in.corrections_rejected;
  out.ring_unconfirmed = in.ring_unconfirmed;
  out.ring_dropped = in.ring_dropped;
  out.ring_confirmed_seq = in.ring_confirmed_seq;
  out.shadow_ms = in.shadow_ms;
  out.backfill_total = in.backfill_total;
  out.backfill_remaining = in.backfill_remaining;
  out.confirmations_refused = in.confirmations_refused;
  out.last_shadow_ms = in.last_shadow_ms;
}

bool decode_stored(const teamscan_msg_StoredState& in, StoredSnapshot& out) {
  if (in.count > kMaxRobots) return false;  // validated at the edge: the count comes off the network
  out.stamp_ns = in.stamp_ns;
  out.count = in.count;
  for (std::uint32_t i = 0; i < in.count; ++i) {
    const teamscan_msg_RobotStored& r = in.robots[i];
    out.robots[i] = RobotStoredState{r.robot_id, r.contiguous_seq, r.first_seq, r.stored, r.pose_contiguous_seq};
  }
  return true;
}

bool decode_team(const teamscan_msg_TeamState& in, TeamSnapshot& out) {
  // Validate at the edge (STYLE.md 3): the count comes off the network.
  if (in.count > kMaxRobots) return false;
  out.count = in.count;
  for (std::uint32_t i = 0; i < in.count; ++i) {
    const teamscan_msg_TeamMember& m = in.members[i];
    TeamMemberState& s = out.members[i];
    s.robot_id = m.robot_id;
    s.x_mm = m.x_mm;
    s.y_mm = m.y_mm;
    s.vx_mmps = m.vx_mmps;
    s.vy_mmps = m.vy_mmps;
    s.cov_xx = m.cov_xx_mm2;
    s.cov_xy = m.cov_xy_mm2;
    s.cov_yy = m.cov_yy_mm2;
    s.length_mm = m.length_mm;
    s.width_mm = m.width_mm;
    s.height_mm = m.height_mm;
    s.valid_ns = m.valid_ns;
    s.lost = m.lost != 0;
    s.correction = OdomCorrection{m.corr_x_mm, m.corr_y_mm, m.corr_yaw_urad, m.corr_seq};
    s.correction_sigma_mm = m.corr_sigma_mm;
    s.correction_sigma_yaw_urad = m.corr_sigma_yaw_urad;
  }
  return true;
}

Result<DdsBridge> DdsBridge::create(const DdsBridgeOptions& options) {
  if (options.robot_id == 0 || options.robot_id > kMaxRobots) {
    return Error{"dds: robot_id must be 1..32", 0, static_cast<long>(options.robot_id)};
  }
  if (options.scan_history_depth == 0 || options.scan_history_depth > 100000) {
    return Error{"dds: scan_history_depth must be 1..100000", 0, static_cast<long>(options.scan_history_depth)};
  }
  Result<dds::Participant> participant = dds::Participant::create(options.domain_id, options.pki_dir);
  if (!participant.ok()) return participant.error();
  // Start-up allocations: the samples (about 7 kB) and the one-sample team buffer.
  DdsBridge b{std::move(participant.value())};
  b.robot_id_ = options.robot_id;
  b.samples_.reset(new Samples{});

  // Poses keep a history as the scans do (DdsBridgeOptions::pose_history_depth); status keep-last 1.
  dds_qos_t* q = dds::make_scan_writer_qos(options.robot_id, options.pose_history_depth, options.liveliness_lease,
                                           options.max_blocking);
  Result<dds_entity_t> pose_writer = dds::create_writer<teamscan_msg_RobotPose>(b.participant_, q);
  dds_delete_qos(q);
  q = dds::make_state_writer_qos(options.robot_id, options.liveliness_lease, options.max_blocking);
  Result<dds_entity_t> status_writer = dds::create_writer<teamscan_msg_RobotStatus>(b.participant_, q);
  dds_delete_qos(q);
  q = dds::make_scan_writer_qos(options.robot_id, options.scan_history_depth, options.liveliness_lease, options.max_blocking,
                                options.scan_late_joiner_depth);
  Result<dds_entity_t> scan_writer = dds::create_writer<teamscan_msg_ScanPoints>(b.participant_, q);
  dds_delete_qos(q);
  if (!pose_writer.ok()) return pose_writer.error();
  if (!status_writer.ok()) return status_writer.error();
  if (!scan_writer.ok()) return scan_writer.error();
  b.pose_writer_ = pose_writer.value();
  b.status_writer_ = status_writer.value();
  b.scan_writer_ = scan_writer.value();

  // Register this robot's instance once: an unregistered instance is created and garbage-collected on
  // every write (+2 allocations and a GC request per write, DDS_SYSTEMD.md 1.8).
  Samples& s = *b.samples_;
  s.pose_tx.robot_id = options.robot_id;
  s.scan_tx.robot_id = options.robot_id;
  s.status_tx.robot_id = options.robot_id;
  dds_instance_handle_t ih = 0;
  dds_return_t rc = dds_register_instance(b.pose_writer_, &ih, &s.pose_tx);
  if (rc < 0) return dds_error("dds: cannot register pose instance", rc);
  rc = dds_register_instance(b.scan_writer_, &ih, &s.scan_tx);
  if (rc < 0) return dds_error("dds: cannot register scan instance", rc);
  rc = dds_register_instance(b.status_writer_, &ih, &s.status_tx);
  if (rc < 0) return dds_error("dds: cannot register status instance", rc);

  if (options.store_and_forward) {
    s.backfill_tx.robot_id = options.robot_id;
    for (dds_entity_t& lane : b.backfill_writers_) {
      q = dds::make_scan_writer_qos(options.robot_id, dds::kBackfillHistoryDepth, options.liveliness_lease,
                                    options.max_blocking);
      Result<dds_entity_t> backfill_writer =
          dds::create_writer<teamscan_msg_ScanPoints>(b.participant_, q, dds::kTopicBackfill);
      dds_delete_qos(q);
      if (!backfill_writer.ok()) return backfill_writer.error();
      lane = backfill_writer.value();
      rc = dds_register_instance(lane, &ih, &s.backfill_tx);
      if (rc < 0) return dds_error("dds: cannot register back-fill instance", rc);
    }
    q = dds::make_scan_writer_qos(options.robot_id, options.pose_history_depth, options.liveliness_lease,
                                  options.max_blocking);
    Result<dds_entity_t> backfill_pose_writer =
        dds::create_writer<teamscan_msg_RobotPose>(b.participant_, q, dds::kTopicBackfillPose);
    dds_delete_qos(q);
    if (!backfill_pose_writer.ok()) return backfill_pose_writer.error();
    b.backfill_pose_writer_ = backfill_pose_writer.value();
    s.backfill_pose_tx.robot_id = options.robot_id;
    rc = dds_register_instance(b.backfill_pose_writer_, &ih, &s.backfill_pose_tx);
    if (rc < 0) return dds_error("dds: cannot register pose back-fill instance", rc);
    q = dds::make_team_reader_qos();
    Result<dds_entity_t> stored_reader = dds::create_reader<teamscan_msg_StoredState>(b.participant_, q);
    dds_delete_qos(q);
    if (!stored_reader.ok()) return stored_reader.error();
    b.stored_reader_ = stored_reader.value();
  }

  if (options.subscribe_team) {
    q = dds::make_team_reader_qos();
    Result<dds_entity_t> team_reader = dds::create_reader<teamscan_msg_TeamState>(b.participant_, q);
    dds_delete_qos(q);
    if (!team_reader.ok()) return team_reader.error();
    b.team_reader_ = team_reader.value();
  }
  return b;
}

Status DdsBridge::publish_pose(const OnboardPose& pose) {
  if (!participant_.valid() || pose.robot_id != robot_id_) {
    ++counters_.write_errors;
    return Error{"dds: pose for another robot id or bridge not created", 0, static_cast<long>(pose.robot_id)};
  }
  encode_pose(pose, samples_->pose_tx);
  const dds_return_t rc = dds_write(pose_writer_, &samples_->pose_tx);
  if (rc < 0) {
    ++counters_.write_errors;
    return dds_error("dds: pose write failed", rc);
  }
  ++counters_.poses_written;
  return ok_status();
}

Status DdsBridge::publish_scan(const ScanPoints& scan) {
  if (!participant_.valid() || scan.robot_id != robot_id_) {
    ++counters_.write_errors;
    return Error{"dds: scan for another robot id or bridge not created", 0, static_cast<long>(scan.robot_id)};
  }
  encode_scan(scan, samples_->scan_tx);
  const dds_return_t rc = dds_write(scan_writer_, &samples_->scan_tx);
  if (rc < 0) {
    ++counters_.write_errors;
    return dds_error("dds: scan write failed", rc);
  }
  ++counters_.scans_written;
  return ok_status();
}

Status DdsBridge::publish_backfill(const ScanPoints& scan) {
  const dds_entity_t lane = backfill_writers_[scan.seq % dds::kBackfillLanes];
  if (!participant_.valid() || lane <= 0 || scan.robot_id != robot_id_) {
    ++counters_.write_errors;
    return Error{"dds: back-fill for another robot id or no back-fill writer", 0, static_cast<long>(scan.robot_id)};
  }
  encode_scan(scan, samples_->backfill_tx);
  const dds_return_t rc = dds_write(lane, &samples_->backfill_tx);
  if (rc < 0) {
    ++counters_.write_errors;
    return dds_error("dds: back-fill write failed", rc);
  }
  ++counters_.backfills_written;
  return ok_status();
}

Status DdsBridge::publish_backfill_pose(const OnboardPose& pose) {
  if (!participant_.valid() || backfill_pose_writer_ <= 0 || pose.robot_id != robot_id_) {
    ++counters_.write_errors;
    return Error{"dds: pose back-fill for another robot id or no back-fill writer", 0, static_cast<long>(pose.robot_id)};
  }
  encode_pose(pose, samples_->backfill_pose_tx);
  const dds_return_t rc = dds_write(backfill_pose_writer_, &samples_->backfill_pose_tx);
  if (rc < 0) {
    ++counters_.write_errors;
    return dds_error("dds: pose back-fill write failed", rc);
  }
  ++counters_.backfill_poses_written;
  return ok_status();
}

Status DdsBridge::publish_status(const OnboardStatus& status) {
  if (!participant_.valid() || status.robot_id != robot_id_) {
    ++counters_.write_errors;
    return Error{"dds: status for another robot id or bridge not created", 0, static_cast<long>(status.robot_id)};
  }
  encode_status(status, samples_->status_tx);
  const dds_return_t rc = dds_write(status_writer_, &samples_->status_tx);
  if (rc < 0) {
    ++counters_.write_errors;
    return dds_error("dds: status write failed", rc);
  }
  ++counters_.status_written;
  return ok_status();
}

bool DdsBridge::take_team(TeamSnapshot& out) {
  if (team_reader_ <= 0 || !participant_.valid()) return false;
  bool got = false;
  // Keep-last 1: at most one sample waits. The sample memory is ours, so the take deserialises into
  // it without allocating (fixed-size type, DDS_SYSTEMD.md 1.8).
  (void)dds::take_all(
      team_reader_, team_rx_, [] {},
      [&](const teamscan_msg_TeamState& team, const dds_sample_info_t& info) {
        if (!info.valid_data) return;  // dispose / no-writers notifications
        if (decode_team(team, out)) {
          got = true;
          ++counters_.teams_taken;
        } else {
          ++counters_.bad_team_samples;
        }
      });
  return got;
}

bool DdsBridge::take_stored(StoredSnapshot& out) {
  if (stored_reader_ <= 0 || !participant_.valid()) return false;
  bool got = false;
  (void)dds::take_all(
      stored_reader_, stored_rx_, [] {},
      [&](const teamscan_msg_StoredState& stored, const dds_sample_info_t& info) {
        if (!info.valid_data) return;
        if (decode_stored(stored, out)) {
          got = true;
          ++counters_.stored_taken;
        } else {
          ++counters_.bad_stored_samples;
        }
      });
  return got;
}

Status DdsBridge::wait_for_scan_acks(Duration timeout) {
  if (scan_writer_ <= 0 || !participant_.valid()) return Error{"dds: bridge not created"};
  const dds_return_t rc = dds_wait_for_acks(scan_writer_, static_cast<dds_duration_t>(timeout.count()));
  if (rc < 0) return dds_error("dds: scans not acknowledged in time", rc);
  return ok_status();
}

std::uint32_t DdsBridge::scan_reader_matches() const {
  if (scan_writer_ <= 0 || !participant_.valid()) return 0;
  dds_publication_matched_status_t st{};
  if (dds_get_publication_matched_status(scan_writer_, &st) < 0) return 0;
  return st.total_count;
}

std::uint32_t DdsBridge::scan_subscribers() const {
  if (scan_writer_ <= 0 || !participant_.valid()) return 0;
  dds_publication_matched_status_t st{};
  if (dds_get_publication_matched_status(scan_writer_, &st) < 0) return 0;
  return st.current_count;
}

}  // namespace teamscan::onboard
