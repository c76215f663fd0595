// teamscan-onboard's event loop (STYLE.md 8: one loop, one tick): epoll over both serial ports, a
// timerfd for the clients' deadlines and the daemon's periods, and a signalfd. Runs ArcosClient and
// LmsClient (drivers/), reopens a lost device every 500 ms without stopping the other, feeds SIP poses
// into the odometry history, turns scans into filtered points (onboard/core) and hands pose, scan and
// status to the Publisher. Never exits on a device fault.
#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <string>

#include "common/result.hpp"
#include "common/time.hpp"
#include "drivers/arcos/client.hpp"
#include "drivers/lms200/client.hpp"
#include "drivers/serial/serial_port.hpp"
#include "onboard/core/config.hpp"
#include "onboard/core/pipeline.hpp"
#include "onboard/daemon/clock_sync.hpp"
#include "onboard/daemon/publisher.hpp"
#include "onboard/ring/scan_ring.hpp"

namespace teamscan::onboard {

struct DaemonOptions {
  Duration reopen_period = 500ms;      // a lost or missing device is tried again this often
  Duration shutdown_timeout = 2s;      // SIGTERM: at most this long to stop the laser and close the Pioneer
  Duration team_poll_period = 10ms;    // teamscan/team is taken this often
  Duration write_timeout = 100ms;      // one write to a port (a 9600-baud command is a few ms)
};

// One serial device: its port, reopen timer and counters. The client is the daemon's.
struct DeviceSlot {
  const char* name = "";
  std::string path;
  serial::SerialPort port;
  bool open = false;
  bool started = false;         // the client was started once (later opens are on_device_back)
  Time next_open{};             // monotonic
  std::uint32_t opens = 0;
  std::uint32_t losses = 0;
  const char* last_error = "";
};

class OnboardDaemon {
 public:
  // Allocates everything the loop needs (start-up); the error says what failed.
  [[nodiscard]] static Result<std::unique_ptr<OnboardDaemon>> create(const OnboardConfig& config, Publisher& publisher,
                                                                     const DaemonOptions& options = {});
  ~OnboardDaemon();
  OnboardDaemon(const OnboardDaemon&) = delete;
  OnboardDaemon& operator=(const OnboardDaemon&) = delete;

  // Runs until SIGTERM or SIGINT (blocked and taken through a signalfd), then stops the laser stream,
  // closes the Pioneer connection and returns the exit code (0). Non-zero only for a resource error.
  int run();

 private:
  OnboardDaemon(const OnboardConfig& config, Publisher& publisher, const DaemonOptions& options,
                OnboardPipeline pipeline, std::unique_ptr<ring::ScanRing> ring);

  Status setup_fds();
  void tick(Time now);
  void try_open(DeviceSlot& dev, serial::SerialEndpoint& client, Time now);
  void lose(DeviceSlot& dev, Time now, const char* why, int err);
  void service_rx(DeviceSlot& dev, serial::SerialEndpoint& client, Time now);
  void service_tx(DeviceSlot& dev, serial::SerialEndpoint& client, Time now);
  void sync_baud(DeviceSlot& dev, const serial::SerialEndpoint& client, Time now);
  void take_scans(Time now);
  // Projects, filters and publishes the scans waiting for odometry: each waits until a SIP at or after
  // its stamp has arrived (so its beams are interpolated, as sim/receiver.cpp does for the data set),
  // unless `force`, or the queue is full, or it has waited odometry.max_hold_s (config.hpp).
  void drain_scans(Time now, bool force);
  void publish_status(Time now);
  // Store and forward (config [ring]): the station's confirmations into the ring, the flush policy, and
  // the back-fill of what it has not confirmed, after the live scans of this turn.
  void service_ring(Time now);
  void on_stored(Time now);
  void ring_failed(const Status& s, const char* what, Time now);
  // Hands the team state just taken to the pipeline (checked there); a refusal is logged at most once
  // per 10 s with the count since the last line.
  void on_team(Time now);
  void log_state_changes();
  [[nodiscard]] Time next_wakeup(Time now) const;
  [[nodiscard]] Time to_realtime(Time monotonic) const { return monotonic + realtime_offset_; }
  // Re-reads CLOCK_REALTIME − CLOCK_MONOTONIC (NTP may slew it), keeping the old value when the
  // reading was preempted (daemon.cpp).
  void update_realtime_offset();
  static void on_sip(void* self, const arcos::SipPacket& sip, const arcos::OdometryState& odometry, Time received);

  OnboardConfig config_;
  Publisher& publisher_;
  DaemonOptions options_;
  OnboardPipeline pipeline_;
  std::unique_ptr<ring::ScanRing> ring_;  // null: no [ring] in the config
  arcos::ArcosClient arcos_;
  lms200::LmsClient lms_;
  DeviceSlot arcos_dev_;
  DeviceSlot lms_dev_;

  int epoll_fd_ = -1, timer_fd_ = -1, signal_fd_ = -1;
  Duration realtime_offset_{0};
  bool have_realtime_offset_ = false;
  bool stopping_ = false;
  Time stop_deadline_{};
  bool ready_sent_ = false;
  Duration watchdog_period_{0};
  Time next_watchdog_{};
  Time next_status_{};
  Time next_team_poll_{};
  Time started_{};

  // Per status period.
  std::uint32_t sips_in_period_ = 0, scans_in_period_ = 0;
  Time period_start_{};
  std::uint32_t loop_max_us_ = 0;
  std::uint32_t status_seq_ = 0;
  std::uint32_t publish_errors_ = 0;
  std::uint64_t scans_published_ = 0;
  arcos::ArcosClientState last_arcos_state_ = arcos::ArcosClientState::kIdle;
  lms200::LmsClientState last_lms_state_ = lms200::LmsClientState::idle;

  // Preallocated buffers of the data path.
  OnboardPose pose_msg_{};
  OnboardStatus status_msg_{};
  TeamSnapshot team_msg_{};
  StoredSnapshot stored_msg_{};
  ScanPoints backfill_msg_{};
  OnboardPose backfill_pose_{};
  std::uint64_t confirmations_refused_ = 0;
  std::uint64_t ring_errors_ = 0;
  Time next_ring_error_log_{};          // monotonic
  bool station_reachable_ = false;      // as the ring saw it last turn (for the journal's transitions)
  std::uint32_t scan_reader_matches_ = 0;  // the live writer's reader matches seen (Publisher::scan_reader_matches)
  // Scans waiting for the SIP that covers them: a fixed ring (16 scans = 213 ms at 75 Hz).
  struct PendingScan {
    lms200::ScanTelegram telegram;
    Time stamp;  // end of sweep, CLOCK_REALTIME
  };
  static constexpr std::size_t kPendingScans = 16;
  std::array<PendingScan, kPendingScans> pending_{};
  std::size_t pending_head_ = 0, pending_size_ = 0;
  std::uint32_t scans_forced_ = 0;  // projected before a covering SIP arrived
  Time next_team_reject_log_{};      // monotonic
  ClockSync clock_sync_ = ClockSync::kUnknown;
  std::array<std::uint8_t, kSerialRxChunk> rx_buf_{};
  std::array<std::uint8_t, 2 * kMaxLmsTelegram> tx_buf_{};
};

}  // namespace teamscan::onboard
