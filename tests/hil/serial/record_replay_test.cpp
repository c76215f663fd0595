// Record -> replay round trip through the real `teamscan` binary: a scripted host talks to a scripted
// device (PtyRunner) through `teamscan record`, including a baud switch the proxy must follow; then
// `teamscan replay` of that capture serves the same host session and exits 0, exits 2 when the host
// diverges and 3 when it stays silent.
#include <gtest/gtest.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <string>
#include <thread>
#include <vector>

#include "common/capture.hpp"
#include "common/clock.hpp"
#include "drivers/serial/pty_runner.hpp"
#include "drivers/serial/serial_port.hpp"
#include "tests/hil/serial/pty_test_util.hpp"
#include "tests/unit/serial/scripted_endpoint.hpp"

namespace teamscan::serial {
namespace {

using testing::ScriptedEndpoint;
using testing::spawn;
using testing::teamscan_binary;
using testing::wait_exit;
using testing::wait_for_path;
using testing::TempDir;
using Bytes = std::vector<std::uint8_t>;
using namespace std::chrono_literals;

// The scripted protocol: frames [len, payload...]. The device answers [len, payload ^ 0x5A]; the
// payload {0x20, 0x01} asks for 38400 baud: the device answers {0x01, 0x06} at the old rate, then
// switches (the LMS pattern, PROTOCOLS.md §2.11).
void install_device_protocol(ScriptedEndpoint& device, Bytes& inbox) {
  device.responder = [&inbox](ScriptedEndpoint& self, std::span<const std::uint8_t> bytes, Time) {
    inbox.insert(inbox.end(), bytes.begin(), bytes.end());
    while (!inbox.empty() && inbox.size() >= 1u + inbox[0]) {
      const Bytes payload(inbox.begin() + 1, inbox.begin() + 1 + inbox[0]);
      inbox.erase(inbox.begin(), inbox.begin() + 1 + inbox[0]);
      if (payload == Bytes{0x20, 0x01}) {
        self.send_now({0x01, 0x06});
        self.switch_baud_after_send(38400);
        continue;
      }
      Bytes reply{static_cast<std::uint8_t>(payload.size())};
      for (auto b : payload) reply.push_back(static_cast<std::uint8_t>(b ^ 0x5A));
      self.send_now(reply);
    }
  };
}

Bytes expected_reply(const Bytes& frame) {
  if (frame == Bytes{0x02, 0x20, 0x01}) return {0x01, 0x06};
  Bytes reply{frame[0]};
  for (std::size_t i = 1; i < frame.size(); ++i) reply.push_back(static_cast<std::uint8_t>(frame[i] ^ 0x5A));
  return reply;
}

struct Session {
  Bytes sent, received;
  bool all_replies_right = true;
};

// The host: three frames at 9600, the switch, three frames at 38400. `diverge` changes a byte of the
// fifth frame (after the switch).
Session host_session(const std::string& path, bool diverge) {
  Session s;
  const std::vector<Bytes> frames = {
      {0x03, 0x10, 0x11, 0x12}, {0x01, 0xFF}, {0x05, 0x00, 0x0A, 0x0D, 0x7E, 0x80},
      {0x02, 0x20, 0x01},  // switch to 38400
      {0x04, 0x30, 0x31, 0x32, 0x33}, {0x02, 0xAA, 0x55}, {0x03, 0x01, 0x02, 0x03}};
  auto port = SerialPort::open(path.c_str(), 9600);
  if (!port) {
    s.all_replies_right = false;
    return s;
  }
  for (std::size_t i = 0; i < frames.size(); ++i) {
    Bytes frame = frames[i];
    if (diverge && i == 4) frame[2] = 0x99;
    if (!port->write_all(frame, 1s)) break;
    s.sent.insert(s.sent.end(), frame.begin(), frame.end());
    const Bytes want = expected_reply(frame);
    Bytes got;
    const Time deadline = now_monotonic() + (diverge ? 1s : 3s);
    while (got.size() < want.size() && now_monotonic() < deadline) {
      std::uint8_t buf[64];
      auto n = port->read(std::span<std::uint8_t>{buf, want.size() - got.size()}, 20ms);
      if (!n) break;
      got.insert(got.end(), buf, buf + *n);
    }
    s.received.insert(s.received.end(), got.begin(), got.end());
    if (got != want) {
      s.all_replies_right = false;
      break;
    }
    if (frame == Bytes{0x02, 0x20, 0x01} && !port->set_baud(38400)) s.all_replies_right = false;
  }
  return s;
}

TEST(RecordReplayTest, RecordedSessionReplaysAndDivergenceIsCaught) {
  TempDir dir;
  const std::string device_link = (dir.path / "ttyDevice").string();
  const std::string record_link = (dir.path / "ttyRecord").string();
  const std::string replay_link = (dir.path / "ttyReplay").string();
  const std::string cap_path = (dir.path / "session.cap").string();

  // 1. The device on a pty, the recorder between it and the host.
  ScriptedEndpoint device{9600};
  Bytes inbox;
  install_device_protocol(device, inbox);
  auto runner = PtyRunner::create(device, PtyRunnerOptions{.link_path = device_link});
  ASSERT_TRUE(runner.ok());
  ASSERT_TRUE((*runner)->start().ok());
  const pid_t recorder = spawn({teamscan_binary(), "record", "--device", device_link, "--link", record_link, "--out",
                               cap_path, "--device-kind", "lms200", "--baud", "9600", "--duration", "30"});
  ASSERT_GT(recorder, 0);
  ASSERT_TRUE(wait_for_path(record_link, 5s));
  const Session recorded = host_session(record_link, false);
  ::kill(recorder, SIGTERM);
  EXPECT_EQ(wait_exit(recorder, 5s), 0);
  (*runner)->stop();
  EXPECT_TRUE(recorded.all_replies_right);  // the proxy followed the host to 38400: no garbling
  EXPECT_EQ((*runner)->stats().garbled_bytes, 0u);

  auto cap = load_capture(cap_path);
  ASSERT_TRUE(cap.ok()) << cap.error().what;
  EXPECT_EQ(cap->device, DeviceKind::lms200);
  EXPECT_EQ(cap->bytes(CaptureDirection::tx), recorded.sent);
  EXPECT_EQ(cap->bytes(CaptureDirection::rx), recorded.received);
  std::vector<std::uint32_t> bauds;
  for (const auto& r : cap->records)
    if (r.kind == CaptureRecord::Kind::baud) bauds.push_back(r.baud);
  EXPECT_EQ(bauds, (std::vector<std::uint32_t>{9600, 38400}));

  // 2. Replay serves the same session to the same host.
  {
    const pid_t replay = spawn({teamscan_binary(), "replay", cap_path, "--link", replay_link, "--timeout", "5"});
    ASSERT_GT(replay, 0);
    ASSERT_TRUE(wait_for_path(replay_link, 5s));
    const Session replayed = host_session(replay_link, false);
    EXPECT_EQ(wait_exit(replay, 10s), 0);
    EXPECT_TRUE(replayed.all_replies_right);
    EXPECT_EQ(replayed.sent, recorded.sent);
    EXPECT_EQ(replayed.received, recorded.received);
  }
  // 3. A host that sends something else makes replay fail with 2.
  {
    const pid_t replay = spawn({teamscan_binary(), "replay", cap_path, "--link", replay_link, "--timeout", "5", "--quiet"});
    ASSERT_GT(replay, 0);
    ASSERT_TRUE(wait_for_path(replay_link, 5s));
    const Session diverged = host_session(replay_link, true);
    EXPECT_EQ(wait_exit(replay, 10s), 2);
    EXPECT_FALSE(diverged.all_replies_right);
  }
  // 4. A host that opens the port and says nothing makes replay fail with 3.
  {
    const pid_t replay = spawn({teamscan_binary(), "replay", cap_path, "--link", replay_link, "--timeout", "0.3", "--quiet"});
    ASSERT_GT(replay, 0);
    ASSERT_TRUE(wait_for_path(replay_link, 5s));
    auto silent = SerialPort::open(replay_link.c_str(), 9600);
    EXPECT_TRUE(silent.ok());
    EXPECT_EQ(wait_exit(replay, 10s), 3);
  }
}

TEST(RecordReplayTest, ReplayKeepsTheCapturedDelayScaledBySpeed) {
  // The device answered 300 ms after the host's request; a device-first greeting opens the capture.
  TempDir dir;
  const std::string cap_path = (dir.path / "timed.cap").string();
  std::FILE* f = std::fopen(cap_path.c_str(), "w");
  ASSERT_NE(f, nullptr);
  std::fputs("#teamscan-capture 1\n#device arcos\n#baud 0 9600\n20000 rx 55\n1000000 tx 01 02\n1300000 rx 06\n", f);
  std::fclose(f);
  for (const char* speed : {"1", "3"}) {
    SCOPED_TRACE(speed);
    const std::string link = (dir.path / (std::string{"ttyT"} + speed)).string();
    const pid_t replay = spawn({teamscan_binary(), "replay", cap_path, "--link", link, "--speed", speed, "--quiet"});
    ASSERT_GT(replay, 0);
    ASSERT_TRUE(wait_for_path(link, 5s));
    auto port = SerialPort::open(link.c_str(), 9600);
    ASSERT_TRUE(port.ok());
    std::uint8_t buf[4];
    auto greeting = port->read(buf, 3s);
    ASSERT_TRUE(greeting.ok());
    ASSERT_EQ(*greeting, 1u);
    EXPECT_EQ(buf[0], 0x55);
    const Time asked = now_monotonic();
    ASSERT_TRUE(port->write_all(Bytes{0x01, 0x02}, 1s).ok());
    auto answer = port->read(buf, 3s);
    const Duration took = now_monotonic() - asked;
    ASSERT_TRUE(answer.ok());
    ASSERT_EQ(*answer, 1u);
    EXPECT_EQ(buf[0], 0x06);
    // Never earlier than the captured 300 ms, scaled by 1/speed (a lower bound only).
    EXPECT_GE(took, std::string{speed} == "1" ? Duration{300ms} : Duration{100ms});
    EXPECT_EQ(wait_exit(replay, 10s), 0);
  }
}

TEST(RecordReplayTest, RecordReportsAMissingDeviceAndReplayAMalformedCapture) {
  TempDir dir;
  const pid_t rec = spawn({teamscan_binary(), "record", "--device", (dir.path / "nothing").string(), "--link",
                           (dir.path / "l").string(), "--out", (dir.path / "x.cap").string()});
  ASSERT_GT(rec, 0);
  EXPECT_EQ(wait_exit(rec, 5s), 1);
  const std::string bad = (dir.path / "bad.cap").string();
  std::FILE* f = std::fopen(bad.c_str(), "w");
  ASSERT_NE(f, nullptr);
  std::fputs("#teamscan-capture 1\n#device arcos\n12 rx ZZ\n", f);
  std::fclose(f);
  const pid_t rep = spawn({teamscan_binary(), "replay", bad, "--link", (dir.path / "r").string(), "--quiet"});
  ASSERT_GT(rep, 0);
  EXPECT_EQ(wait_exit(rep, 5s), 1);
}

}  // namespace
}  // namespace teamscan::serial
