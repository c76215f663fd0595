// ArcosClient against PioneerEmulator over serial::VirtualLink: simulated 8N1 byte timing at 9600 baud
// and garbage on a rate mismatch. Covers ARIA's CLOSE-at-every-rate recovery (PROTOCOLS.md §1.4) for a
// robot an earlier client left at another rate with HOSTBAUD (§1.1).
#include <gtest/gtest.h>

#include "drivers/arcos/client.hpp"
#include "drivers/arcos/emulator.hpp"
#include "drivers/serial/virtual_link.hpp"

namespace teamscan::arcos {
namespace {

TEST(ArcosVirtualLink, HandshakeAndSipsWithByteTiming) {
  ArcosClient client;
  PioneerEmulator robot;
  serial::VirtualLink link{client, robot, {.device = DeviceKind::arcos, .start = Time::from_seconds(10)}};
  link.run_for(3s);
  ASSERT_TRUE(client.connected()) << to_string(client.state());
  const auto s = client.statistics();
  EXPECT_EQ(s.connects, 1U);
  EXPECT_EQ(s.parser.bad_checksum, 0U);
  EXPECT_GE(s.sips, 20U);
  // A SIP of 38 bytes takes 39.6 ms at 9600 baud: it arrives that long after the robot queued it.
  EXPECT_GT(link.stats().bytes_to_host, 20U * 38U);
  EXPECT_EQ(link.stats().garbled_bytes, 0U);
}

TEST(ArcosVirtualLink, RecoversARobotLeftAtAnotherRate) {
  PioneerEmulator robot;
  {
    // An earlier client connects, switches the robot to 38400 and dies without CLOSE.
    ArcosClient first;
    serial::VirtualLink link{first, robot, {.device = DeviceKind::arcos, .start = Time::from_seconds(10)}};
    link.run_for(3s);
    ASSERT_TRUE(first.connected());
    ASSERT_TRUE(first.send_command(make_command(Command::kHostBaud, 2), link.now()));
    link.run_for(50ms);
    ASSERT_EQ(robot.baud(), 38400U);
    ASSERT_TRUE(robot.server_open());
  }
  ArcosClient second;
  serial::VirtualLink link{second, robot, {.device = DeviceKind::arcos, .start = Time::from_seconds(20)}};
  link.run_for(20s);
  ASSERT_TRUE(second.connected()) << to_string(second.state());
  const auto s = second.statistics();
  EXPECT_GE(s.sync_timeouts, 2U);  // silent at 9600 until the cycle reached 38400
  EXPECT_GE(s.baud_cycles, 1U);
  EXPECT_GE(robot.statistics().closes, 1U);
  EXPECT_EQ(robot.baud(), 9600U);  // CLOSE put the robot back to its power-up rate
  EXPECT_GT(link.stats().garbled_bytes, 0U);
  EXPECT_EQ(s.connects, 1U);
}

}  // namespace
}  // namespace teamscan::arcos
