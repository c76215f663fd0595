// HIL: ArcosClient over a real SerialPort (termios on a pty slave) against the emulated Pioneer on the
// pty master (serial::PtyRunner, paced at 9600 baud): handshake, SIPs for seconds, unplug -> device
// loss reported -> replug -> reconnection (PROTOCOLS.md §1.4, §6).
#include <gtest/gtest.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <string>

#include "common/clock.hpp"
#include "drivers/arcos/port_driver.hpp"

namespace teamscan::arcos {
namespace {

struct TempDir {
  std::filesystem::path path;
  TempDir() {
    std::string tmpl = (std::filesystem::temp_directory_path() / "teamscan-arcos-XXXXXX").string();
    path = ::mkdtemp(tmpl.data());
  }
  ~TempDir() {
    std::error_code ec;
    std::filesystem::remove_all(path, ec);
  }
};

template <class Pred>
bool step_until(ArcosPortDriver& d, Pred pred, Duration limit) {
  const Time end = now_monotonic() + limit;
  while (now_monotonic() < end) {
    d.step(10ms);
    if (pred()) return true;
  }
  return false;
}

TEST(ArcosHil, HandshakeStreamingUnplugReplug) {
  TempDir dir;
  const std::string link = (dir.path / "ttyPioneer").string();
  PioneerEmulator robot;
  auto runner = run_pioneer_on_pty(robot, link);
  ASSERT_TRUE(runner.ok()) << runner.error().what;
  auto& pty = *runner.value();

  ArcosClient client;
  ArcosPortDriver driver{client, link.c_str(), 200ms};
  ASSERT_TRUE(step_until(driver, [&] { return client.connected(); }, 10s)) << to_string(client.state());
  EXPECT_EQ(client.identity().subclass.view(), "p3at-sh");

  // Stream for 3 s while driving.
  client.set_velocity(300, 0, now_monotonic());
  const std::uint64_t sips_before = client.statistics().sips;
  const Time t0 = now_monotonic();
  driver.run_until(t0 + 3s, 10ms);
  const double seconds = to_seconds(now_monotonic() - t0);
  const auto sips = static_cast<double>(client.statistics().sips - sips_before);
  // Streaming, not timing: a loaded machine may deliver fewer than the nominal 10 per second.
  std::printf("SIPs over the pty: %.1f per second\n", sips / seconds);
  EXPECT_GE(sips, 15.0);
  EXPECT_EQ(client.statistics().parser.bad_checksum, 0U);
  EXPECT_TRUE(client.connected());
  const double robot_x_mm = pty.locked([&] { return robot.x_mm(); });
  EXPECT_GT(robot_x_mm, 600.0);
  EXPECT_NEAR(client.odometry().pose.x_m * 1000.0, robot_x_mm, 100.0);  // one SIP period of lag at most

  // Unplug: the client is told by the driver (EIO/hang-up on the slave), not by a timeout.
  pty.unplug();
  ASSERT_TRUE(step_until(driver, [&] { return client.state() == ArcosClientState::kDeviceLost; }, 3s));
  EXPECT_EQ(client.statistics().device_losses, 1U);
  EXPECT_FALSE(driver.port_open());
  driver.run_until(now_monotonic() + 500ms, 10ms);
  EXPECT_EQ(client.state(), ArcosClientState::kDeviceLost);

  // Replug: the robot's server is still open (SIPs first), the client recovers and reconnects.
  ASSERT_TRUE(pty.replug().ok());
  ASSERT_TRUE(step_until(driver, [&] { return client.connected(); }, 15s)) << to_string(client.state());
  EXPECT_EQ(client.statistics().connects, 2U);
  EXPECT_GE(driver.statistics().opens, 2U);
  const std::uint64_t after = client.statistics().sips;
  driver.run_until(now_monotonic() + 1s, 10ms);
  EXPECT_GE(client.statistics().sips - after, 7U);

  client.shutdown(now_monotonic());
  driver.run_until(now_monotonic() + 300ms, 10ms);
  EXPECT_FALSE(pty.locked([&] { return robot.server_open(); }));
  pty.stop();
}

}  // namespace
}  // namespace teamscan::arcos
