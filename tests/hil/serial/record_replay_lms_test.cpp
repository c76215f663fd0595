// Record -> replay with the real LMS models: the LMS client brings the emulated scanner (PtyRunner) up
// to 500 kBd streaming through `teamscan record`, which must follow the 9600 -> 500000 switch; then
// `teamscan replay` of that capture serves a fresh client the same bring-up and the same scans.
#include <gtest/gtest.h>

#include <array>
#include <functional>

#include "common/capture.hpp"
#include "common/clock.hpp"
#include "drivers/lms200/client.hpp"
#include "drivers/lms200/emulator.hpp"
#include "drivers/serial/pty_runner.hpp"
#include "drivers/serial/serial_port.hpp"
#include "tests/hil/serial/pty_test_util.hpp"

namespace teamscan::serial {
namespace {

using testing::spawn;
using testing::teamscan_binary;
using testing::TempDir;
using testing::wait_exit;
using testing::wait_for_path;
using namespace std::chrono_literals;

struct HostResult {
  bool streamed = false;
  std::uint64_t scans = 0;
  std::uint32_t final_baud = 0;
};

// The host I/O loop around LmsClient (rate first, then bytes) until `done()` or 20 s.
HostResult run_lms_host(const std::string& path, const std::function<bool(const lms200::LmsClient&)>& done) {
  HostResult r;
  auto port = SerialPort::open(path.c_str(), 9600);
  if (!port) return r;
  lms200::LmsClient client{};
  client.start(now_monotonic());
  std::array<std::uint8_t, 4096> buf{};
  const Time give_up = now_monotonic() + 20s;
  while (now_monotonic() < give_up && !done(client)) {
    const std::size_t n_tx = client.take_tx(buf);
    if (client.baud() != port->baud() && !port->set_baud(client.baud())) break;
    if (n_tx > 0 && !port->write_all(std::span{buf}.first(n_tx), 1s)) break;
    const Duration wait = std::clamp(client.next_deadline() - now_monotonic(), Duration::zero(), Duration{5ms});
    auto n = port->read(buf, wait);
    if (!n) break;
    if (*n > 0) client.on_rx(std::span{buf}.first(*n), now_monotonic());
    if (client.next_deadline() <= now_monotonic()) client.on_tick(now_monotonic());
    r.streamed = r.streamed || client.streaming();
  }
  r.scans = client.statistics().scans;
  r.final_baud = port->baud();
  return r;
}

TEST(RecordReplayLmsTest, BringUpAndStreamReplayToAFreshClient) {
  TempDir dir;
  const std::string device_link = (dir.path / "ttyLMS").string();
  const std::string record_link = (dir.path / "ttyRec").string();
  const std::string replay_link = (dir.path / "ttyReplay").string();
  const std::string cap_path = (dir.path / "lms.cap").string();

  lms200::LmsEmulatorOptions eo;
  eo.pace_output = false;  // the runner paces the line
  lms200::LmsEmulator device{eo};
  device.power_up(now_monotonic());
  auto runner = PtyRunner::create(device, PtyRunnerOptions{.link_path = device_link});
  ASSERT_TRUE(runner.ok());
  ASSERT_TRUE((*runner)->start().ok());
  const pid_t recorder = spawn({teamscan_binary(), "record", "--device", device_link, "--link", record_link, "--out",
                               cap_path, "--device-kind", "lms200", "--duration", "30"});
  ASSERT_GT(recorder, 0);
  ASSERT_TRUE(wait_for_path(record_link, 5s));
  const HostResult recorded = run_lms_host(record_link, [](const lms200::LmsClient& c) { return c.statistics().scans >= 40; });
  ::kill(recorder, SIGTERM);
  EXPECT_EQ(wait_exit(recorder, 5s), 0);
  (*runner)->stop();
  ASSERT_TRUE(recorded.streamed);
  EXPECT_EQ(recorded.final_baud, 500000u);
  EXPECT_EQ((*runner)->stats().garbled_bytes, 0u);  // the proxy switched the device side in time

  auto cap = load_capture(cap_path);
  ASSERT_TRUE(cap.ok()) << cap.error().what;
  std::vector<std::uint32_t> bauds;
  for (const auto& r : cap->records)
    if (r.kind == CaptureRecord::Kind::baud) bauds.push_back(r.baud);
  ASSERT_GE(bauds.size(), 2u);
  EXPECT_EQ(bauds.front(), 9600u);
  EXPECT_EQ(bauds.back(), 500000u);

  // Replay: the fresh client gets the same session; it runs until replay has served everything.
  const pid_t replay = spawn({teamscan_binary(), "replay", cap_path, "--link", replay_link, "--timeout", "5"});
  ASSERT_GT(replay, 0);
  ASSERT_TRUE(wait_for_path(replay_link, 5s));
  int replay_rc = -2;
  const HostResult replayed = run_lms_host(replay_link, [&](const lms200::LmsClient&) {
    int status = 0;
    if (::waitpid(replay, &status, WNOHANG) == replay) replay_rc = WIFEXITED(status) ? WEXITSTATUS(status) : 128;
    return replay_rc != -2;
  });
  if (replay_rc == -2) replay_rc = wait_exit(replay, 10s);
  EXPECT_EQ(replay_rc, 0);
  EXPECT_TRUE(replayed.streamed);
  EXPECT_EQ(replayed.final_baud, 500000u);
  // Every scan the recorded client got (and any the recorder saw after it stopped reading) reached
  // the replayed client.
  EXPECT_GE(replayed.scans, recorded.scans);
}

}  // namespace
}  // namespace teamscan::serial
