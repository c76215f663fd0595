// The live world stops a robot whose ARCOS client goes silent, as the Pioneer's firmware does
// (PROTOCOLS.md §1.6): over robot 1's pseudo-terminal a client opens the server and keeps it alive with
// PULSE, then goes silent. After the watchdog time (2 s) the robot's truth stands still (the ray casts of
// its own and its teammates' scans use the same poses) and its SIPs report no motion; robot 2, whose
// scenario track runs on, keeps driving. When the client is back, robot 1 drives on from where it stopped.
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <thread>
#include <vector>

#include "common/clock.hpp"
#include "drivers/arcos/codec.hpp"
#include "drivers/arcos/parser.hpp"
#include "drivers/serial/serial_port.hpp"
#include "sim/live.hpp"
#include "sim/scenario.hpp"

namespace teamscan::sim {
namespace {

using namespace std::chrono_literals;

double distance(const Pose2& a, const Pose2& b) { return std::hypot(a.x_m - b.x_m, a.y_m - b.y_m); }

class Host {
 public:
  explicit Host(serial::SerialPort port) : port_{std::move(port)} {}
  void send(arcos::Command c) { ASSERT_TRUE(port_.write_all(arcos::make_command(c).span(), 1s).ok()); }
  // Reads for `d`; keeps the SIPs.
  void read_for(Duration d) {
    const Time end = now_monotonic() + d;
    std::uint8_t buf[512];
    while (now_monotonic() < end) {
      auto n = port_.read(buf, 20ms);
      ASSERT_TRUE(n.ok());
      parser_.push(std::span<const std::uint8_t>(buf, n.value()), [&](const arcos::PacketView& v) {
        if (!arcos::is_sip_type(v.type)) return;
        if (auto s = arcos::decode_sip(v)) sips.push_back(s.value());
      });
    }
  }
  std::vector<arcos::SipPacket> sips;

 private:
  serial::SerialPort port_;
  arcos::ArcosParser parser_;
};

TEST(LiveWatchdog, ASilentClientStopsTheRobotInTheWorldAndItDrivesOnWhenBack) {
  const char* src = std::getenv("TEAMSCAN_SOURCE_DIR");
  ASSERT_NE(src, nullptr);
  const ScenarioLoad load = load_scenario_file(std::string(src) + "/sim/scenarios/lap2.toml");
  ASSERT_TRUE(load.scenario) << load.error;
  char tmpl[] = "/tmp/teamscan-live-watchdog-XXXXXX";
  ASSERT_NE(::mkdtemp(tmpl), nullptr);
  LiveOptions o;
  o.run_dir = tmpl;
  o.bringup_s = 0.2;
  auto live_r = LiveTeam::create(*load.scenario, o);
  ASSERT_TRUE(live_r.ok()) << live_r.error().what;
  LiveTeam& live = *live_r.value();
  ASSERT_GE(live.robot_count(), 2u);
  ASSERT_TRUE(live.start().ok());

  auto port = serial::SerialPort::open(live.arcos_path(0).c_str(), live.spec(0).arcos_baud);
  ASSERT_TRUE(port.ok()) << port.error().what;
  Host host{std::move(port.value())};
  for (auto c : {arcos::Command::kSync0, arcos::Command::kSync1, arcos::Command::kSync2, arcos::Command::kOpen}) host.send(c);
  // Alive: PULSE every 250 ms for 1.5 s (ARIA sends one every 500 ms).
  double last_pulse_s = 0;
  for (int i = 0; i < 6; ++i) {
    host.send(arcos::Command::kPulse);
    last_pulse_s = live.world_time_s();
    host.read_for(250ms);
  }
  EXPECT_EQ(live.holds(0), 0u);
  EXPECT_FALSE(live.true_motion(0, live.world_time_s()).held);

  // Silent: the firmware's watchdog (2 s) stops the robot.
  const Time silent_from = now_monotonic();
  while (live.holds(0) == 0 && now_monotonic() - silent_from < 6s) host.read_for(50ms);
  ASSERT_EQ(live.holds(0), 1u);
  const double hold_s = live.world_time_s();
  EXPECT_GE(hold_s - last_pulse_s, 1.9);
  EXPECT_LE(hold_s - last_pulse_s, 3.5);
  host.read_for(250ms);  // bytes of SIPs made before the hold, still on the line
  host.sips.clear();
  host.read_for(1s);  // SIPs while held
  const double t1 = live.world_time_s();
  const LiveTruth a = live.true_motion(0, t1 - 0.5), b = live.true_motion(0, t1);
  EXPECT_TRUE(a.held);
  EXPECT_TRUE(b.held);
  EXPECT_EQ(b.v_mps, 0.0);
  EXPECT_LT(distance(a.pose, b.pose), 1e-9);
  EXPECT_EQ(a.pose.theta_rad, b.pose.theta_rad);
  // The teammate without a silent client drives on (0.3 m/s on its oval).
  EXPECT_GT(distance(live.true_motion(1, t1 - 0.5).pose, live.true_motion(1, t1).pose), 0.1);
  // The SIPs sent while held: no wheel motion, the same position.
  std::size_t held_sips = 0;
  arcos::SipPacket first{};
  for (const arcos::SipPacket& s : host.sips) {
    if (held_sips == 0) first = s;
    ++held_sips;
    EXPECT_EQ(s.left_vel, 0);
    EXPECT_EQ(s.right_vel, 0);
    EXPECT_EQ(s.x_raw, first.x_raw);
    EXPECT_EQ(s.y_raw, first.y_raw);
    EXPECT_EQ(s.th_raw, first.th_raw);
  }
  EXPECT_GE(held_sips, 5u);  // SIPs every 100 ms

  // Back: the robot drives on from where it stopped.
  const Pose2 stopped = b.pose;
  host.send(arcos::Command::kPulse);
  host.read_for(300ms);
  host.send(arcos::Command::kPulse);
  host.read_for(300ms);
  const double t2 = live.world_time_s();
  const LiveTruth c = live.true_motion(0, t2);
  EXPECT_FALSE(c.held);
  EXPECT_GT(distance(c.pose, stopped), 0.05);
  EXPECT_LT(distance(c.pose, stopped), 0.3 * 1.0 + 0.05);  // at most ~0.6 s of driving since
  EXPECT_EQ(live.holds(0), 1u);

  live.stop();
  std::error_code ec;
  std::filesystem::remove_all(tmpl, ec);
}

}  // namespace
}  // namespace teamscan::sim
