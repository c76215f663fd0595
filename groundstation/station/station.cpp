// Station: DDS readers of pose/scan/status, session storage, lost-robot detection, team publication.
#include "groundstation/station/station.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <exception>
#include <type_traits>

#include <dds/dds.h>

#include "common/clock.hpp"
#include "common/units.hpp"
#include "dds/participant.hpp"
#include "dds/receive_threads.hpp"
#include "dds/qos.hpp"
#include "dds/security/credentials.hpp"
#include "dds/take.hpp"
#include "groundstation/station/session_replay.hpp"
#include "teamscan.h"

namespace teamscan::station {

namespace {

// The readers (kBackfill, kBackfillPose: teamscan/backfill and teamscan/backfill_pose, the scans and poses
// robots re-publish from their ring).
enum Topic : int { kPose = 0, kScan = 1, kStatus = 2, kBackfill = 3, kBackfillPose = 4 };
constexpr int kTopics = 5;
constexpr const char* kTopicNames[kTopics] = {"pose", "scan", "status", "backfill", "backfill_pose"};

void liveliness_listener(dds_entity_t /*reader*/, const dds_liveliness_changed_status_t status, void* arg) {
  static_cast<Station*>(arg)->push_liveliness(status.last_publication_handle, status.alive_count_change,
                                              status.not_alive_count_change);
}

void matched_listener(dds_entity_t reader, const dds_subscription_matched_status_t status, void* arg) {
  if (status.current_count_change > 0) static_cast<Station*>(arg)->push_matched(reader, status.last_publication_handle);
}

// The robot whose partition ("robotN") publication `handle` matched on `reader` is in; 0 if none.
std::uint32_t publication_robot(dds_entity_t reader, dds_instance_handle_t handle) {
  dds_builtintopic_endpoint_t* ep = dds_get_matched_publication_data(reader, handle);
  if (ep == nullptr) return 0;
  std::uint32_t id = 0;
  std::uint32_t n = 0;
  char** names = nullptr;
  if (dds_qget_partition(ep->qos, &n, &names)) {
    if (n == 1) id = dds::security::robot_id_of_identity(names[0]);  // a writer in several partitions names no one
    for (std::uint32_t i = 0; i < n; ++i) dds_free(names[i]);
    dds_free(names);
  }
  dds_builtintopic_free_endpoint(ep);
  return id;
}

// A body dimension in whole mm, saturated (a NaN: 0).
std::uint16_t body_mm(double m) { return std::isnan(m) ? 0 : to_mm_as<std::uint16_t>(m); }

// A σ in whole mm / µrad, saturated (a NaN or a negative σ: 0, "unknown").
std::uint32_t sigma_mm(double m) { return std::isnan(m) ? 0u : to_mm_as<std::uint32_t>(m); }
std::uint32_t sigma_urad(double rad) { return std::isnan(rad) ? 0u : round_saturated<std::uint32_t>(rad * 1e6); }

}  // namespace

void team_member_from(const TeamMemberEstimate& e, bool lost, teamscan_msg_TeamMember& m) {
  m.robot_id = e.robot_id;
  m.x_mm = to_mm(e.x_m);
  m.y_mm = to_mm(e.y_m);
  m.vx_mmps = to_mm(e.vx_mps);
  m.vy_mmps = to_mm(e.vy_mps);
  m.cov_xx_mm2 = static_cast<float>(e.cov_xx_m2 * 1e6);
  m.cov_xy_mm2 = static_cast<float>(e.cov_xy_m2 * 1e6);
  m.cov_yy_mm2 = static_cast<float>(e.cov_yy_m2 * 1e6);
  m.length_mm = body_mm(e.body.length_m);
  m.width_mm = body_mm(e.body.width_m);
  m.height_mm = body_mm(e.body.height_m);
  m.lost = lost ? 1 : 0;
  m.reserved = 0;
  m.valid_ns = e.valid.ns();
  m.corr_x_mm = e.correction.x_mm;
  m.corr_y_mm = e.correction.y_mm;
  m.corr_yaw_urad = e.correction.yaw_urad;
  m.corr_sigma_mm = sigma_mm(e.correction_sigma_m);
  m.corr_sigma_yaw_urad = sigma_urad(e.correction_sigma_yaw_rad);
  m.corr_seq = e.correction.seq;
}

Receipt stored_from(const teamscan_msg_ScanPoints& s, const ReceiveTime& at, Reject verdict, ScanPoints& out) {
  out.robot_id = s.robot_id;
  out.seq = s.seq;
  out.stamp = Time::from_ns(s.stamp_ns);
  out.origin_x_mm = s.origin_x_mm;
  out.origin_y_mm = s.origin_y_mm;
  out.origin_z_mm = s.origin_z_mm;
  out.applied = OdomCorrection{s.corr_x_mm, s.corr_y_mm, s.corr_yaw_urad, s.corr_seq};
  out.count = std::min<std::uint16_t>(s.count, static_cast<std::uint16_t>(kMaxBeams));
  for (std::uint16_t b = 0; b < out.count; ++b) {
    out.points[b] = ScanPoint{s.points[b].x_mm, s.points[b].y_mm, s.points[b].z_mm, s.points[b].beam, s.points[b].flags};
  }
  // Not on the wire: the robot's projection result (the station decides poses itself).
  out.map_from_robot = Pose2{};
  out.pose_ok = false;
  out.unplaced = 0;
  if (verdict == Reject::kNone) undo_applied_correction(out);
  return Receipt{at.realtime.ns(), at.monotonic.ns(), static_cast<std::uint16_t>(verdict)};
}

// Every DDS entity and preallocated sample of the station (DDS_SYSTEMD.md 1.8: takes into our own
// fixed-size samples allocate nothing).
struct Station::Dds {
  explicit Dds(std::size_t batch) : poses{batch}, scans{batch}, statuses{batch} {}
  dds::Participant participant;  // deleting it deletes every entity below
  dds_entity_t readers[kTopics] = {0, 0, 0, 0};
  dds_entity_t team_writer = 0;
  dds_entity_t stored_writer = 0;
  dds_entity_t map_writer = 0;
  dds_entity_t waitset = 0;
  dds_entity_t guard = 0;
  dds::TakeBuffer<teamscan_msg_RobotPose> poses;
  dds::TakeBuffer<teamscan_msg_ScanPoints> scans;
  dds::TakeBuffer<teamscan_msg_RobotStatus> statuses;
  teamscan_msg_TeamState team{};
  teamscan_msg_StoredState stored_state{};
  std::array<TeamMemberEstimate, kMaxRobots> estimates{};
  ScanPoints stored{};  // the received scan (stored_from), reused for every sample

  template <class Sample>
  dds::TakeBuffer<Sample>& buffer() {
    if constexpr (std::is_same_v<Sample, teamscan_msg_RobotPose>) return poses;
    else if constexpr (std::is_same_v<Sample, teamscan_msg_ScanPoints>) return scans;
    else return statuses;
  }
};

Station::Station(const StationOptions& options, SessionStore& store, TeamSource& team)
    : options_{options},
      store_{store},
      team_{team},
      dds_{std::make_unique<Dds>(options.take_batch)},
      validator_{options.validation},
      senders_{[this](int topic, std::uint64_t handle) {
        return publication_robot(dds_->readers[topic], static_cast<dds_instance_handle_t>(handle));
      }} {
  for (std::uint32_t i = 0; i <= kMaxRobots; ++i) robots_[i].robot_id = i;
}

Station::~Station() {
  // Leave DDS first: a listener callback must not run against members already destroyed.
  dds_.reset();
}

Result<std::unique_ptr<Station>> Station::create(const StationOptions& options, SessionStore& store,
                                                 TeamSource& team) {
  if (options.take_batch == 0 || options.scan_history_depth == 0) {
    return Error{"station: take_batch and scan_history_depth must be positive"};
  }
  std::unique_ptr<Station> st(new Station(options, store, team));
  Dds& d = *st->dds_;

  const std::vector<int> threads_before = dds::thread_ids();
  Result<dds::Participant> participant = dds::Participant::create(options.domain_id, options.pki_dir.empty() ? nullptr : options.pki_dir.c_str());
  if (!participant.ok()) return Error{participant.error().what, 0, participant.error().detail};
  d.participant = std::move(participant.value());
  if (options.batch_receive_threads) {
    const dds::ReceiveThreads rt = dds::batch_receive_threads(threads_before);
    st->event("DDS receive threads: " + std::to_string(rt.batched) + " of " + std::to_string(rt.found) +
              " set to SCHED_BATCH (they take queued packets at the loop's next tick or wait, not one preemption per packet)" +
              (rt.unnamed > 0 ? "; " + std::to_string(rt.unnamed) + " new threads did not name themselves in time" : std::string()));
  }

  dds_listener_t* listener = dds_create_listener(st.get());
  dds_lset_liveliness_changed(listener, liveliness_listener);
  dds_lset_subscription_matched(listener, matched_listener);
  dds_qos_t* q = dds::make_state_reader_qos();
  Result<dds_entity_t> pose_reader = dds::create_reader<teamscan_msg_RobotPose>(d.participant, q, listener);
  Result<dds_entity_t> status_reader = dds::create_reader<teamscan_msg_RobotStatus>(d.participant, q, listener);
  Result<dds_entity_t> backfill_pose_reader =
      dds::create_reader<teamscan_msg_RobotPose>(d.participant, q, listener, dds::kTopicBackfillPose);
  dds_delete_qos(q);
  q = dds::make_scan_reader_qos();
  Result<dds_entity_t> scan_reader = dds::create_reader<teamscan_msg_ScanPoints>(d.participant, q, listener);
  Result<dds_entity_t> backfill_reader =
      dds::create_reader<teamscan_msg_ScanPoints>(d.participant, q, listener, dds::kTopicBackfill);
  dds_delete_qos(q);
  dds_delete_listener(listener);
  q = dds::make_team_writer_qos(options.team_liveliness_lease);
  Result<dds_entity_t> team_writer = dds::create_writer<teamscan_msg_TeamState>(d.participant, q);
  Result<dds_entity_t> stored_writer = dds::create_writer<teamscan_msg_StoredState>(d.participant, q);
  dds_delete_qos(q);
  q = dds::make_map_qos();
  Result<dds_entity_t> map_writer = dds::create_writer<teamscan_msg_MapUpdate>(d.participant, q);
  dds_delete_qos(q);
  for (const Result<dds_entity_t>* e :
       {&pose_reader, &status_reader, &scan_reader, &backfill_reader, &backfill_pose_reader, &team_writer, &stored_writer, &map_writer}) {
    if (!e->ok()) return Error{"station: cannot create a DDS topic, reader or writer", 0, e->error().detail};
  }
  d.readers[kPose] = pose_reader.value();
  d.readers[kStatus] = status_reader.value();
  d.readers[kScan] = scan_reader.value();
  d.readers[kBackfill] = backfill_reader.value();
  d.readers[kBackfillPose] = backfill_pose_reader.value();
  d.team_writer = team_writer.value();
  d.stored_writer = stored_writer.value();
  d.map_writer = map_writer.value();

  d.waitset = dds_create_waitset(d.participant.handle());
  d.guard = dds_create_guardcondition(d.participant.handle());
  if (d.waitset < 0 || d.guard < 0) return Error{"station: cannot create the waitset"};
  (void)dds_waitset_attach(d.waitset, d.guard, 0);
  for (int t = 0; t < kTopics; ++t) {
    const dds_entity_t rc = dds_create_readcondition(d.readers[t], DDS_ANY_STATE);
    if (rc < 0) return Error{"station: cannot create a read condition"};
    (void)dds_waitset_attach(d.waitset, rc, t + 1);
  }
  st->recover_stored();
  st->event("station started: listening to teamscan/pose, teamscan/scan, teamscan/status, teamscan/backfill, teamscan/backfill_pose");
  return st;
}

void Station::recover_stored() {
  // A restart on the same session folder: the scans stored before are not stored again (the robots' DDS
  // history replays them) and the confirmations go on from what the session holds, so a robot back-fills
  // exactly the station's outage. Reads scans.bin once (bounded memory: record by record).
  SessionReadStats stats;
  const Status s = replay_session_files(
      store_.dir(),
      [this](const PoseObservation& p) {
        if (stored_poses_[p.robot_id].insert(p.seq)) ++counters_.recovered_poses;
      },
      [this](const ScanPoints& scan, const Receipt& receipt) {
        if (receipt.rejected != 0 || scan.robot_id == 0 || scan.robot_id > kMaxRobots) return;
        if (stored_[scan.robot_id].insert(scan.seq)) ++counters_.recovered_scans;
      },
      stats);
  if (!s.ok()) {
    event(std::string("stored scans not recovered from the session folder: ") + s.error().what);
    return;
  }
  if (counters_.recovered_scans == 0 && counters_.recovered_poses == 0) return;
  std::string text = "recovered " + std::to_string(counters_.recovered_scans) + " stored scans from the session folder:";
  for (std::uint32_t id = 1; id <= kMaxRobots; ++id) {
    const StoredSeqs& q = stored_[id];
    if (!q.any()) continue;
    text += " robot " + std::to_string(id) + " seq " + std::to_string(q.first()) + ".." + std::to_string(q.contiguous()) +
            (q.holes() > 0 ? " (" + std::to_string(q.holes()) + " missing above)" : "") + ";";
  }
  text += " and " + std::to_string(counters_.recovered_poses) + " poses";
  stored_changed_ = true;
  event(text);
}

void Station::wake() { (void)dds_set_guardcondition(dds_->guard, true); }

void Station::push_liveliness(std::uint64_t writer_handle, int alive_change, int not_alive_change) {
  std::lock_guard<std::mutex> lock(events_mutex_);
  events_.push_back(LivelinessEvent{writer_handle, alive_change, not_alive_change});
}

void Station::push_matched(std::int32_t reader, std::uint64_t publication_handle) {
  std::lock_guard<std::mutex> lock(events_mutex_);
  matched_.emplace_back(reader, publication_handle);
}

void Station::event(const std::string& text) { store_.log_event(now_realtime(), text); }

std::int32_t Station::participant() const { return dds_->participant.handle(); }

void Station::close_inputs() {
  Dds& d = *dds_;
  if (d.readers[kPose] == 0) return;
  // A reader's read condition goes with it (and off the waitset).
  for (dds_entity_t& reader : d.readers) {
    (void)dds_delete(reader);
    reader = 0;
  }
  for (dds_entity_t* writer : {&d.team_writer, &d.stored_writer}) {
    (void)dds_delete(*writer);
    *writer = 0;
  }
  event("station stopped listening: the robots keep what they send from now on for the next station");
}

bool Station::inputs_closed() const { return dds_->readers[kPose] == 0; }

std::size_t Station::poll(Duration max_wait) {
  if (inputs_closed()) return 0;
  dds_attach_t triggered[4];
  (void)dds_waitset_wait(dds_->waitset, triggered, 4, static_cast<dds_duration_t>(std::max<std::int64_t>(0, max_wait.count())));
  (void)dds_set_guardcondition(dds_->guard, false);
  const std::uint64_t before = counters_.scans + counters_.poses + counters_.statuses;
  {
    // Newly matched publications: learn their sender before their first sample is taken.
    std::lock_guard<std::mutex> lock(events_mutex_);
    matched_work_.swap(matched_);
  }
  for (const auto& [reader, handle] : matched_work_) {
    for (int t = 0; t < kTopics; ++t)
      if (dds_->readers[t] == reader) senders_.matched(t, handle);
  }
  matched_work_.clear();
  // Store first, then run the hooks. The receive time of a sample is when its dds_take returned.
  take<teamscan_msg_RobotPose>(kPose, [this](const auto& p, RobotRecord& r, const ReceiveTime& at) { on_pose(p, r, at); });
  take<teamscan_msg_RobotStatus>(kStatus, [this](const auto& s, RobotRecord& r, const ReceiveTime& at) { on_status(s, r, at); });
  take<teamscan_msg_ScanPoints>(kScan, [this](const auto& s, RobotRecord& r, const ReceiveTime& at) { on_scan(s, r, at); });
  take<teamscan_msg_ScanPoints>(kBackfill,
                                [this](const auto& s, RobotRecord& r, const ReceiveTime& at) { on_backfill(s, r, at); });
  take<teamscan_msg_RobotPose>(kBackfillPose,
                               [this](const auto& p, RobotRecord& r, const ReceiveTime& at) { on_backfill_pose(p, r, at); });
  handle_liveliness_events();
  check_silence(now_monotonic());
  validator_.clock_changes([&](std::uint32_t, const std::string& text) { event(text); });
  return static_cast<std::size_t>(counters_.scans + counters_.poses + counters_.statuses - before);
}

void Station::refused(SampleTopic topic, const Verdict& v, std::uint32_t robot_id, std::uint32_t seq,
                      std::int64_t stamp_ns, const ReceiveTime& at) {
  ++counters_.rejected;
  store_.append_rejected(at, topic_name(topic), robot_id, seq, stamp_ns, reject_name(v.reason), v.value);
  const std::string line = validator_.log_line(v, topic, robot_id, at.monotonic);
  if (!line.empty()) event(line);
}

bool Station::write_validation() const { return store_.write_file_atomically("validation.csv", validator_.csv()); }

// Only samples the validator accepted get here: robot_id is 1..kMaxRobots.
RobotRecord* Station::heard(std::uint32_t robot_id, int topic, std::uint64_t writer, std::uint64_t instance,
                            Time now_mono) {
  const std::uint32_t sender = senders_.robot_of(topic, writer);
  if (sender != robot_id) {
    // Another participant publishing as this robot (robot 2 may write robot_id 1 in its own partition):
    // stored raw and marked (identity), counted per claimed robot and logged at most once a second per robot.
    ++counters_.identity_mismatches;
    RobotRecord& claimed = robots_[robot_id];
    ++claimed.identity_mismatches;
    if (claimed.identity_mismatches == 1 || now_mono - claimed.last_identity_event >= std::chrono::seconds(1)) {
      event((sender == 0 ? std::string("a publication outside every robot partition") : "robot " + std::to_string(sender)) +
            " published as robot " + std::to_string(robot_id) + " on teamscan/" + kTopicNames[topic] + ": refused (" +
            std::to_string(claimed.identity_mismatches) + " so far)");
      claimed.last_identity_event = now_mono;
    }
    return nullptr;
  }
  RobotRecord& r = robots_[robot_id];
  if (!r.seen) {
    r.seen = true;
    event("robot " + std::to_string(robot_id) + " first heard on teamscan/" + kTopicNames[topic]);
  }
  r.writer_handles[topic] = writer;
  r.instance_handles[topic] = instance;
  r.last_heard = now_mono;
  if (r.lost) set_lost(r, false, "heard again on teamscan/" + std::string(kTopicNames[topic]));
  return &r;
}

void Station::instance_ended(int topic, std::uint64_t instance, std::uint32_t instance_state) {
  for (std::uint32_t id = 1; id <= kMaxRobots; ++id) {
    RobotRecord& r = robots_[id];
    if (!r.seen || r.instance_handles[topic] != instance) continue;
    if (instance_state == DDS_NOT_ALIVE_DISPOSED_INSTANCE_STATE) {
      set_lost(r, true, std::string(kTopicNames[topic]) + " instance disposed (robot stopped or died)");
    } else if (instance_state == DDS_NOT_ALIVE_NO_WRITERS_INSTANCE_STATE) {
      set_lost(r, true, std::string("no ") + kTopicNames[topic] + " writer left");
    }
  }
}

void Station::set_lost(RobotRecord& r, bool lost, const std::string& why) {
  if (r.lost == lost) return;
  r.lost = lost;
  if (lost) {
    r.lost_at = now_monotonic();
    ++counters_.robots_lost;
  }
  team_.set_lost(r.robot_id, lost);
  event("robot " + std::to_string(r.robot_id) + (lost ? " LOST: " : " back: ") + why);
  for (const LostHook& h : lost_hooks_) {
    try {
      h(r.robot_id, lost);
    } catch (const std::exception& e) {
      ++counters_.hook_failures;
      event(std::string("lost hook failed: ") + e.what());
    }
  }
}

template <class Sample, class OnSample>
void Station::take(int topic, OnSample&& on_sample) {
  ReceiveTime at{};
  (void)dds::take_all(
      dds_->readers[topic], dds_->buffer<Sample>(),
      // The receive time of a sample is when its dds_take returned.
      [&] { at = ReceiveTime{now_realtime(), now_monotonic()}; },
      [&](const Sample& sample, const dds_sample_info_t& info) {
        if (!info.valid_data) {
          ++counters_.invalid_samples;
          instance_ended(topic, info.instance_handle, info.instance_state);
          return;
        }
        // Validate at the edge (sample_validation.hpp), before anything but the raw store sees the sample:
        // a refused one is stored raw, marked with its reason, and goes nowhere else (not the robot's
        // bookkeeping, the team source or the hooks: tracker, filters, map, latency statistics).
        const Verdict v = check_and_store_if_refused(sample, at, topic);
        if (!v.ok()) {
          // Stored raw, so confirmed as stored when its robot sent it: its ring does not send it again and
          // again. One claimed by another participant confirms nothing.
          if (v.reason != Reject::kRobotId && senders_.robot_of(topic, info.publication_handle) == sample.robot_id)
            confirm_refused(sample);
          return;
        }
        RobotRecord* r = heard(sample.robot_id, topic, info.publication_handle, info.instance_handle, at.monotonic);
        if (r == nullptr) {
          // Another participant publishing as this robot (DDS Security partitions): stored raw, marked.
          store_refused(sample, at, Reject::kIdentity);
          return;
        }
        on_sample(sample, *r, at);
      });
}

void Station::store_refused(const teamscan_msg_RobotPose& p, const ReceiveTime& at, Reject reason) {
  store_.append_pose(p, at, static_cast<std::uint16_t>(reason));
}
void Station::store_refused(const teamscan_msg_RobotStatus& s, const ReceiveTime& at, Reject reason) {
  store_.append_status(s, at, static_cast<std::uint16_t>(reason));
}
void Station::store_refused(const teamscan_msg_ScanPoints& s, const ReceiveTime& at, Reject reason) {
  const Receipt receipt = stored_from(s, at, reason, dds_->stored);
  store_.append_scan(dds_->stored, receipt);
}

void Station::confirm_refused(const teamscan_msg_RobotPose& p) {
  if (stored_poses_[p.robot_id].insert(p.seq)) stored_changed_ = true;
}
void Station::confirm_refused(const teamscan_msg_ScanPoints& s) {
  if (stored_[s.robot_id].insert(s.seq)) stored_changed_ = true;
}
void Station::confirm_refused(const teamscan_msg_RobotStatus&) {}

template <class Sample>
Verdict Station::check_and_store_if_refused(const Sample& sample, const ReceiveTime& at, int reader) {
  Verdict v;
  SampleTopic topic;
  if constexpr (std::is_same_v<Sample, teamscan_msg_RobotPose>) {
    const bool backfill = reader == kBackfillPose;
    v = backfill ? validator_.check_backfill_pose(sample, at.realtime) : validator_.check_pose(sample, at.realtime);
    topic = backfill ? SampleTopic::kBackfillPose : SampleTopic::kPose;
  } else if constexpr (std::is_same_v<Sample, teamscan_msg_RobotStatus>) {
    v = validator_.check_status(sample, at.realtime);
    topic = SampleTopic::kStatus;
  } else if (reader == kBackfill) {
    v = validator_.check_backfill(sample, at.realtime);
    topic = SampleTopic::kBackfill;
  } else {
    v = validator_.check_scan(sample, at.realtime);
    topic = SampleTopic::kScan;
  }
  if (!v.ok()) {
    store_refused(sample, at, v.reason);
    refused(topic, v, sample.robot_id, sample.seq, sample.stamp_ns, at);
  }
  return v;
}

PoseObservation pose_observation(const teamscan_msg_RobotPose& p, Time received) {
  PoseObservation obs;
  obs.robot_id = p.robot_id;
  obs.seq = p.seq;
  obs.stamp = Time::from_ns(p.stamp_ns);
  obs.received = received;
  obs.x_m = p.x_mm * 1e-3;
  obs.y_m = p.y_mm * 1e-3;
  obs.yaw_rad = p.yaw_urad * 1e-6;
  obs.vx_mps = p.vx_mmps * 1e-3;
  obs.vy_mps = p.vy_mmps * 1e-3;
  obs.yaw_rate_radps = p.yaw_rate_mradps * 1e-3;
  return obs;
}

void Station::on_pose(const teamscan_msg_RobotPose& p, RobotRecord& r, const ReceiveTime& at) {
  // A seq far below the last one is a robot that lost its ring and numbers from 1 again (as for scans).
  if (r.poses > 0 && p.seq < r.last_pose_seq && r.last_pose_seq - p.seq > options_.scan_history_depth) {
    stored_poses_[p.robot_id].reset();
  }
  if (r.poses == 0 || p.seq > r.last_pose_seq || r.last_pose_seq - p.seq > options_.scan_history_depth) {
    r.last_pose_seq = p.seq;
  }
  if (!store_pose(p, r, at)) return;
  const PoseObservation obs = pose_observation(p, at.realtime);
  team_.add_pose(obs);
  for (const PoseHook& h : pose_hooks_) {
    try {
      h(obs);
    } catch (const std::exception& e) {
      ++counters_.hook_failures;
      event(std::string("pose hook failed: ") + e.what());
    }
  }
}

void Station::on_backfill_pose(const teamscan_msg_RobotPose& p, RobotRecord& r, const ReceiveTime& at) {
  if (!store_pose(p, r, at)) return;
  ++r.poses_backfilled;
  ++counters_.poses_backfilled;
  const PoseObservation obs = pose_observation(p, at.realtime);
  for (const PoseHook& h : backfill_pose_hooks_) {
    try {
      h(obs);
    } catch (const std::exception& e) {
      ++counters_.hook_failures;
      event(std::string("back-fill pose hook failed: ") + e.what());
    }
  }
}

bool Station::store_pose(const teamscan_msg_RobotPose& p, RobotRecord& r, const ReceiveTime& at) {
  // Each (robot, pose seq) enters the session once: the live writer's history replayed to a returning
  // station and the ring's back-fill overlap.
  if (!stored_poses_[p.robot_id].insert(p.seq)) {
    ++r.poses_duplicate;
    ++counters_.duplicate_poses;
    return false;
  }
  stored_changed_ = true;
  store_.append_pose(p, at);
  ++r.poses;
  ++counters_.poses;
  return true;
}

void Station::on_status(const teamscan_msg_RobotStatus& s, RobotRecord& r, const ReceiveTime& at) {
  store_.append_status(s, at);
  // The robot's own reports (docs/validation.md): its clock's NTP state, its refused team states.
  if (s.clock_sync != r.clock_sync && (s.clock_sync == 2 || r.clock_sync == 2)) {
    event("robot " + std::to_string(s.robot_id) + " reports its clock " + (s.clock_sync == 2 ? "NOT synchronised" : "synchronised"));
  }
  if (s.teams_rejected > r.teams_rejected) {
    event("robot " + std::to_string(s.robot_id) + " refused " + std::to_string(s.teams_rejected - r.teams_rejected) +
          " team state(s), last reason code " + std::to_string(s.last_team_reject));
  }
  if (s.corrections_rejected > r.corrections_rejected) {
    event("robot " + std::to_string(s.robot_id) + " refused " +
          std::to_string(s.corrections_rejected - r.corrections_rejected) +
          " odometry correction(s) as an absurd step from the one it applies");
  }
  on_ring_status(s, r, at);
  r.clock_sync = s.clock_sync;
  r.teams_rejected = s.teams_rejected;
  r.corrections_rejected = s.corrections_rejected;
  ++r.statuses;
  ++counters_.statuses;
}

void Station::on_ring_status(const teamscan_msg_RobotStatus& s, RobotRecord& r, const ReceiveTime& at) {
  // The operator's view of a robot's radio shadow: "robot 2 back after a shadow of 43.0 s: back-filling
  // 3200 scans", progress every 5 s, and when it is whole again.
  const std::string robot = "robot " + std::to_string(s.robot_id);
  r.ring_unconfirmed = s.ring_unconfirmed;
  r.last_shadow_ms = s.last_shadow_ms;
  r.backfill_total = s.backfill_total;
  r.backfill_remaining = s.backfill_remaining;
  if (s.backfill_remaining > 0 && s.backfill_total > 0) {
    if (!r.backfilling) {
      r.backfilling = true;
      char text[200];
      std::snprintf(text, sizeof text, " back after a shadow of %.1f s: back-filling %u scans from its ring (%u unconfirmed)",
                    s.last_shadow_ms / 1000.0, s.backfill_total, s.ring_unconfirmed);
      event(robot + text);
      r.last_backfill_event = at.monotonic;
    } else if (at.monotonic - r.last_backfill_event >= std::chrono::seconds(5)) {
      char text[160];
      std::snprintf(text, sizeof text, " back-filling %.0f %% (%u of %u scans left)",
                    100.0 * (s.backfill_total - s.backfill_remaining) / s.backfill_total, s.backfill_remaining, s.backfill_total);
      event(robot + text);
      r.last_backfill_event = at.monotonic;
    }
  } else if (r.backfilling) {
    r.backfilling = false;
    r.whole_again = at.realtime;
    event(robot + " whole again: " + std::to_string(s.backfill_total) + " scans back-filled, " +
          std::to_string(stored_[s.robot_id].holes()) + " missing in the session; " +
          std::to_string(r.poses_backfilled) + " poses back-filled so far, " +
          std::to_string(stored_poses_[s.robot_id].holes()) + " missing");
  }
}

void Station::on_scan(const teamscan_msg_ScanPoints& s, RobotRecord& r, const ReceiveTime& at) {
  // Sequence bookkeeping: gaps mean the writer's history overran while we were not reading. A seq
  // far below the last one is a restarted robot; a little below is a transient-local replay.
  if (r.scans > 0) {
    if (s.seq > r.last_scan_seq + 1) {
      const std::uint32_t missing = s.seq - r.last_scan_seq - 1;
      r.scans_missing += missing;
      r.gaps_unreported += missing;
      if (at.monotonic - r.last_gap_event >= std::chrono::seconds(1)) {
        event("robot " + std::to_string(s.robot_id) + " scans " + std::to_string(r.last_scan_seq + 1) + ".." +
              std::to_string(s.seq - 1) + " missing (" + std::to_string(r.gaps_unreported) +
              " missing since the last report)");
        r.last_gap_event = at.monotonic;
        r.gaps_unreported = 0;
      }
    } else if (s.seq <= r.last_scan_seq) {
      ++r.scans_repeated;
      if (r.last_scan_seq - s.seq > options_.scan_history_depth) {
        event("robot " + std::to_string(s.robot_id) + " scan seq restarted at " + std::to_string(s.seq) +
              " after " + std::to_string(r.last_scan_seq));
        stored_[s.robot_id].reset();  // a new numbering (the robot lost its ring): its seqs are new scans
      }
      // Otherwise a replayed sweep: a duplicate (store_scan), seq bookkeeping unchanged.
    }
  }
  if (r.scans == 0 || s.seq > r.last_scan_seq || r.last_scan_seq - s.seq > options_.scan_history_depth) {
    r.last_scan_seq = s.seq;
  }
  (void)store_scan(s, r, at);
}

void Station::on_backfill(const teamscan_msg_ScanPoints& s, RobotRecord& r, const ReceiveTime& at) {
  if (!store_scan(s, r, at)) return;
  ++r.scans_backfilled;
  ++counters_.scans_backfilled;
}

bool Station::store_scan(const teamscan_msg_ScanPoints& s, RobotRecord& r, const ReceiveTime& at) {
  // Each (robot, seq) enters the session once: a history replay or a back-fill of a scan the session
  // holds is counted, neither stored nor fused again.
  if (!stored_[s.robot_id].insert(s.seq)) {
    ++r.scans_duplicate;
    ++counters_.duplicate_scans;
    return false;
  }
  stored_changed_ = true;
  const ScanPoints& out = dds_->stored;
  const Receipt receipt = stored_from(s, at, Reject::kNone, dds_->stored);
  store_.append_scan(out, receipt);  // stored before any fusion code runs
  ++r.scans;
  ++counters_.scans;
  for (const ScanHook& h : scan_hooks_) {
    try {
      h(out, receipt);
    } catch (const std::exception& e) {
      ++counters_.hook_failures;
      event(std::string("scan hook failed: ") + e.what());
    }
  }
  return true;
}

void Station::handle_liveliness_events() {
  {
    std::lock_guard<std::mutex> lock(events_mutex_);
    events_work_.swap(events_);
  }
  for (const LivelinessEvent& e : events_work_) {
    ++counters_.liveliness_events;
    if (e.not_alive_change <= 0 && e.alive_change >= 0) continue;  // a writer became alive: data says so
    for (std::uint32_t id = 1; id <= kMaxRobots; ++id) {
      RobotRecord& r = robots_[id];
      if (!r.seen) continue;
      if (std::find(std::begin(r.writer_handles), std::end(r.writer_handles), e.handle) != std::end(r.writer_handles)) {
        set_lost(r, true, "DDS liveliness lapsed");
      }
    }
  }
  events_work_.clear();
}

void Station::check_silence(Time now_monotonic) {
  if (options_.silence_timeout.count() <= 0) return;
  for (std::uint32_t id = 1; id <= kMaxRobots; ++id) {
    RobotRecord& r = robots_[id];
    if (r.seen && !r.lost && now_monotonic - r.last_heard > options_.silence_timeout) {
      set_lost(r, true, "silent for longer than the silence timeout");
    }
  }
}

bool Station::publish_team_if_due(Time now_mono) {
  if (inputs_closed() || now_mono - last_team_ < options_.team_period) return false;
  last_team_ = now_mono;
  Dds& d = *dds_;
  const Time now_rt = now_realtime();
  const std::size_t n = team_.estimate(now_rt, std::span<TeamMemberEstimate>(d.estimates));
  teamscan_msg_TeamState& t = d.team;
  t.seq = ++team_seq_;
  t.stamp_ns = now_rt.ns();
  t.count = static_cast<std::uint8_t>(std::min<std::size_t>(n, kMaxRobots));
  for (std::size_t i = 0; i < t.count; ++i) {
    const TeamMemberEstimate& e = d.estimates[i];
    // The station's own liveliness view wins over a tracker that does not know yet.
    team_member_from(e, e.lost || (e.robot_id <= kMaxRobots && robots_[e.robot_id].lost), t.members[i]);
  }
  (void)publish_stored(now_mono);
  if (dds_write(d.team_writer, &t) < 0) {
    ++counters_.team_write_errors;
    return false;
  }
  ++counters_.teams_published;
  return true;
}

bool Station::publish_stored(Time now_mono) {
  if (!stored_changed_ && now_mono - last_stored_ < std::chrono::seconds(1)) return false;
  teamscan_msg_StoredState& st = dds_->stored_state;
  st.seq = ++stored_seq_;
  st.stamp_ns = now_realtime().ns();
  st.count = 0;
  for (std::uint32_t id = 1; id <= kMaxRobots; ++id) {
    const StoredSeqs& q = stored_[id];
    // A robot is confirmed once the session holds one of its scans: an entry with contiguous_seq 0 would
    // tell it that none of its ring's scans is stored, and it would back-fill them all. Its poses'
    // confirmation rides along.
    if (!q.any()) continue;
    const StoredSeqs& poses = stored_poses_[id];
    teamscan_msg_RobotStored& e = st.robots[st.count++];
    e.robot_id = id;
    e.contiguous_seq = q.contiguous();
    e.first_seq = q.first();
    e.stored = static_cast<std::uint32_t>(std::min<std::uint64_t>(q.count(), 0xFFFFFFFFu));
    e.pose_contiguous_seq = poses.contiguous();
  }
  if (dds_write(dds_->stored_writer, &st) < 0) return false;
  stored_changed_ = false;
  last_stored_ = now_mono;
  ++counters_.stored_published;
  return true;
}

const StoredSeqs& Station::stored(std::uint32_t robot_id) const {
  TEAMSCAN_EXPECTS(robot_id >= 1 && robot_id <= kMaxRobots);
  return stored_[robot_id];
}

Status Station::publish_map(std::span<const teamscan_msg_MapVoxel> voxels, std::uint32_t resolution_mm,
                            std::uint32_t total_voxels) {
  teamscan_msg_MapUpdate m{};
  m.seq = ++map_seq_;
  m.stamp_ns = now_realtime().ns();
  m.resolution_mm = resolution_mm;
  m.total_voxels = total_voxels;
  m.voxels._buffer = const_cast<teamscan_msg_MapVoxel*>(voxels.data());
  m.voxels._length = static_cast<std::uint32_t>(voxels.size());
  m.voxels._maximum = static_cast<std::uint32_t>(voxels.size());
  m.voxels._release = false;  // our memory: Cyclone must not free it
  const dds_return_t rc = dds_write(dds_->map_writer, &m);
  if (rc < 0) return Error{"station: map write failed", 0, rc};
  return ok_status();
}

bool Station::map_acknowledged_within(Duration timeout) {
  return dds_wait_for_acks(dds_->map_writer, static_cast<dds_duration_t>(timeout.count())) == DDS_RETCODE_OK;
}

const StoredSeqs& Station::stored_poses(std::uint32_t robot_id) const {
  TEAMSCAN_EXPECTS(robot_id >= 1 && robot_id <= kMaxRobots);
  return stored_poses_[robot_id];
}

const RobotRecord& Station::robot(std::uint32_t robot_id) const {
  TEAMSCAN_EXPECTS(robot_id >= 1 && robot_id <= kMaxRobots);
  return robots_[robot_id];
}

std::uint32_t Station::robots_seen() const {
  std::uint32_t n = 0;
  for (std::uint32_t id = 1; id <= kMaxRobots; ++id) n += robots_[id].seen ? 1 : 0;
  return n;
}

std::uint32_t Station::robots_lost() const {
  std::uint32_t n = 0;
  for (std::uint32_t id = 1; id <= kMaxRobots; ++id) n += robots_[id].lost ? 1 : 0;
  return n;
}

std::string Station::status_line() const {
  std::uint64_t missing = 0;
  for (std::uint32_t id = 1; id <= kMaxRobots; ++id) missing += robots_[id].scans_missing;
  char buf[256];
  std::snprintf(buf, sizeof buf, "robots %u (lost %u), scans %llu (missing %llu), poses %llu, status %llu, team %llu",
                robots_seen(), robots_lost(), static_cast<unsigned long long>(counters_.scans),
                static_cast<unsigned long long>(missing), static_cast<unsigned long long>(counters_.poses),
                static_cast<unsigned long long>(counters_.statuses),
                static_cast<unsigned long long>(counters_.teams_published));
  std::string out = buf;
  std::string unsynced;
  for (std::uint32_t id = 1; id <= kMaxRobots; ++id) {
    if (robots_[id].seen && robots_[id].clock_sync == 2) unsynced += (unsynced.empty() ? "r" : ", r") + std::to_string(id);
  }
  if (!unsynced.empty()) out += "; clock not synchronised (robots say): " + unsynced;
  // Store and forward: robots in a shadow (lost, with their last report) and back-filling ones.
  for (std::uint32_t id = 1; id <= kMaxRobots; ++id) {
    const RobotRecord& r = robots_[id];
    char text[160];
    if (r.seen && r.lost) {
      std::snprintf(text, sizeof text, "; r%u silent for %.0f s", id, to_seconds(now_monotonic() - r.last_heard));
      out += text;
    } else if (r.backfilling && r.backfill_total > 0) {
      std::snprintf(text, sizeof text, "; r%u back-filling %.0f %% (%u of %u left)", id,
                    100.0 * (r.backfill_total - r.backfill_remaining) / r.backfill_total, r.backfill_remaining, r.backfill_total);
      out += text;
    }
  }
  const std::string validation = validator_.status_text();
  return validation.empty() ? out : out + "; " + validation;
}

}  // namespace teamscan::station
