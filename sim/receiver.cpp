// Client side of a simulated or replayed robot (receiver.hpp).
#include "sim/receiver.hpp"

#include <array>

#include "drivers/arcos/codec.hpp"

namespace teamscan::sim {

RobotReceiver::RobotReceiver(const Pose3& robot_from_laser, const Pose2& map_from_odom, std::uint32_t arcos_baud,
                             ScanHandler on_scan, SipHandler on_sip)
    : projector_{robot_from_laser, map_from_odom},
      arcos_baud_{arcos_baud},
      on_scan_{std::move(on_scan)},
      on_sip_{std::move(on_sip)} {}

void RobotReceiver::attach(arcos::ArcosClient& arcos, lms200::LmsClient& lms) {
  arcos.set_sip_callback(&RobotReceiver::sip_trampoline, this);
  lms.set_scan_sink(this);
}

void RobotReceiver::sip_trampoline(void* self, const arcos::SipPacket& sip, const arcos::OdometryState& odometry,
                                   Time received) {
  static_cast<RobotReceiver*>(self)->on_sip(sip, odometry, received);
}

void RobotReceiver::on_sip(const arcos::SipPacket& sip, const arcos::OdometryState& odometry, Time received) {
  // Back-date the arrival by the SIP's own time on the line: the pose is the firmware's at sending.
  const Duration on_line = serial_transmission_time(static_cast<std::int64_t>(arcos::encode_sip(sip).size), arcos_baud_);
  const Time stamp = floor_us(received) - on_line;
  if (!history_.push(stamp, odometry.pose)) return;  // not newer than the last: counted by the history
  ++sips_;
  if (on_sip_) on_sip_({stamp, odometry.pose, odometry.trans_vel_mm_s * 1e-3, odometry.rot_vel_rad_s});
  drain(false);
}

void RobotReceiver::on_scan(const lms200::ScanTelegram& scan, const lms200::ScanArrival& arrival) {
  const Time stamp = floor_us(arrival.last_byte) - arrival.transmission();
  pending_.push_back({std::make_unique<lms200::ScanTelegram>(scan), stamp});
  drain(false);
}

void RobotReceiver::drain(bool force) {
  // A scan waits until a SIP at or after its stamp has arrived, so every beam is interpolated
  // between two SIPs rather than extrapolated (the beams are measured before the stamp).
  while (!pending_.empty()) {
    if (!force && (history_.empty() || history_.newest().stamp < pending_.front().stamp)) return;
    project(*pending_.front().telegram, pending_.front().stamp);
    pending_.pop_front();
  }
}

void RobotReceiver::flush() { drain(true); }

void RobotReceiver::project(const lms200::ScanTelegram& scan, Time stamp) {
  // The variant follows from the count (the telegram does not carry the resolution).
  LaserVariant variant{180, 100};
  switch (scan.count) {
    case 361: variant = {180, 50}; break;
    case 101: variant = {100, 100}; break;
    case 201: variant = {100, 50}; break;
    case 401: variant = {100, 25}; break;
    default: break;
  }
  // The same input as the robot daemon's (ScanTelegram::sweep()). Not one full sweep (a partial scan,
  // a count of no variant): nothing to place, the scan is skipped.
  if (!projector_.project(scan.sweep(), stamp, variant, history_, *points_)) return;
  on_scan_({sequence_++, &scan, points_.get()});
}

}  // namespace teamscan::sim
