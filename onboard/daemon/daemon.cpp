// teamscan-onboard's event loop (daemon.hpp).
#include "onboard/daemon/daemon.hpp"

#include <sys/epoll.h>
#include <sys/signalfd.h>
#include <sys/timerfd.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <csignal>
#include <cstdarg>
#include <cstdio>
#include <cstdlib>
#include <cstring>

#include "common/clock.hpp"
#include "drivers/serial/posix_call.hpp"
#include "onboard/daemon/log.hpp"
#include "dds/notify.hpp"

namespace teamscan::onboard {

namespace {

using serial::posix_call;

// Tags in epoll_event.data.u32.
constexpr std::uint32_t kTagTimer = 1, kTagSignal = 2, kTagArcos = 3, kTagLms = 4;

// Status state byte: 0 = port not open, else 1 + the client's state.
std::uint8_t state_byte(bool open, std::uint8_t state) { return open ? static_cast<std::uint8_t>(state + 1) : 0; }

std::uint32_t rate_mhz(std::uint32_t events, Duration period) {
  if (period <= Duration::zero()) return 0;
  return static_cast<std::uint32_t>(static_cast<std::int64_t>(events) * 1'000'000'000'000LL / period.count());
}

std::uint32_t clamp_u32(std::uint64_t v) { return v > 0xFFFFFFFFull ? 0xFFFFFFFFu : static_cast<std::uint32_t>(v); }

// Longest gap between the two CLOCK_MONOTONIC reads around CLOCK_REALTIME for the offset sample to
// count: three vDSO clock reads take well under a microsecond, so a longer gap means the thread was
// preempted in between and the difference of the clocks would be off by the preemption.
constexpr Duration kMaxOffsetReadGap = 20us;

}  // namespace

Result<std::unique_ptr<OnboardDaemon>> OnboardDaemon::create(const OnboardConfig& config, Publisher& publisher,
                                                             const DaemonOptions& options) {
  Result<OnboardPipeline> pipeline = OnboardPipeline::create(config);
  if (!pipeline.ok()) return pipeline.error();
  std::unique_ptr<ring::ScanRing> ring;
  if (config.ring.enabled()) {
    Result<std::unique_ptr<ring::ScanRing>> opened = ring::ScanRing::open(config.ring, config.robot_id, config.scan_history_depth,
                                                                           kRingLiveLateJoinerDepth);
    if (!opened.ok()) {
      log_message(LogLevel::err, "ring %s: %s (%s)", config.ring.path.c_str(), opened.error().what,
                  std::strerror(opened.error().sys_errno));
      return opened.error();
    }
    ring = std::move(opened.value());
    const ring::RingIndex& idx = ring->index();
    const ring::RingCounters& rc = idx.counters();
    char seqs[48] = "";
    if (rc.recovered_scans > 0) std::snprintf(seqs, sizeof seqs, " (seq %u..%u)", idx.oldest_scan_seq(), idx.newest_scan_seq());
    log_message(LogLevel::notice,
                "ring %s: %llu records (%.0f MB)%s; recovered %llu scans%s and %llu poses in %.2f s; "
                "%llu torn and %llu misplaced records skipped, %llu of another robot",
                config.ring.path.c_str(), static_cast<unsigned long long>(idx.slots()),
                static_cast<double>(idx.slots() * ring::kSlotBytes) / 1e6, ring->created() ? " (new)" : "",
                static_cast<unsigned long long>(rc.recovered_scans), seqs, static_cast<unsigned long long>(rc.recovered_poses),
                ring->recovery_s(),
                static_cast<unsigned long long>(rc.torn), static_cast<unsigned long long>(rc.misplaced),
                static_cast<unsigned long long>(rc.foreign));
    // The numbering continues after the newest recovered scan and pose: never a seq twice at the station.
    pipeline.value().resume_after(idx.newest_scan_seq(), idx.newest_pose_seq());
  }
  std::unique_ptr<OnboardDaemon> d{new OnboardDaemon(config, publisher, options, pipeline.value(), std::move(ring))};
  const Status fds = d->setup_fds();
  if (!fds.ok()) return fds.error();
  return d;
}

OnboardDaemon::OnboardDaemon(const OnboardConfig& config, Publisher& publisher, const DaemonOptions& options,
                             OnboardPipeline pipeline, std::unique_ptr<ring::ScanRing> ring)
    : config_{config},
      publisher_{publisher},
      options_{options},
      pipeline_{pipeline},
      ring_{std::move(ring)},
      arcos_{[&] {
        arcos::ArcosClientOptions o;
        o.baud = config.arcos_baud;
        return o;
      }()},
      lms_{[&] {
        lms200::LmsClientOptions o;
        o.target_baud = config.lms_baud;
        o.variant = config.lms_variant;
        o.units = config.lms_units == LmsUnits::mm ? lms200::Unit::mm : lms200::Unit::cm;
        return o;
      }()} {
  arcos_dev_.name = "arcos";
  arcos_dev_.path = config.arcos_device;
  lms_dev_.name = "lms";
  lms_dev_.path = config.lms_device;
  arcos_.set_sip_callback(&OnboardDaemon::on_sip, this);
}

OnboardDaemon::~OnboardDaemon() {
  for (int fd : {epoll_fd_, timer_fd_, signal_fd_})
    if (fd >= 0) ::close(fd);
}

Status OnboardDaemon::setup_fds() {
  // SIGTERM/SIGINT stop the daemon, SIGUSR1 asks for a status dump: all through the loop's signalfd.
  sigset_t set;
  sigemptyset(&set);
  sigaddset(&set, SIGTERM);
  sigaddset(&set, SIGINT);
  sigaddset(&set, SIGUSR1);
  if (::sigprocmask(SIG_BLOCK, &set, nullptr) != 0) return Error{"sigprocmask failed", errno};
  std::signal(SIGPIPE, SIG_IGN);
  auto sfd = posix_call([&] { return ::signalfd(-1, &set, SFD_CLOEXEC | SFD_NONBLOCK); });
  if (!sfd.ok()) return Error{"signalfd failed", sfd.err};
  signal_fd_ = static_cast<int>(sfd.value);
  auto tfd = posix_call([] { return ::timerfd_create(CLOCK_MONOTONIC, TFD_CLOEXEC | TFD_NONBLOCK); });
  if (!tfd.ok()) return Error{"timerfd_create failed", tfd.err};
  timer_fd_ = static_cast<int>(tfd.value);
  auto efd = posix_call([] { return ::epoll_create1(EPOLL_CLOEXEC); });
  if (!efd.ok()) return Error{"epoll_create1 failed", efd.err};
  epoll_fd_ = static_cast<int>(efd.value);
  for (auto [fd, tag] : {std::pair{timer_fd_, kTagTimer}, std::pair{signal_fd_, kTagSignal}}) {
    epoll_event ev{};
    ev.events = EPOLLIN;
    ev.data.u32 = tag;
    if (::epoll_ctl(epoll_fd_, EPOLL_CTL_ADD, fd, &ev) != 0) return Error{"epoll_ctl failed", errno};
  }
  return ok_status();
}

void OnboardDaemon::try_open(DeviceSlot& dev, serial::SerialEndpoint& client, Time now) {
  Result<serial::SerialPort> port = serial::SerialPort::open(dev.path.c_str(), client.baud());
  if (!port.ok()) {
    if (dev.opens == 0 || dev.last_error != port.error().what) {
      log_message(LogLevel::warning, "%s: cannot open %s: %s (%s); retrying every %lld ms", dev.name, dev.path.c_str(),
                  port.error().what, std::strerror(port.error().sys_errno),
                  static_cast<long long>(options_.reopen_period.count() / 1'000'000));
    }
    dev.last_error = port.error().what;
    dev.next_open = now + options_.reopen_period;
    return;
  }
  dev.port = std::move(port.value());
  epoll_event ev{};
  ev.events = EPOLLIN;
  ev.data.u32 = &dev == &arcos_dev_ ? kTagArcos : kTagLms;
  if (::epoll_ctl(epoll_fd_, EPOLL_CTL_ADD, dev.port.fd(), &ev) != 0) {
    log_message(LogLevel::err, "%s: epoll_ctl: %s", dev.name, std::strerror(errno));
    dev.port.close();
    dev.next_open = now + options_.reopen_period;
    return;
  }
  dev.open = true;
  ++dev.opens;
  dev.last_error = "";
  log_message(LogLevel::notice, "%s: opened %s at %u baud", dev.name, dev.path.c_str(), client.baud());
  const bool first = !dev.started;
  dev.started = true;
  if (&dev == &arcos_dev_) {
    if (first) arcos_.start(now); else arcos_.on_device_back(now);
  } else {
    if (first) lms_.start(now); else lms_.on_device_back(now);
  }
}

void OnboardDaemon::lose(DeviceSlot& dev, Time now, const char* why, int err) {
  if (!dev.open) return;
  log_message(LogLevel::err, "%s: device %s lost: %s (%s); reopening every %lld ms", dev.name, dev.path.c_str(), why,
              std::strerror(err), static_cast<long long>(options_.reopen_period.count() / 1'000'000));
  (void)::epoll_ctl(epoll_fd_, EPOLL_CTL_DEL, dev.port.fd(), nullptr);
  dev.port.close();
  dev.open = false;
  ++dev.losses;
  dev.last_error = why;
  dev.next_open = now + options_.reopen_period;
  if (&dev == &arcos_dev_) arcos_.on_device_lost(now); else lms_.on_device_lost(now);
}

void OnboardDaemon::sync_baud(DeviceSlot& dev, const serial::SerialEndpoint& client, Time now) {
  if (!dev.open || client.baud() == dev.port.baud()) return;
  const Status s = dev.port.set_baud(client.baud());
  if (!s.ok()) lose(dev, now, s.error().what, s.error().sys_errno);
}

void OnboardDaemon::service_rx(DeviceSlot& dev, serial::SerialEndpoint& client, Time now) {
  // Level-triggered: read what is there now (a few chunks at most), the rest on the next wake-up.
  for (int chunk = 0; chunk < 4 && dev.open; ++chunk) {
    Result<std::size_t> n = dev.port.read(rx_buf_, Duration{0});
    if (!n.ok()) {
      lose(dev, now, n.error().what, n.error().sys_errno);
      return;
    }
    if (n.value() == 0) return;
    client.on_rx(std::span<const std::uint8_t>(rx_buf_.data(), n.value()), now);
    sync_baud(dev, client, now);
    if (n.value() < rx_buf_.size()) return;
  }
}

void OnboardDaemon::service_tx(DeviceSlot& dev, serial::SerialEndpoint& client, Time now) {
  for (;;) {
    // The client may change its rate (baud switch, recovery): the port follows before each take_tx.
    sync_baud(dev, client, now);
    const std::size_t n = client.take_tx(tx_buf_);
    if (n == 0 || !dev.open) return;
    const Status s = dev.port.write_all(std::span<const std::uint8_t>(tx_buf_.data(), n), options_.write_timeout);
    if (!s.ok()) {
      lose(dev, now, s.error().what, s.error().sys_errno);
      return;
    }
  }
}

void OnboardDaemon::on_sip(void* self_ptr, const arcos::SipPacket& sip, const arcos::OdometryState& odometry,
                           Time received) {
  auto* self = static_cast<OnboardDaemon*>(self_ptr);
  // The SIP describes the robot when ARCOS sent it: back-date the arrival by its own time on the wire.
  // Times are truncated to whole microseconds as in sim/receiver.cpp (the capture format's resolution).
  const Duration on_line =
      serial_transmission_time(static_cast<std::int64_t>(arcos::encode_sip(sip).size), self->arcos_.baud());
  const Time stamp = Time::from_us(self->to_realtime(received).us()) - on_line;
  ++self->sips_in_period_;
  if (!self->pipeline_.on_odometry(stamp, odometry.pose, odometry.trans_vel_mm_s, odometry.rot_vel_rad_s,
                                   self->pose_msg_))
    return;
  if (!self->publisher_.publish_pose(self->pose_msg_).ok()) ++self->publish_errors_;
  if (self->ring_) {
    const Status s = self->ring_->append_pose(self->pose_msg_, received);
    if (!s.ok()) self->ring_failed(s, "pose not kept", received);
  }
  self->drain_scans(received, false);
}

void OnboardDaemon::take_scans(Time now) {
  lms200::ScanArrival arrival;
  for (;;) {
    if (pending_size_ == kPendingScans) {
      // No room: the oldest goes out with the odometry there is (extrapolated, or flagged no-pose).
      ++scans_forced_;
      drain_scans(now, true);
    }
    PendingScan& slot = pending_[(pending_head_ + pending_size_) % kPendingScans];
    if (!lms_.take_scan(slot.telegram, arrival)) break;
    // A scan's stamp is the end of its sweep: its last byte's arrival minus its transmission time.
    slot.stamp = Time::from_us(to_realtime(arrival.last_byte).us()) - arrival.transmission();
    ++pending_size_;
  }
  drain_scans(now, false);
}

void OnboardDaemon::drain_scans(Time now, bool force) {
  const Time now_rt = to_realtime(now);
  while (pending_size_ > 0) {
    PendingScan& p = pending_[pending_head_];
    const OdometryHistory<>& odometry = pipeline_.odometry();
    const bool covered = !odometry.empty() && odometry.newest().stamp >= p.stamp;
    // Held at most odometry.max_hold_s for the covering SIP (ARCOS sends one every SipCycle = 100 ms,
    // PROTOCOLS.md §1.7); then published, the beams after the newest SIP extrapolated (odometry_history.hpp).
    const bool overdue = now_rt - p.stamp >= config_.odometry_max_hold;
    if (!covered && !force && !overdue) return;
    if (!covered && !force) ++scans_forced_;
    pending_head_ = (pending_head_ + 1) % kPendingScans;
    --pending_size_;
    force = false;  // a forced drain releases one scan
    // A partial scan or one of another variant would place its beams at wrong angles: the pipeline
    // refuses it (counted in its scans_refused).
    const ScanPoints* msg = pipeline_.on_scan(p.telegram.sweep(), p.stamp);
    if (msg == nullptr) continue;
    ++scans_in_period_;
    if (publisher_.publish_scan(*msg).ok()) ++scans_published_; else ++publish_errors_;
    // Kept whether or not DDS took it: the ring is what the station gets back later.
    if (ring_) {
      const Status s = ring_->append_scan(*msg, now);
      if (!s.ok()) ring_failed(s, "scan not kept", now);
    }
  }
}

void OnboardDaemon::ring_failed(const Status& s, const char* what, Time now) {
  ++ring_errors_;
  if (now >= next_ring_error_log_) {
    log_message(LogLevel::err, "ring: %s: %s (%s); %llu ring errors so far", what, s.error().what,
                std::strerror(s.error().sys_errno), static_cast<unsigned long long>(ring_errors_));
    next_ring_error_log_ = now + std::chrono::seconds(10);
  }
}

void OnboardDaemon::on_stored(Time now) {
  // A confirmation older than the reachable timeout is the transient-local copy a restarted robot gets of
  // the station's last one, not a sign of contact (clocks: NTP, as for the team state's age).
  const Duration age = to_realtime(now) - Time::from_ns(stored_msg_.stamp_ns);
  const bool fresh = age <= ring_->index().options().reachable_timeout;
  for (std::uint32_t i = 0; i < stored_msg_.count; ++i) {
    const RobotStoredState& r = stored_msg_.robots[i];
    const ring::Confirmation c = ring_->on_confirmation(r.robot_id, r.contiguous_seq, now, fresh, r.pose_contiguous_seq);
    if (c == ring::Confirmation::kUnknownRobot || c == ring::Confirmation::kFuture) {
      ++confirmations_refused_;
      if (now >= next_ring_error_log_) {
        log_message(LogLevel::warning, "confirmation refused: robot %u seq %u (%s; newest scan %u); %llu refused so far",
                    r.robot_id, r.contiguous_seq, c == ring::Confirmation::kFuture ? "from the future" : "unknown robot",
                    ring_->index().newest_scan_seq(), static_cast<unsigned long long>(confirmations_refused_));
        next_ring_error_log_ = now + std::chrono::seconds(10);
      }
    }
  }
}

void OnboardDaemon::service_ring(Time now) {
  if (!ring_) return;
  if (publisher_.take_stored(stored_msg_)) on_stored(now);
  // A station (re)matched the live writer since the last turn: what the writer no longer offers it is
  // the back-fill's from now on, even if the confirmations never lapsed (a station restarted in seconds).
  if (const std::uint32_t matches = publisher_.scan_reader_matches(); matches != scan_reader_matches_) {
    if (matches > scan_reader_matches_) ring_->on_live_reader_matched(now);
    scan_reader_matches_ = matches;
  }
  const Status f = ring_->flush_if_due(now);
  if (!f.ok()) ring_failed(f, "flush", now);
  const ring::ShadowState st = ring_->index().shadow(now);
  if (st.reachable != station_reachable_) {
    if (st.reachable)
      log_message(LogLevel::notice, "station confirms scan %u: back-filling %u scans from the ring", st.confirmed_seq,
                  st.backfill_total);
    else
      log_message(LogLevel::warning, "station unreachable (no confirmation for %.1f s): %u scans unconfirmed, kept in the ring",
                  to_seconds(now - st.shadow_since), st.unconfirmed);
    station_reachable_ = st.reachable;
  }
  // After this turn's live scans (take_scans ran first): at most the back-fill's burst, at its rate.
  ring_->start_turn(now);
  while (ring_->next_backfill(now, backfill_msg_)) {
    if (!publisher_.publish_backfill(backfill_msg_).ok()) {
      ++publish_errors_;
      break;
    }
  }
  while (ring_->next_backfill_pose(now, backfill_pose_)) {
    if (!publisher_.publish_backfill_pose(backfill_pose_).ok()) {
      ++publish_errors_;
      break;
    }
  }
}

void OnboardDaemon::publish_status(Time now) {
  const Duration period = now - period_start_;
  const PipelineCounters& pc = pipeline_.counters();
  const arcos::ArcosClientStatistics as = arcos_.statistics();
  const lms200::LmsParserStatistics& lp = lms_.parser_statistics();
  OnboardStatus& s = status_msg_;
  s.robot_id = config_.robot_id;
  s.seq = ++status_seq_;
  s.stamp_ns = to_realtime(now).ns();
  s.arcos_state = state_byte(arcos_dev_.open, static_cast<std::uint8_t>(arcos_.state()));
  s.lms_state = state_byte(lms_dev_.open, static_cast<std::uint8_t>(lms_.state()));
  s.team_fresh = pipeline_.team_fresh(to_realtime(now));
  const ClockSync sync = read_clock_sync();
  if (sync != clock_sync_) {
    log_message(sync == ClockSync::kNotSynchronised ? LogLevel::warning : LogLevel::info, "clock: %s", to_string(sync));
    clock_sync_ = sync;
  }
  s.clock_sync = static_cast<std::uint8_t>(sync);
  s.teams_rejected = clamp_u32(pipeline_.team_checks().rejected);
  s.last_team_reject = static_cast<std::uint32_t>(pipeline_.team_checks().last_reject);
  s.sip_rate_mhz = rate_mhz(sips_in_period_, period);
  s.scan_rate_mhz = rate_mhz(scans_in_period_, period);
  s.arcos_bad_packets = clamp_u32(as.parser.bad_checksum + as.parser.bad_length + as.bad_sips);
  s.lms_bad_telegrams = clamp_u32(lp.bad_crc + lp.bad_length + lms_.statistics().decode_errors);
  s.lms_resyncs = clamp_u32(lp.resyncs);
  s.scans_published = clamp_u32(scans_published_);
  s.points_direction_filtered = clamp_u32(pc.points_direction_filtered);
  const PublisherHealth health = publisher_.health();
  s.dds_write_errors = clamp_u32(publish_errors_ + health.write_errors);
  s.uptime_s = static_cast<std::uint32_t>((now - started_).count() / 1'000'000'000);
  s.arcos_reopens = arcos_dev_.opens;
  s.lms_reopens = lms_dev_.opens;
  s.points_team_stale = clamp_u32(pc.points_team_stale);
  s.points_no_pose = clamp_u32(pc.points_no_pose);
  s.loop_max_us = loop_max_us_;
  s.corrections_applied = clamp_u32(pc.corrections_applied);
  s.corrections_rejected = clamp_u32(pc.corrections_rejected);
  ring::ShadowState shadow;
  if (ring_) {
    shadow = ring_->index().shadow(now);
    s.ring_unconfirmed = shadow.unconfirmed;
    s.ring_dropped = clamp_u32(ring_->index().counters().dropped_unconfirmed);
    s.ring_confirmed_seq = shadow.confirmed_seq;
    s.shadow_ms = shadow.reachable || !shadow.ever_confirmed
                      ? 0
                      : clamp_u32(static_cast<std::uint64_t>(std::max<std::int64_t>(1, (now - shadow.shadow_since).count() / 1'000'000)));
    s.backfill_total = shadow.backfill_total;
    s.backfill_remaining = shadow.backfill_remaining;
    s.confirmations_refused = clamp_u32(confirmations_refused_);
    s.last_shadow_ms = clamp_u32(static_cast<std::uint64_t>(std::max<std::int64_t>(0, shadow.last_shadow.count() / 1'000'000)));
  }
  if (!publisher_.publish_status(s).ok()) ++publish_errors_;

  char text[1024];
  std::snprintf(text, sizeof text,
                "arcos %s %.1f Hz (opens %u, bad %u); lms %s %.1f Hz (opens %u, bad %u, dropped %u, forced %u); scans %u, "
                "filtered %u, stale %u, no pose %u; team %s (refused %u, last %s); correction %u (applied %u, refused %u); "
                "clock %s; loop max %u us; publish errors %u",
                arcos_dev_.open ? arcos::to_string(arcos_.state()) : "closed", s.sip_rate_mhz / 1000.0, s.arcos_reopens,
                s.arcos_bad_packets, lms_dev_.open ? lms200::to_string(lms_.state()) : "closed", s.scan_rate_mhz / 1000.0,
                s.lms_reopens, s.lms_bad_telegrams, clamp_u32(pc.scans_refused), scans_forced_, s.scans_published, s.points_direction_filtered,
                s.points_team_stale, s.points_no_pose, s.team_fresh ? "fresh" : "stale", s.teams_rejected,
                team_reject_name(pipeline_.team_checks().last_reject), pipeline_.applied_correction().seq,
                s.corrections_applied, s.corrections_rejected, to_string(sync), s.loop_max_us, publish_errors_);
  if (ring_) {
    // The ring's part of the status line: "ring: 3200 unconfirmed (shadow 43.0 s), back-fill 1184/3200, ...".
    const std::size_t used = std::strlen(text);
    std::snprintf(text + used, sizeof text - used,
                  "; ring: %u unconfirmed (confirmed %u, %s %.1f s), back-fill %u/%u, dropped %u, refused %u, errors %llu, "
                  "flush max %u us",
                  s.ring_unconfirmed, s.ring_confirmed_seq, s.shadow_ms > 0 ? "shadow" : "reachable", s.shadow_ms / 1000.0,
                  s.backfill_total - s.backfill_remaining, s.backfill_total, s.ring_dropped, s.confirmations_refused,
                  static_cast<unsigned long long>(ring_errors_), ring_->take_flush_max_us());
  }
  if (health.queued) {
    // "send queue 3 (max 411, refused 0, longest write 2310 ms)": a link that blocked the writes.
    const std::size_t used = std::strlen(text);
    std::snprintf(text + used, sizeof text - used, "; send queue %u (max %u, refused %llu, longest write %lld ms)", health.depth,
                  health.high_water, static_cast<unsigned long long>(health.refused),
                  static_cast<long long>(health.longest_write_ns / 1'000'000));
  }
  dds::notify_status(text);
  sips_in_period_ = scans_in_period_ = 0;
  loop_max_us_ = 0;
  period_start_ = now;
}

void OnboardDaemon::on_team(Time now) {
  const TeamCheck check = pipeline_.on_team(team_msg_, to_realtime(now));
  if (check.ok()) return;
  const std::uint64_t rejected = pipeline_.team_checks().rejected;
  if (now >= next_team_reject_log_) {
    log_message(LogLevel::warning, "team state refused: %s (member %u); %llu refused so far, the filter keeps the last good one",
                team_reject_name(check.reason), check.member, static_cast<unsigned long long>(rejected));
    next_team_reject_log_ = now + std::chrono::seconds(10);
  }
}

void OnboardDaemon::log_state_changes() {
  if (arcos_.state() != last_arcos_state_) {
    log_message(arcos_.connected() ? LogLevel::notice : LogLevel::info, "arcos: %s -> %s%s%s",
                arcos::to_string(last_arcos_state_), arcos::to_string(arcos_.state()),
                *arcos_.last_error() != '\0' ? "; last error: " : "", arcos_.last_error());
    last_arcos_state_ = arcos_.state();
  }
  if (lms_.state() != last_lms_state_) {
    log_message(lms_.streaming() ? LogLevel::notice : LogLevel::info, "lms: %s -> %s%s%s", lms200::to_string(last_lms_state_),
                lms200::to_string(lms_.state()), *lms_.last_error() != '\0' ? "; last error: " : "", lms_.last_error());
    last_lms_state_ = lms_.state();
  }
}

Time OnboardDaemon::next_wakeup(Time now) const {
  Time t = now + 1s;
  auto consider = [&](Time d) {
    if (d.ns() != 0 && d < t) t = d;
  };
  if (arcos_dev_.open) consider(arcos_.next_deadline()); else consider(arcos_dev_.next_open);
  if (lms_dev_.open) consider(lms_.next_deadline()); else consider(lms_dev_.next_open);
  consider(next_status_);
  consider(next_team_poll_);
  if (watchdog_period_ > Duration::zero()) consider(next_watchdog_);
  if (stopping_) consider(std::min(stop_deadline_, now + 10ms));
  // The oldest held scan is due when its hold ends (stamps are CLOCK_REALTIME, the loop runs on monotonic).
  if (pending_size_ > 0) consider(pending_[pending_head_].stamp - realtime_offset_ + config_.odometry_max_hold);
  // The ring: its flush period, and the back-fill's next turn while there is some to do.
  if (ring_) {
    if (ring_->flush_counters().unflushed > 0) consider(ring_->flush_due());
    const ring::ShadowState st = ring_->index().shadow(now);
    if (st.reachable && st.backfill_remaining > 0) consider(now + 10ms);
  }
  return std::max(t, now);
}

void OnboardDaemon::update_realtime_offset() {
  // Every stamp on the wire is a monotonic arrival time plus this offset: a preemption between the two
  // clock reads on a loaded machine was seen to shift stamps by milliseconds, either way
  // (tests/hil/onboard/sim_compare_hil_test.cpp). Read realtime between two monotonic reads and keep
  // the sample only if they are close; otherwise the previous offset stands (it moves by NTP slew only).
  for (int attempt = 0; attempt < 3; ++attempt) {
    const Time m0 = now_monotonic();
    const Time r = now_realtime();
    const Time m1 = now_monotonic();
    if (m1 - m0 <= kMaxOffsetReadGap || (!have_realtime_offset_ && attempt == 2)) {
      realtime_offset_ = r - (m0 + (m1 - m0) / 2);
      have_realtime_offset_ = true;
      return;
    }
  }
}

void OnboardDaemon::tick(Time now) {
  update_realtime_offset();
  if (!arcos_dev_.open && !stopping_ && now >= arcos_dev_.next_open) try_open(arcos_dev_, arcos_, now);
  if (!lms_dev_.open && !stopping_ && now >= lms_dev_.next_open) try_open(lms_dev_, lms_, now);
  if (arcos_dev_.open) {
    arcos_.on_tick(now);
    service_tx(arcos_dev_, arcos_, now);
  }
  if (lms_dev_.open) {
    lms_.on_tick(now);
    service_tx(lms_dev_, lms_, now);
  }
  take_scans(now);
  if (now >= next_team_poll_) {
    // take_team gives the newest state since the last call: one call per poll is enough.
    if (publisher_.take_team(team_msg_)) on_team(now);
    next_team_poll_ = now + options_.team_poll_period;
  }
  service_ring(now);
  log_state_changes();
  if (!ready_sent_ && arcos_.connected() && lms_.streaming()) {
    // READY=1 only once both devices stream (DDS_SYSTEMD.md 5).
    dds::notify_ready();
    ready_sent_ = true;
    log_message(LogLevel::notice, "ready: Pioneer connected and LMS streaming");
  }
  if (now >= next_status_) {
    publish_status(now);
    next_status_ = now + config_.status_period;
  }
  if (watchdog_period_ > Duration::zero() && now >= next_watchdog_) {
    dds::notify_watchdog();  // from the loop itself, so a hung loop starves systemd's watchdog
    next_watchdog_ = now + watchdog_period_;
  }
}

int OnboardDaemon::run() {
  started_ = now_monotonic();
  period_start_ = started_;
  next_status_ = started_ + config_.status_period;
  next_team_poll_ = started_;
  const Duration wd = dds::watchdog_interval();
  watchdog_period_ = wd / 2;
  next_watchdog_ = started_;
  log_message(LogLevel::notice, "robot %u starting; publisher: %s; watchdog %lld ms", config_.robot_id, publisher_.name(),
              static_cast<long long>(wd.count() / 1'000'000));

  std::array<epoll_event, 8> events{};
  for (;;) {
    const Time now = now_monotonic();
    tick(now);
    if (stopping_) {
      const bool lms_done = !lms_dev_.open || lms_.state() == lms200::LmsClientState::stopped ||
                            lms_.state() == lms200::LmsClientState::device_lost;
      if (lms_done || now >= stop_deadline_) break;
    }
    const Time wake = next_wakeup(now);
    itimerspec spec{};
    spec.it_value.tv_sec = static_cast<time_t>(wake.ns() / 1'000'000'000);
    spec.it_value.tv_nsec = static_cast<long>(wake.ns() % 1'000'000'000);
    if (spec.it_value.tv_sec == 0 && spec.it_value.tv_nsec == 0) spec.it_value.tv_nsec = 1;
    if (::timerfd_settime(timer_fd_, TFD_TIMER_ABSTIME, &spec, nullptr) != 0) {
      log_message(LogLevel::crit, "timerfd_settime: %s", std::strerror(errno));
      return 1;
    }
    const auto n = posix_call([&] { return ::epoll_wait(epoll_fd_, events.data(), static_cast<int>(events.size()), -1); });
    if (!n.ok()) {
      log_message(LogLevel::crit, "epoll_wait: %s", std::strerror(n.err));
      return 1;
    }
    const Time woke = now_monotonic();
    update_realtime_offset();
    for (long i = 0; i < n.value; ++i) {
      switch (events[static_cast<std::size_t>(i)].data.u32) {
        case kTagTimer: {
          std::uint64_t expirations = 0;
          // Drains the timerfd; the expiration count is not needed (the loop polls every source each tick).
          [[maybe_unused]] const ssize_t drained = ::read(timer_fd_, &expirations, sizeof expirations);
          break;
        }
        case kTagSignal: {
          signalfd_siginfo si{};
          while (::read(signal_fd_, &si, sizeof si) == static_cast<ssize_t>(sizeof si)) {
            if (si.ssi_signo == SIGUSR1) {
              publish_status(woke);
              log_message(LogLevel::info, "status dump requested");
            } else if (!stopping_) {
              log_message(LogLevel::notice, "signal %u: stopping the laser stream and closing the Pioneer", si.ssi_signo);
              dds::notify_stopping();
              stopping_ = true;
              stop_deadline_ = woke + options_.shutdown_timeout;
              if (lms_dev_.open) lms_.shutdown(woke);
              if (arcos_dev_.open) arcos_.shutdown(woke);
            }
          }
          break;
        }
        case kTagArcos:
          if (arcos_dev_.open) service_rx(arcos_dev_, arcos_, woke);
          break;
        case kTagLms:
          if (lms_dev_.open) service_rx(lms_dev_, lms_, woke);
          break;
        default: break;
      }
    }
    const Duration busy = now_monotonic() - woke;
    loop_max_us_ = std::max(loop_max_us_, static_cast<std::uint32_t>(busy.count() / 1000));
  }
  // Flush what the clients queued for the shutdown (STOP + CLOSE for the Pioneer) and close the ports.
  const Time end = now_monotonic();
  while (pending_size_ > 0) drain_scans(end, true);  // nothing received is lost
  if (ring_) {
    const Status f = ring_->flush();
    if (!f.ok()) ring_failed(f, "final flush", end);
  }
  if (arcos_dev_.open) service_tx(arcos_dev_, arcos_, end);
  if (lms_dev_.open) service_tx(lms_dev_, lms_, end);
  for (DeviceSlot* dev : {&arcos_dev_, &lms_dev_}) {
    if (dev->open) {
      (void)dev->port.drain(options_.write_timeout);
      dev->port.close();
      dev->open = false;
    }
  }
  const long long ran_s = static_cast<long long>((end - started_).count() / 1'000'000'000);
  const unsigned long long published = scans_published_;
  if (const PublisherHealth health = publisher_.health(); health.queued)
    log_message(LogLevel::notice, "stopped after %lld s; %llu scans published; send queue: max %u waiting, %llu refused, longest write %lld ms",
                ran_s, published, health.high_water, static_cast<unsigned long long>(health.refused),
                static_cast<long long>(health.longest_write_ns / 1'000'000));
  else
    log_message(LogLevel::notice, "stopped after %lld s; %llu scans published", ran_s, published);
  return 0;
}

}  // namespace teamscan::onboard
