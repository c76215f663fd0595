// The robot's client side as the simulator and the capture replay both run it: decoded SIPs fill an
// odometry history, decoded 0xB0 scans wait until odometry covers their sweep, then become 3-D points
// with the shared laser geometry (common/scan_points.hpp ScanProjector). The data set's points are
// exactly what this class makes of the bytes, so replaying the captures reproduces them.
//
// Time stamps: received times are truncated to whole microseconds (the capture format's resolution)
// before use, so a live run and a replay of its captures compute the same numbers. A SIP is stamped
// with its arrival back-dated by its transmission time at the ARCOS rate; a scan with the end of its
// sweep estimated as the arrival of its last byte minus its transmission time (DESIGN.md).
#pragma once

#include <cstdint>
#include <deque>
#include <functional>
#include <memory>
#include <vector>

#include "common/odometry_history.hpp"
#include "common/scan_points.hpp"
#include "drivers/arcos/client.hpp"
#include "drivers/lms200/client.hpp"

namespace teamscan::sim {

// One scan as the client side made it.
struct ReceivedScan {
  std::uint32_t sequence = 0;           // scans delivered so far by this receiver (from 0)
  const lms200::ScanTelegram* telegram = nullptr;
  const ScanPoints* points = nullptr;   // points->stamp = the estimated end of the sweep
};

// One decoded SIP: the odometry pose in the odometry frame and the wheel velocities.
struct ReceivedSip {
  Time stamp;
  Pose2 odom_pose;
  double v_mps = 0, w_radps = 0;
};

class RobotReceiver final : public lms200::ScanSink {
 public:
  using ScanHandler = std::function<void(const ReceivedScan&)>;
  using SipHandler = std::function<void(const ReceivedSip&)>;

  RobotReceiver(const Pose3& robot_from_laser, const Pose2& map_from_odom, std::uint32_t arcos_baud,
                ScanHandler on_scan, SipHandler on_sip = {});

  // Wires the receiver to the two clients (SIP callback and scan sink).
  void attach(arcos::ArcosClient& arcos, lms200::LmsClient& lms);
  // Projects the scans still waiting (their last beams extrapolated from the newest SIPs).
  void flush();

  void on_scan(const lms200::ScanTelegram& scan, const lms200::ScanArrival& arrival) override;
  [[nodiscard]] std::uint64_t scans() const { return sequence_; }
  [[nodiscard]] std::uint64_t sips() const { return sips_; }

 private:
  static void sip_trampoline(void* self, const arcos::SipPacket& sip, const arcos::OdometryState& odometry, Time received);
  void on_sip(const arcos::SipPacket& sip, const arcos::OdometryState& odometry, Time received);
  void project(const lms200::ScanTelegram& scan, Time stamp);
  void drain(bool force);

  struct Pending {
    std::unique_ptr<lms200::ScanTelegram> telegram;
    Time stamp;
  };
  ScanProjector projector_;
  std::uint32_t arcos_baud_;
  ScanHandler on_scan_;
  SipHandler on_sip_;
  teamscan::OdometryHistory<> history_;
  std::deque<Pending> pending_;
  std::unique_ptr<ScanPoints> points_ = std::make_unique<ScanPoints>();
  std::uint32_t sequence_ = 0;
  std::uint64_t sips_ = 0;
};

// Time truncated to whole microseconds (the resolution of a capture).
[[nodiscard]] inline Time floor_us(Time t) { return Time::from_us(t.us()); }

}  // namespace teamscan::sim
