// Capture replay through the drivers' clients (replay.hpp).
#include "sim/replay.hpp"

#include <algorithm>
#include <array>
#include <vector>

namespace teamscan::sim {

arcos::ArcosClientOptions arcos_client_options(const RobotSpec& spec) {
  arcos::ArcosClientOptions o;
  o.baud = spec.arcos_baud;
  return o;
}

lms200::LmsClientOptions lms_client_options(const RobotSpec& spec) {
  lms200::LmsClientOptions o;
  o.target_baud = spec.lms_baud;
  o.variant = spec.variant;
  return o;
}

namespace {

// One client fed from one capture, ticked like VirtualLink ticks an endpoint.
struct Feed {
  serial::SerialEndpoint* client;
  const Capture* capture;
  std::size_t next = 0;
  Time last_tick;
  bool ticked = false;
  Time now;

  // VirtualLink's rule: an endpoint whose deadline is not after its last tick is ticked 1 ms later.
  [[nodiscard]] Time deadline() const {
    const Time d = client->next_deadline();
    if (ticked && d <= last_tick) return last_tick + 1ms;
    return d;
  }
  // Skips to the next rx chunk; returns its time or "never".
  [[nodiscard]] Time next_rx(Time start) {
    while (next < capture->records.size()) {
      const CaptureRecord& r = capture->records[next];
      if (r.kind == CaptureRecord::Kind::chunk && r.direction == CaptureDirection::rx) return start + Duration{r.time_us * 1000};
      ++next;
    }
    return Time::from_ns(INT64_MAX);
  }
};

}  // namespace

ReplayStats replay_robot(const Capture& arcos, const Capture& lms, const RobotSpec& spec, const Pose2& map_from_odom,
                         Time start, const RobotReceiver::ScanHandler& on_scan) {
  arcos::ArcosClient arcos_client{arcos_client_options(spec)};
  lms200::LmsClient lms_client{lms_client_options(spec)};
  RobotReceiver receiver{spec.robot_from_laser, map_from_odom, spec.arcos_baud, on_scan};
  receiver.attach(arcos_client, lms_client);
  lms_client.start(start);

  ReplayStats stats;
  std::array<Feed, 2> feeds{Feed{&arcos_client, &arcos, 0, start, false, start}, Feed{&lms_client, &lms, 0, start, false, start}};
  std::array<std::uint8_t, 4096> sink{};
  for (;;) {
    Time next = Time::from_ns(INT64_MAX);
    for (Feed& f : feeds) next = std::min(next, f.next_rx(start));
    if (next == Time::from_ns(INT64_MAX)) break;  // no more bytes: the session is over
    // Both links ran in lock step; each feed is advanced to `next` on its own, as its link did, with
    // VirtualLink::run_until's loop: the earliest of rx and deadline, time never going back,
    // deliveries due first, then the tick.
    for (Feed& f : feeds) {
      for (;;) {
        const Time t = std::min(f.next_rx(start), f.deadline());
        if (t > next) break;
        f.now = std::max(f.now, t);
        while (f.next_rx(start) <= f.now) {
          f.client->on_rx(f.capture->records[f.next].bytes, f.now);
          ++f.next;
          ++stats.rx_chunks;
        }
        if (f.deadline() <= f.now) {
          f.client->on_tick(f.now);
          f.last_tick = f.now;
          f.ticked = true;
        }
        while (f.client->take_tx(sink) > 0) {
        }
      }
    }
  }
  receiver.flush();
  stats.scans = receiver.scans();
  stats.sips = receiver.sips();
  return stats;
}

}  // namespace teamscan::sim
