// ArcosClient against PioneerEmulator in process (simulated time, 1 ms steps): handshake, stale open
// server, keep-alive, watchdog, reconnection after silence and device loss, baud cycle and give-up
// (PROTOCOLS.md §1.4, §1.6, §6).
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <cmath>
#include <vector>

#include "drivers/arcos/client.hpp"
#include "drivers/arcos/emulator.hpp"
#include "tests/unit/arcos/test_support.hpp"

namespace teamscan::arcos {
namespace {

using test::bytes_of_packet;
using test::Loop;

struct Rig {
  explicit Rig(ArcosClientOptions co = {}, PioneerEmulatorOptions eo = {}) : client{co}, robot{eo} {}
  ArcosClient client;
  PioneerEmulator robot;
  Loop loop{client, robot};
  bool connect(Duration limit = 5s) {
    return loop.run_until([&] { return client.connected(); }, limit);
  }
};

TEST(ArcosClientEmulator, HandshakeOpensTheServerAndSipsFlow) {
  Rig r;
  ASSERT_TRUE(r.connect());
  EXPECT_EQ(r.client.identity().robot_class.view(), "Pioneer");
  EXPECT_EQ(r.client.identity().subclass.view(), "p3at-sh");
  EXPECT_DOUBLE_EQ(r.client.params().dist_conv_mm, 1.0);
  EXPECT_TRUE(r.robot.server_open());
  r.loop.run_for(2s);
  EXPECT_TRUE(r.robot.motors_enabled());  // ENABLE 1 after OPEN
  const auto s = r.client.statistics();
  EXPECT_EQ(s.connects, 1U);
  EXPECT_EQ(s.wrong_replies, 0U);
  EXPECT_EQ(s.sync_timeouts, 0U);
  EXPECT_NEAR(static_cast<double>(s.sips), 21.0, 1.0);  // 100 ms cycle
  EXPECT_EQ(s.parser.bad_checksum, 0U);
  // The handshake bytes on the wire, in order: SYNC0, SYNC1, SYNC2, OPEN 1, ENABLE 1 (A1-A3, A5, A6).
  const auto expect = test::hex("FA FB 03 00 00 00 FA FB 03 01 00 01 FA FB 03 02 00 02 FA FB 06 01 3B 01 00 02 3B FA FB 06 04 3B 01 00 05 3B");
  ASSERT_GE(r.loop.host_tx_bytes.size(), expect.size());
  EXPECT_TRUE(std::equal(expect.begin(), expect.end(), r.loop.host_tx_bytes.begin()));
}

TEST(ArcosClientEmulator, OldControllerSubclassSelectsItsDistConv) {
  PioneerEmulatorOptions eo;
  eo.subclass = "p3at";
  Rig r{{}, eo};
  ASSERT_TRUE(r.connect());
  EXPECT_DOUBLE_EQ(r.client.params().dist_conv_mm, 0.465);
  r.client.set_velocity(500, 0, r.loop.now);
  r.loop.run_for(4s);
  // Both sides convert with 0.465 mm per count: the client's odometry follows the robot's pose.
  EXPECT_NEAR(r.client.odometry().pose.x_m * 1000.0, r.robot.x_mm(), 0.465 + 500 * 0.1);
  EXPECT_GT(r.robot.x_mm(), 1800.0);
}

TEST(ArcosClientEmulator, RecoversFromAServerLeftOpen) {
  Rig first;
  ASSERT_TRUE(first.connect());
  // A new client process meets the robot whose server is still open: SIPs arrive first.
  ArcosClient second;
  Loop loop{second, first.robot};
  loop.now = first.loop.now;
  ASSERT_TRUE(loop.run_until([&] { return second.connected(); }, 10s));
  const auto s = second.statistics();
  EXPECT_GE(s.wrong_replies, 1U);
  EXPECT_EQ(s.connects, 1U);
  EXPECT_GE(first.robot.statistics().closes, 1U);  // the client's CLOSE stopped the stale server
  loop.run_for(1s);
  EXPECT_TRUE(second.connected());
}

TEST(ArcosClientEmulator, KeepAliveEveryHalfSecondAndNoWatchdogStop) {
  Rig r;
  ASSERT_TRUE(r.connect());
  r.client.set_velocity(200, 10, r.loop.now);
  r.loop.host_tx_times.clear();
  r.loop.run_for(10s);
  ASSERT_GE(r.loop.host_tx_times.size(), 19U);
  Duration max_gap{0};
  for (std::size_t i = 1; i < r.loop.host_tx_times.size(); ++i)
    max_gap = std::max(max_gap, r.loop.host_tx_times[i] - r.loop.host_tx_times[i - 1]);
  EXPECT_LE(max_gap, 500ms);
  EXPECT_EQ(r.robot.statistics().watchdog_stops, 0U);
  EXPECT_DOUBLE_EQ(r.robot.trans_vel_mm_s(), 200.0);  // motion command re-sent, still driving
  EXPECT_NEAR(r.robot.rot_vel_deg_s(), 10.0, 1e-9);
}

TEST(ArcosClientEmulator, WatchdogStopsTheRobotAfterTwoSecondsWithoutCommands) {
  Rig r;
  ASSERT_TRUE(r.connect());
  r.client.set_velocity(300, 0, r.loop.now);
  r.loop.run_for(1s);
  EXPECT_DOUBLE_EQ(r.robot.trans_vel_mm_s(), 300.0);
  // The host's commands stop reaching the robot (the client process hangs, the cable is cut).
  r.loop.host_to_device_up = false;
  const Time last_command = r.robot.last_command_time();
  ASSERT_TRUE(r.loop.run_until([&] { return r.robot.trans_vel_mm_s() == 0.0; }, 5s));
  EXPECT_GE(r.loop.now - last_command, 2000ms);
  EXPECT_LE(r.loop.now - last_command, 2000ms + 2ms);
  EXPECT_EQ(r.robot.statistics().watchdog_stops, 1U);
  EXPECT_TRUE(r.robot.server_open());  // the watchdog stops the motors, not the server
}

TEST(ArcosClientEmulator, DriveIntegratesOdometryFromSips) {
  Rig r;
  ASSERT_TRUE(r.connect());
  r.client.set_velocity(400, 0, r.loop.now);
  r.loop.run_for(5s);
  EXPECT_NEAR(r.client.odometry().pose.x_m * 1000.0, r.robot.x_mm(), 1.0 + 400 * 0.1);
  EXPECT_NEAR(r.client.odometry().trans_vel_mm_s, 400.0, 1.0);
  EXPECT_GT(r.client.latest_sip_time(), r.loop.now - 150ms);
  EXPECT_EQ(r.client.latest_sip().type, 0x33);
  // VEL2: left 200, right 100 -> 150 mm/s forward, turning right.
  r.client.set_wheel_velocities(200, 100, r.loop.now);
  r.loop.run_for(200ms);
  EXPECT_NEAR(r.robot.trans_vel_mm_s(), 150.0, 1e-9);
  EXPECT_LT(r.robot.rot_vel_deg_s(), 0.0);
  r.client.stop(r.loop.now);
  r.loop.run_for(200ms);
  EXPECT_EQ(r.robot.trans_vel_mm_s(), 0.0);
  EXPECT_EQ(r.robot.rot_vel_deg_s(), 0.0);
}

TEST(ArcosClientEmulator, ReconnectsAfterSilence) {
  ArcosClientOptions co;
  co.sip_timeout = 1000ms;
  Rig r{co};
  ASSERT_TRUE(r.connect());
  r.loop.device_to_host_up = false;  // SIPs stop arriving
  ASSERT_TRUE(r.loop.run_until([&] { return !r.client.connected(); }, 3s));
  EXPECT_EQ(r.client.statistics().silence_reconnects, 1U);
  r.loop.run_for(3s);
  r.loop.device_to_host_up = true;
  ASSERT_TRUE(r.connect(20s));
  EXPECT_EQ(r.client.statistics().connects, 2U);
  r.loop.run_for(1s);
  EXPECT_TRUE(r.client.connected());
}

TEST(ArcosClientEmulator, ReconnectsAfterRobotPowerCycle) {
  Rig r;
  ASSERT_TRUE(r.connect());
  r.client.set_velocity(100, 0, r.loop.now);
  r.loop.run_for(2s);
  const double x_before = r.client.odometry().pose.x_m;
  r.robot.power_cycle();  // server closed, counters at zero
  ASSERT_TRUE(r.loop.run_until([&] { return !r.client.connected(); }, 3s));
  ASSERT_TRUE(r.connect(20s));
  r.loop.run_for(500ms);
  // The integrated pose continues where it was (rebase), it does not jump to the new counters.
  EXPECT_NEAR(r.client.odometry().pose.x_m, x_before, 0.15);
}

TEST(ArcosClientEmulator, DeviceLossAndReturn) {
  Rig r;
  ASSERT_TRUE(r.connect());
  r.client.on_device_lost(r.loop.now);
  EXPECT_EQ(r.client.state(), ArcosClientState::kDeviceLost);
  r.loop.run_for(3s);
  EXPECT_EQ(r.client.state(), ArcosClientState::kDeviceLost);  // silent until the loop says so
  EXPECT_EQ(r.client.statistics().device_losses, 1U);
  r.client.on_device_back(r.loop.now);
  ASSERT_TRUE(r.connect(20s));
  EXPECT_EQ(r.client.statistics().connects, 2U);
}

TEST(ArcosClientEmulator, ShutdownClosesTheServer) {
  Rig r;
  ASSERT_TRUE(r.connect());
  r.client.set_velocity(300, 0, r.loop.now);
  r.loop.run_for(500ms);
  r.client.shutdown(r.loop.now);
  r.loop.run_for(100ms);
  EXPECT_FALSE(r.robot.server_open());
  EXPECT_EQ(r.robot.trans_vel_mm_s(), 0.0);
  EXPECT_EQ(r.client.state(), ArcosClientState::kShutdown);
  const std::size_t sent = r.loop.host_tx_bytes.size();
  r.loop.run_for(3s);
  EXPECT_EQ(r.loop.host_tx_bytes.size(), sent);  // no keep-alive after shutdown
  r.client.start(r.loop.now);
  ASSERT_TRUE(r.connect());
}

TEST(ArcosClientEmulator, SilentRobotCyclesBaudsDislodgesThenPausesAndStartsOver) {
  ArcosClientOptions co;
  co.retry_pause = 3s;
  Rig r{co};
  r.loop.device_to_host_up = false;  // the robot never answers
  // 10 silent tries of 1 s each plus the CLOSE cycles (5 × 50 ms) between them: about 12.5 s.
  r.loop.run_for(13s);
  auto s = r.client.statistics();
  EXPECT_EQ(s.sync_timeouts, 10U);
  EXPECT_EQ(s.give_ups, 1U);
  EXPECT_GE(s.baud_cycles, 8U);    // silent tries 2..9
  EXPECT_GE(s.dislodge_opens, 1U); // after more than 3 silent tries
  EXPECT_EQ(r.client.state(), ArcosClientState::kPaused);
  // CLOSE went out at every rate of ARIA's cycle.
  for (std::uint32_t b : {9600U, 38400U, 115200U, 19200U, 57600U}) {
    EXPECT_NE(std::find(r.loop.host_tx_bauds.begin(), r.loop.host_tx_bauds.end(), b), r.loop.host_tx_bauds.end()) << b;
  }
  // A daemon never gives up for good: after the pause it tries again and connects.
  r.loop.device_to_host_up = true;
  ASSERT_TRUE(r.connect(10s));
  EXPECT_EQ(r.client.baud(), 9600U);
}

TEST(ArcosClientEmulator, UnknownSubclassFallsBackOrRefuses) {
  PioneerEmulatorOptions eo;
  eo.subclass = "box";
  {
    Rig r{{}, eo};
    ASSERT_TRUE(r.connect());
    EXPECT_EQ(r.client.statistics().unknown_subclass, 1U);
    EXPECT_DOUBLE_EQ(r.client.params().dist_conv_mm, 1.0);
    EXPECT_EQ(r.client.params().subclass, "box");
  }
  {
    ArcosClientOptions co;
    co.allow_unknown_subclass = false;
    Rig r{co, eo};
    EXPECT_FALSE(r.connect(5s));
    EXPECT_GE(r.client.statistics().give_ups, 1U);
    EXPECT_FALSE(r.robot.server_open());
  }
  {
    ArcosClientOptions co;
    co.subclass_override = "p3at";
    Rig r{co, eo};
    ASSERT_TRUE(r.connect());
    EXPECT_DOUBLE_EQ(r.client.params().dist_conv_mm, 0.465);
  }
}

TEST(ArcosClientEmulator, ConfigAndEncoderPackets) {
  ArcosClientOptions co;
  co.request_config = true;
  Rig r{co};
  ASSERT_TRUE(r.connect());
  r.loop.run_for(300ms);
  ASSERT_TRUE(r.client.have_config());
  EXPECT_EQ(r.client.config().sip_cycle_ms, 100);
  EXPECT_EQ(r.client.config().watchdog_ms, 2000);
  EXPECT_EQ(r.client.config().subclass.view(), "p3at-sh");
  ASSERT_TRUE(r.client.send_command(make_command(Command::kEncoder, 2), r.loop.now));
  r.client.set_velocity(100, 0, r.loop.now);
  r.loop.run_for(1s);
  EXPECT_GE(r.client.statistics().encoder_packets, 9U);
  EXPECT_GT(r.client.latest_encoder().left, 0);
}

TEST(ArcosClientEmulator, MotionCommandTimeoutStopsTheRobot) {
  ArcosClientOptions co;
  co.motion_command_timeout = 600ms;  // RosAria's cmd_vel timeout (rosaria#51)
  Rig r{co};
  ASSERT_TRUE(r.connect());
  r.client.set_velocity(250, 0, r.loop.now);
  r.loop.run_for(400ms);
  EXPECT_DOUBLE_EQ(r.robot.trans_vel_mm_s(), 250.0);
  r.loop.run_for(400ms);
  EXPECT_EQ(r.robot.trans_vel_mm_s(), 0.0);
  EXPECT_EQ(r.client.statistics().motion_timeouts, 1U);
  EXPECT_TRUE(r.client.connected());
}

// ---- emulator alone ----

std::vector<std::uint8_t> drain(PioneerEmulator& e) {
  std::uint8_t buf[4096];
  const std::size_t n = e.take_tx(buf);
  return {buf, buf + n};
}

TEST(PioneerEmulator, OutOfSequenceSyncRestartsTheHandshake) {
  PioneerEmulator e;
  const Time t = Time::from_seconds(1);
  e.on_rx(make_command(Command::kSync0).span(), t);
  EXPECT_EQ(drain(e), test::hex("FA FB 03 00 00 00"));
  e.on_rx(make_command(Command::kSync2).span(), t);  // SYNC1 skipped
  EXPECT_TRUE(drain(e).empty());
  EXPECT_EQ(e.state(), PioneerState::kWaitSync0);
  EXPECT_EQ(e.statistics().handshake_restarts, 1U);
  e.on_rx(make_command(Command::kSync1).span(), t);  // not after SYNC0: ignored
  EXPECT_TRUE(drain(e).empty());
  e.on_rx(make_command(Command::kSync0).span(), t);
  e.on_rx(make_command(Command::kSync1).span(), t);
  e.on_rx(make_command(Command::kSync2).span(), t);
  auto out = drain(e);
  const auto expect_prefix = test::hex("FA FB 03 00 00 00 FA FB 03 01 00 01");
  ASSERT_GT(out.size(), expect_prefix.size());
  EXPECT_TRUE(std::equal(expect_prefix.begin(), expect_prefix.end(), out.begin()));
  EXPECT_EQ(e.state(), PioneerState::kReady);
  // Commands before OPEN are not obeyed and no SIPs flow.
  e.on_rx(make_command(Command::kVel, 100).span(), t);
  e.on_tick(t + 1s);
  EXPECT_TRUE(drain(e).empty());
}

TEST(PioneerEmulator, SipsEveryCycleAfterOpen) {
  PioneerEmulatorOptions o;
  o.sip_period = 50ms;
  PioneerEmulator e{o};
  Time t = Time::from_seconds(1);
  for (auto c : {Command::kSync0, Command::kSync1, Command::kSync2, Command::kOpen}) e.on_rx(make_command(c).span(), t);
  (void)drain(e);
  ArcosParser p;
  int sips = 0;
  for (int i = 0; i < 1000; ++i) {
    t += 1ms;
    e.on_tick(t);
    const auto out = drain(e);
    p.push(out, [&](const PacketView& v) { sips += is_sip_type(v.type) ? 1 : 0; });
  }
  EXPECT_EQ(sips, 21);  // at open, then every 50 ms for one second
  EXPECT_EQ(e.statistics().sips_sent, 21U);
}

struct FixedSource final : SipSource {
  RobotParams params;
  double x_mm = 0;
  int calls = 0;
  bool fill_sip(Time, SipPacket& sip) override {
    ++calls;
    fill_sip_motion(sip, params, x_mm, 0, 0, 300, 300);
    sip.battery_dv = 111;
    return true;
  }
};

TEST(PioneerEmulator, SipSourceDrivesTheSipContentWithFifteenBitWrap) {
  FixedSource src;
  src.params = params_for_subclass("p3at").value();
  src.x_mm = 40000.0;  // 86022 counts at 0.465 mm: wraps the 16-bit counter
  PioneerEmulatorOptions o;
  o.subclass = "p3at";
  PioneerEmulator e{o};
  e.set_sip_source(&src);
  const SipPacket s = e.make_sip(Time::from_seconds(1));
  EXPECT_EQ(src.calls, 1);
  EXPECT_EQ(s.battery_dv, 111);
  EXPECT_EQ(s.x_raw, static_cast<std::uint16_t>(86022 & 0xFFFF));
  EXPECT_EQ(s.left_vel, 300);
  EXPECT_EQ(s.type, 0x33);
  // The client-side unwrap of two consecutive source SIPs gives the true step.
  SipPacket a = s, b;
  fill_sip_motion(b, src.params, 40000.0 + 30.0, 0, 0, 300, 300);
  const long expected = std::lround(40030.0 / 0.465) - std::lround(40000.0 / 0.465);  // 86086 - 86022
  EXPECT_EQ(unwrap15(a.x_raw, b.x_raw), expected);
}

}  // namespace
}  // namespace teamscan::arcos

namespace teamscan::arcos {
namespace {

struct SkippingSource final : SipSource {
  int calls = 0;
  bool fill_sip(Time, SipPacket&) override { return ++calls % 2 == 0; }  // every other cycle
};

TEST(PioneerEmulator, SipSourceCanSkipACycle) {
  SkippingSource src;
  PioneerEmulator e;
  e.set_sip_source(&src);
  Time t = Time::from_seconds(1);
  for (auto c : {Command::kSync0, Command::kSync1, Command::kSync2, Command::kOpen}) e.on_rx(make_command(c).span(), t);
  for (int i = 0; i < 1000; ++i) {
    t += 1ms;
    e.on_tick(t);
  }
  EXPECT_EQ(src.calls, 11);  // at OPEN, then every 100 ms up to and including t + 1 s
  EXPECT_EQ(e.statistics().sips_sent, 5U);
}

}  // namespace
}  // namespace teamscan::arcos

namespace teamscan::arcos {
namespace {

struct SipLog {
  std::vector<std::vector<std::uint8_t>> sips;
  static void on_sip(void* self, const SipPacket& sip, const OdometryState&, Time) {
    const auto w = encode_sip(sip);
    static_cast<SipLog*>(self)->sips.emplace_back(w.bytes.begin(), w.bytes.begin() + static_cast<std::ptrdiff_t>(w.size));
  }
};

// A noisy cable (1 % of bytes flipped in both directions, §6 USB adapters): the client keeps its
// connection, every SIP it accepts is one the robot sent, and odometry follows the robot.
TEST(ArcosClientEmulator, NoisyLinkOnePercent) {
  Rig r;
  SipLog log;
  r.client.set_sip_callback(&SipLog::on_sip, &log);
  r.loop.corruption = 0.01;
  ASSERT_TRUE(r.connect(30s));
  r.client.set_velocity(300, 5, r.loop.now);
  r.loop.run_for(60s);
  EXPECT_GT(r.loop.corrupted_bytes, 100U);
  const auto s = r.client.statistics();
  std::printf("noisy link: %llu SIPs, %llu bad checksums, %llu connects, %llu silence reconnects, %llu wrong replies, robot: %llu watchdog stops %llu closes %llu commands\n",
              (unsigned long long)s.sips, (unsigned long long)s.parser.bad_checksum, (unsigned long long)s.connects,
              (unsigned long long)s.silence_reconnects, (unsigned long long)s.wrong_replies,
              (unsigned long long)r.robot.statistics().watchdog_stops, (unsigned long long)r.robot.statistics().closes,
              (unsigned long long)r.robot.statistics().commands);
  EXPECT_GT(s.parser.bad_checksum, 0U);
  EXPECT_GT(s.sips, 400U);  // of 600 sent; a 38-byte SIP survives 1 % flips with p = 0.68
  // Every accepted SIP is byte-identical to one the robot sent, in order.
  std::vector<std::vector<std::uint8_t>> sent;
  ArcosParser p;
  p.push(r.loop.device_tx_bytes, [&](const PacketView& v) {
    if (is_sip_type(v.type)) sent.emplace_back(v.wire.begin(), v.wire.end());
  });
  std::size_t k = 0;
  for (const auto& got : log.sips) {
    while (k < sent.size() && sent[k] != got) ++k;
    ASSERT_LT(k, sent.size()) << "a SIP the robot never sent was accepted";
    ++k;
  }
  EXPECT_NEAR(r.client.odometry().pose.x_m * 1000.0, r.robot.x_mm(), 50.0);
  EXPECT_NEAR(r.client.odometry().pose.y_m * 1000.0, r.robot.y_mm(), 50.0);
  EXPECT_GT(r.robot.statistics().commands, 100U);
  EXPECT_EQ(r.robot.statistics().watchdog_stops, 0U);  // keep-alives get through often enough
}

}  // namespace
}  // namespace teamscan::arcos

namespace teamscan::arcos {
namespace {

// A command whose count byte was corrupted upwards makes the receiver wait for bytes the host will
// not send for seconds; after the inter-byte timeout the robot re-scans and obeys what followed.
TEST(PioneerEmulator, CorruptedCountDoesNotStallCommands) {
  PioneerEmulatorOptions o;
  o.motors_enabled_at_open = true;
  PioneerEmulator e{o};
  Time t = Time::from_seconds(1);
  for (auto c : {Command::kSync0, Command::kSync1, Command::kSync2, Command::kOpen}) e.on_rx(make_command(c).span(), t);
  auto bad = bytes_of_packet(make_command(Command::kPulse));
  bad[2] = 0xC8;  // count 200: waits for 203 bytes
  e.on_rx(bad, t);
  e.on_rx(make_command(Command::kVel, 250).span(), t + 10ms);
  e.on_tick(t + 50ms);
  EXPECT_EQ(e.trans_vel_mm_s(), 0.0);  // still inside the suspect packet
  EXPECT_LE(e.next_deadline(), t + 10ms + o.inter_byte_timeout);
  e.on_tick(t + 10ms + o.inter_byte_timeout);
  EXPECT_DOUBLE_EQ(e.trans_vel_mm_s(), 250.0);
  EXPECT_EQ(e.statistics().parser.bad_length, 1U);
}


// §1.6 with the emulator alone: the robot stops exactly at the last command + the watchdog time, even
// when the next tick comes late, and stays there; its SIPs say velocity 0 and a frozen position.
struct SilenceRecorder final : SipSource {
  bool fill_sip(Time, SipPacket&) override { return true; }  // the emulator's own motion
  void on_client_silent(Time since) override { silences.push_back(since); }
  void on_client_back(Time at) override { backs.push_back(at); }
  std::vector<Time> silences, backs;
};

PioneerEmulatorOptions motors_on() {
  PioneerEmulatorOptions o;
  o.motors_enabled_at_open = true;
  return o;
}

void open_server(PioneerEmulator& e, Time t, SipSource* source) {
  e.set_sip_source(source);
  for (auto c : {Command::kSync0, Command::kSync1, Command::kSync2, Command::kOpen}) e.on_rx(make_command(c).span(), t);
  (void)drain(e);
}

TEST(PioneerEmulator, WatchdogFreezesThePoseAtTheDeadlineEvenWithALateTick) {
  SilenceRecorder rec;
  Time t = Time::from_seconds(1);
  PioneerEmulator e{motors_on()};
  open_server(e, t, &rec);
  e.on_rx(make_command(Command::kVel, 300).span(), t);
  const Time last_command = t;
  EXPECT_LE(e.next_deadline(), last_command + 2000ms);
  e.on_tick(t + 1000ms);
  EXPECT_NEAR(e.x_mm(), 300.0, 1e-6);
  EXPECT_FALSE(e.client_silent());
  // The feeder was starved: the next tick is 3 s late. The robot moved only until the deadline.
  e.on_tick(t + 5000ms);
  EXPECT_NEAR(e.x_mm(), 600.0, 1e-6);  // 300 mm/s × 2 s
  EXPECT_EQ(e.trans_vel_mm_s(), 0.0);
  EXPECT_TRUE(e.client_silent());
  EXPECT_EQ(e.client_silent_since(), last_command + 2000ms);
  ASSERT_EQ(rec.silences.size(), 1U);
  EXPECT_EQ(rec.silences[0], last_command + 2000ms);
  EXPECT_EQ(e.statistics().watchdog_stops, 1U);
  EXPECT_EQ(e.statistics().client_silences, 1U);
  const SipPacket sip = e.make_sip(t + 6000ms);
  EXPECT_EQ(sip.left_vel, 0);
  EXPECT_EQ(sip.right_vel, 0);
  e.on_tick(t + 9000ms);
  EXPECT_NEAR(e.x_mm(), 600.0, 1e-6);  // frozen
  EXPECT_EQ(rec.silences.size(), 1U);  // one silence, told once
}

TEST(PioneerEmulator, TheWatchdogIsDueEvenWhenTheRobotIsNotCommandedToMove) {
  // The simulator moves the robot through the SIP source, not by commands: the silence still counts.
  SilenceRecorder rec;
  const Time t = Time::from_seconds(1);
  PioneerEmulator e{motors_on()};
  open_server(e, t, &rec);
  EXPECT_LE(e.next_deadline(), t + 2000ms);
  e.on_tick(t + 1999ms);
  EXPECT_TRUE(rec.silences.empty());
  e.on_tick(t + 2000ms);
  ASSERT_EQ(rec.silences.size(), 1U);
  EXPECT_EQ(rec.silences[0], t + 2000ms);
  EXPECT_EQ(e.statistics().watchdog_stops, 0U);  // nothing was commanded to move
  EXPECT_TRUE(e.server_open());                  // the watchdog stops the robot, not the server
}

TEST(PioneerEmulator, AnyCommandEndsTheSilenceAndKeepAliveNeverStartsOne) {
  SilenceRecorder rec;
  Time t = Time::from_seconds(1);
  PioneerEmulator e{motors_on()};
  open_server(e, t, &rec);
  for (int i = 0; i < 20; ++i) {  // PULSE every 500 ms for 10 s: never silent
    t += 500ms;
    e.on_tick(t);
    e.on_rx(make_command(Command::kPulse).span(), t);
  }
  EXPECT_TRUE(rec.silences.empty());
  e.on_tick(t + 2500ms);
  ASSERT_EQ(rec.silences.size(), 1U);
  e.on_rx(make_command(Command::kPulse).span(), t + 3000ms);
  ASSERT_EQ(rec.backs.size(), 1U);
  EXPECT_EQ(rec.backs[0], t + 3000ms);
  EXPECT_FALSE(e.client_silent());
  // The robot obeys motion again.
  e.on_rx(make_command(Command::kVel, 100).span(), t + 3000ms);
  e.on_tick(t + 4000ms);
  EXPECT_EQ(e.trans_vel_mm_s(), 100.0);
}

TEST(PioneerEmulator, CloseStopsTheRobotUntilTheNextOpen) {
  SilenceRecorder rec;
  const Time t = Time::from_seconds(1);
  PioneerEmulator e{motors_on()};
  open_server(e, t, &rec);
  e.on_rx(make_command(Command::kClose).span(), t + 100ms);
  ASSERT_EQ(rec.silences.size(), 1U);
  EXPECT_EQ(rec.silences[0], t + 100ms);
  EXPECT_FALSE(e.server_open());
  for (auto c : {Command::kSync0, Command::kSync1, Command::kSync2, Command::kOpen}) e.on_rx(make_command(c).span(), t + 500ms);
  ASSERT_EQ(rec.backs.size(), 1U);
  EXPECT_EQ(rec.backs[0], t + 500ms);
}

}  // namespace
}  // namespace teamscan::arcos
