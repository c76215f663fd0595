// Station: DDS readers of pose/scan/status, session storage, lost-robot detection, team publication.
#include "groundstation/station/station.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <exception>
#include <type_traits>

#include <dds/dds.h>

#include "common/clock.hpp"
#include "dds/participant.hpp"
#include "dds/qos.hpp"
#include "dds/take.hpp"
#include "teamscan.h"

namespace teamscan::station {

namespace {

enum Topic : int { kPose = 0, kScan = 1, kStatus = 2 };
constexpr const char* kTopicNames[3] = {"pose", "scan", "status"};

void liveliness_listener(dds_entity_t /*reader*/, const dds_liveliness_changed_status_t status, void* arg) {
  static_cast<Station*>(arg)->push_liveliness(status.last_publication_handle, status.alive_count_change,
                                              status.not_alive_count_change);
}

std::int32_t to_mm(double m) {
  const double mm = std::round(m * 1000.0);
  return static_cast<std::int32_t>(std::clamp(mm, -2.0e9, 2.0e9));
}

std::uint16_t to_mm_u16(double m) {
  return static_cast<std::uint16_t>(std::clamp(std::round(m * 1000.0), 0.0, 65535.0));
}

}  // namespace

// Every DDS entity and preallocated sample of the station (DDS_SYSTEMD.md 1.8: takes into our own
// fixed-size samples allocate nothing).
struct Station::Dds {
  explicit Dds(std::size_t batch) : poses{batch}, scans{batch}, statuses{batch} {}
  dds::Participant participant;  // deleting it deletes every entity below
  dds_entity_t readers[3] = {0, 0, 0};
  dds_entity_t team_writer = 0;
  dds_entity_t map_writer = 0;
  dds_entity_t waitset = 0;
  dds_entity_t guard = 0;
  dds::TakeBuffer<teamscan_msg_RobotPose> poses;
  dds::TakeBuffer<teamscan_msg_ScanPoints> scans;
  dds::TakeBuffer<teamscan_msg_RobotStatus> statuses;
  teamscan_msg_TeamState team{};
  std::array<TeamMemberEstimate, kMaxRobots> estimates{};
  StoredScan stored{};

  template <class Sample>
  dds::TakeBuffer<Sample>& buffer() {
    if constexpr (std::is_same_v<Sample, teamscan_msg_RobotPose>) return poses;
    else if constexpr (std::is_same_v<Sample, teamscan_msg_ScanPoints>) return scans;
    else return statuses;
  }
};

Station::Station(const StationOptions& options, SessionStore& store, TeamSource& team)
    : options_{options}, store_{store}, team_{team}, dds_{std::make_unique<Dds>(options.take_batch)} {
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

  Result<dds::Participant> participant = dds::Participant::create(options.domain_id);
  if (!participant.ok()) return Error{"station: cannot create DDS participant (check CYCLONEDDS_URI)", 0, participant.error().detail};
  d.participant = std::move(participant.value());

  dds_listener_t* listener = dds_create_listener(st.get());
  dds_lset_liveliness_changed(listener, liveliness_listener);
  dds_qos_t* q = dds::make_state_reader_qos();
  Result<dds_entity_t> pose_reader = dds::create_reader<teamscan_msg_RobotPose>(d.participant, q, listener);
  Result<dds_entity_t> status_reader = dds::create_reader<teamscan_msg_RobotStatus>(d.participant, q, listener);
  dds_delete_qos(q);
  q = dds::make_scan_reader_qos();
  Result<dds_entity_t> scan_reader = dds::create_reader<teamscan_msg_ScanPoints>(d.participant, q, listener);
  dds_delete_qos(q);
  dds_delete_listener(listener);
  q = dds::make_team_writer_qos(options.team_liveliness_lease);
  Result<dds_entity_t> team_writer = dds::create_writer<teamscan_msg_TeamState>(d.participant, q);
  dds_delete_qos(q);
  q = dds::make_map_qos();
  Result<dds_entity_t> map_writer = dds::create_writer<teamscan_msg_MapUpdate>(d.participant, q);
  dds_delete_qos(q);
  for (const Result<dds_entity_t>* e : {&pose_reader, &status_reader, &scan_reader, &team_writer, &map_writer}) {
    if (!e->ok()) return Error{"station: cannot create a DDS topic, reader or writer", 0, e->error().detail};
  }
  d.readers[kPose] = pose_reader.value();
  d.readers[kStatus] = status_reader.value();
  d.readers[kScan] = scan_reader.value();
  d.team_writer = team_writer.value();
  d.map_writer = map_writer.value();

  d.waitset = dds_create_waitset(d.participant.handle());
  d.guard = dds_create_guardcondition(d.participant.handle());
  if (d.waitset < 0 || d.guard < 0) return Error{"station: cannot create the waitset"};
  (void)dds_waitset_attach(d.waitset, d.guard, 0);
  for (int t = 0; t < 3; ++t) {
    const dds_entity_t rc = dds_create_readcondition(d.readers[t], DDS_ANY_STATE);
    if (rc < 0) return Error{"station: cannot create a read condition"};
    (void)dds_waitset_attach(d.waitset, rc, t + 1);
  }
  st->event("station started: listening to teamscan/pose, teamscan/scan, teamscan/status");
  return st;
}

void Station::wake() { (void)dds_set_guardcondition(dds_->guard, true); }

void Station::push_liveliness(std::uint64_t writer_handle, int alive_change, int not_alive_change) {
  std::lock_guard<std::mutex> lock(events_mutex_);
  events_.push_back(LivelinessEvent{writer_handle, alive_change, not_alive_change});
}

void Station::event(const std::string& text) { store_.log_event(now_realtime(), text); }

std::size_t Station::poll(Duration max_wait) {
  dds_attach_t triggered[4];
  (void)dds_waitset_wait(dds_->waitset, triggered, 4, static_cast<dds_duration_t>(std::max<std::int64_t>(0, max_wait.count())));
  (void)dds_set_guardcondition(dds_->guard, false);
  const std::uint64_t before = counters_.scans + counters_.poses + counters_.statuses;
  // Store first, then run the hooks. The receive time of a sample is when its dds_take returned.
  take<teamscan_msg_RobotPose>(kPose, [this](const auto& p, RobotRecord& r, const ReceiveTime& at) { on_pose(p, r, at); });
  take<teamscan_msg_RobotStatus>(kStatus, [this](const auto& s, RobotRecord& r, const ReceiveTime& at) { on_status(s, r, at); });
  take<teamscan_msg_ScanPoints>(kScan, [this](const auto& s, RobotRecord& r, const ReceiveTime& at) { on_scan(s, r, at); });
  handle_liveliness_events();
  check_silence(now_monotonic());
  return static_cast<std::size_t>(counters_.scans + counters_.poses + counters_.statuses - before);
}

RobotRecord* Station::heard(std::uint32_t robot_id, int topic, std::uint64_t writer, std::uint64_t instance,
                            Time now_mono) {
  if (robot_id == 0 || robot_id > kMaxRobots) {
    ++counters_.bad_samples;
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
        RobotRecord* r = heard(sample.robot_id, topic, info.publication_handle, info.instance_handle, at.monotonic);
        if (r != nullptr) on_sample(sample, *r, at);
      });
}

void Station::on_pose(const teamscan_msg_RobotPose& p, RobotRecord& r, const ReceiveTime& at) {
  store_.append_pose(p, at);
  ++r.poses;
  ++counters_.poses;
  PoseObservation obs;
  obs.robot_id = p.robot_id;
  obs.seq = p.seq;
  obs.stamp = Time::from_ns(p.stamp_ns);
  obs.received = at.realtime;
  obs.x_m = p.x_mm * 1e-3;
  obs.y_m = p.y_mm * 1e-3;
  obs.yaw_rad = p.yaw_urad * 1e-6;
  obs.vx_mps = p.vx_mmps * 1e-3;
  obs.vy_mps = p.vy_mmps * 1e-3;
  obs.yaw_rate_radps = p.yaw_rate_mradps * 1e-3;
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

void Station::on_status(const teamscan_msg_RobotStatus& s, RobotRecord& r, const ReceiveTime& at) {
  store_.append_status(s, at);
  ++r.statuses;
  ++counters_.statuses;
}

void Station::on_scan(const teamscan_msg_ScanPoints& s, RobotRecord& r, const ReceiveTime& at) {
  if (s.count > kMaxBeams) {
    ++counters_.bad_samples;
    return;
  }
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
      }
      // Otherwise a replayed sweep: stored again (receive time differs), seq bookkeeping unchanged.
    }
  }
  if (r.scans == 0 || s.seq > r.last_scan_seq || r.last_scan_seq - s.seq > options_.scan_history_depth) {
    r.last_scan_seq = s.seq;
  }
  StoredScan& out = dds_->stored;
  out.recv_realtime_ns = at.realtime.ns();
  out.recv_monotonic_ns = at.monotonic.ns();
  out.robot_id = s.robot_id;
  out.seq = s.seq;
  out.stamp_ns = s.stamp_ns;
  out.origin_x_mm = s.origin_x_mm;
  out.origin_y_mm = s.origin_y_mm;
  out.origin_z_mm = s.origin_z_mm;
  out.count = s.count;
  for (std::uint16_t b = 0; b < s.count; ++b) {
    out.points[b] = StoredPoint{s.points[b].x_mm, s.points[b].y_mm, s.points[b].z_mm, s.points[b].beam,
                                s.points[b].flags};
  }
  store_.append_scan(out);  // stored before any fusion code runs
  ++r.scans;
  ++counters_.scans;
  for (const ScanHook& h : scan_hooks_) {
    try {
      h(out);
    } catch (const std::exception& e) {
      ++counters_.hook_failures;
      event(std::string("scan hook failed: ") + e.what());
    }
  }
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
  if (now_mono - last_team_ < options_.team_period) return false;
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
    teamscan_msg_TeamMember& m = t.members[i];
    m.robot_id = e.robot_id;
    m.x_mm = to_mm(e.x_m);
    m.y_mm = to_mm(e.y_m);
    m.vx_mmps = to_mm(e.vx_mps);
    m.vy_mmps = to_mm(e.vy_mps);
    m.cov_xx_mm2 = static_cast<float>(e.cov_xx_m2 * 1e6);
    m.cov_xy_mm2 = static_cast<float>(e.cov_xy_m2 * 1e6);
    m.cov_yy_mm2 = static_cast<float>(e.cov_yy_m2 * 1e6);
    m.length_mm = to_mm_u16(e.body.length_m);
    m.width_mm = to_mm_u16(e.body.width_m);
    m.height_mm = to_mm_u16(e.body.height_m);
    // The station's own liveliness view wins over a tracker that does not know yet.
    const bool lost = e.lost || (e.robot_id <= kMaxRobots && robots_[e.robot_id].lost);
    m.lost = lost ? 1 : 0;
    m.reserved = 0;
    m.valid_ns = e.valid.ns();
  }
  if (dds_write(d.team_writer, &t) < 0) {
    ++counters_.team_write_errors;
    return false;
  }
  ++counters_.teams_published;
  return true;
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
  return buf;
}

}  // namespace teamscan::station
