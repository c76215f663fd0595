// PtyRunner over real pseudo-terminals: line pacing (lower bound only), garbling on a rate mismatch,
// unplug/replug, blocking and background modes, capture recording.
#include "drivers/serial/pty_runner.hpp"

#include <gtest/gtest.h>

#include <filesystem>
#include <thread>

#include "common/clock.hpp"
#include "drivers/serial/serial_port.hpp"
#include "tests/hil/serial/pty_test_util.hpp"
#include "tests/unit/serial/scripted_endpoint.hpp"

namespace teamscan::serial {
namespace {

using testing::ScriptedEndpoint;
using testing::TempDir;
using Bytes = std::vector<std::uint8_t>;
using namespace std::chrono_literals;

Bytes pattern(std::size_t n) {
  Bytes b(n);
  for (std::size_t i = 0; i < n; ++i) b[i] = static_cast<std::uint8_t>(i * 7 + 3);
  return b;
}

// Reads until `want` bytes, an error, or `timeout`.
Bytes read_port(SerialPort& port, std::size_t want, Duration timeout) {
  Bytes out;
  const Time deadline = now_monotonic() + timeout;
  while (out.size() < want && now_monotonic() < deadline) {
    std::uint8_t buf[512];
    auto n = port.read(buf, 20ms);
    if (!n) break;
    out.insert(out.end(), buf, buf + *n);
  }
  return out;
}

// A device that answers any received bytes with `reply`.
void answer_with(ScriptedEndpoint& device, Bytes reply) {
  device.responder = [reply](ScriptedEndpoint& self, std::span<const std::uint8_t>, Time) { self.send_now(reply); };
}

TEST(PtyRunnerTest, DeviceBytesTakeAtLeastTheirLineTime) {
  for (std::uint32_t baud : {9600u, 38400u}) {
    SCOPED_TRACE(baud);
    ScriptedEndpoint device{baud};
    const Bytes reply = pattern(200);
    answer_with(device, reply);
    auto runner = PtyRunner::create(device);
    ASSERT_TRUE(runner.ok()) << runner.error().what;
    ASSERT_TRUE((*runner)->start().ok());
    auto host = SerialPort::open((*runner)->host_path().c_str(), baud);
    ASSERT_TRUE(host.ok());
    const Time asked = now_monotonic();
    ASSERT_TRUE(host->write_all(Bytes{'?'}, 1s).ok());
    const Bytes got = read_port(*host, reply.size(), 5s);
    const Duration took = now_monotonic() - asked;
    (*runner)->stop();
    EXPECT_EQ(got, reply);
    // A real UART cannot deliver 200 bytes faster than 200 x 10 bits at the rate (lower bound only).
    EXPECT_GE(took, serial_transmission_time(200, baud));
    EXPECT_EQ((*runner)->stats().bytes_to_host, 200u);
    EXPECT_EQ((*runner)->stats().garbled_bytes, 0u);
  }
}

TEST(PtyRunnerTest, RateMismatchGarblesBothWaysUntilTheHostMatchesTheDevice) {
  ScriptedEndpoint device{9600};
  const Bytes reply = pattern(20);
  answer_with(device, reply);
  auto runner = PtyRunner::create(device);
  ASSERT_TRUE(runner.ok());
  ASSERT_TRUE((*runner)->start().ok());
  auto host = SerialPort::open((*runner)->host_path().c_str(), 38400);  // wrong rate
  ASSERT_TRUE(host.ok());

  const Bytes request{0x02, 0x00, 0x02, 0x00, 0x20, 0x48};
  ASSERT_TRUE(host->write_all(request, 1s).ok());
  const Bytes got = read_port(*host, reply.size(), 3s);
  ASSERT_EQ(got.size(), reply.size());
  for (std::size_t i = 0; i < got.size(); ++i) EXPECT_NE(got[i], reply[i]) << i;
  const Bytes at_device = (*runner)->locked([&] { return device.received_bytes(); });
  ASSERT_EQ(at_device.size(), request.size());
  for (std::size_t i = 0; i < request.size(); ++i) EXPECT_NE(at_device[i], request[i]) << i;

  // The host probes the next rate (as clients do, PROTOCOLS.md §1.1/§2.11): now everything is intact.
  ASSERT_TRUE(host->set_baud(9600).ok());
  (*runner)->locked([&] { device.received.clear(); });
  ASSERT_TRUE(host->write_all(request, 1s).ok());
  EXPECT_EQ(read_port(*host, reply.size(), 3s), reply);
  (*runner)->stop();
  EXPECT_EQ((*runner)->locked([&] { return device.received_bytes(); }), request);
  EXPECT_EQ((*runner)->stats().garbled_bytes, 26u);
  EXPECT_EQ((*runner)->stats().host_baud, 9600u);
}

TEST(PtyRunnerTest, UnplugIsSeenByTheHostAndReplugServesTheSameLink) {
  TempDir dir;
  const std::string link = (dir.path / "ttyPioneer").string();
  ScriptedEndpoint device{115200};
  answer_with(device, {0xFA, 0xFB});
  auto runner = PtyRunner::create(device, PtyRunnerOptions{.link_path = link});
  ASSERT_TRUE(runner.ok());
  EXPECT_EQ((*runner)->host_path(), link);
  ASSERT_TRUE((*runner)->start().ok());
  auto host = SerialPort::open(link.c_str(), 115200);
  ASSERT_TRUE(host.ok());
  ASSERT_TRUE(host->write_all(Bytes{1}, 1s).ok());
  EXPECT_EQ(read_port(*host, 2, 2s), (Bytes{0xFA, 0xFB}));

  (*runner)->unplug();
  EXPECT_FALSE((*runner)->plugged());
  EXPECT_FALSE(std::filesystem::exists(std::filesystem::symlink_status(link)));
  std::uint8_t buf[4];
  EXPECT_FALSE(host->read(buf, 500ms).ok());

  ASSERT_TRUE((*runner)->replug().ok());
  EXPECT_TRUE((*runner)->plugged());
  auto again = SerialPort::open(link.c_str(), 115200);
  ASSERT_TRUE(again.ok()) << again.error().what;
  ASSERT_TRUE(again->write_all(Bytes{2}, 1s).ok());
  EXPECT_EQ(read_port(*again, 2, 2s), (Bytes{0xFA, 0xFB}));

  // Replug with a reset device: the new model answers from then on.
  ScriptedEndpoint fresh{115200};
  answer_with(fresh, {0x06});
  ASSERT_TRUE((*runner)->replug(&fresh).ok());
  auto third = SerialPort::open(link.c_str(), 115200);
  ASSERT_TRUE(third.ok());
  ASSERT_TRUE(third->write_all(Bytes{3}, 1s).ok());
  EXPECT_EQ(read_port(*third, 1, 2s), Bytes{0x06});
  (*runner)->stop();
  EXPECT_EQ(device.received_bytes(), (Bytes{1, 2}));
}

TEST(PtyRunnerTest, BlockingModeRunsUntilAConditionOrTimesOut) {
  ScriptedEndpoint device{9600};
  device.set_period(now_monotonic() + 10ms, 10ms);
  auto runner = PtyRunner::create(device);
  ASSERT_TRUE(runner.ok());
  auto host = SerialPort::open((*runner)->host_path().c_str(), 9600);
  ASSERT_TRUE(host.ok());
  ASSERT_TRUE(host->write_all(Bytes{5, 6, 7}, 1s).ok());
  ASSERT_TRUE((*runner)->run_until([&] { return device.received_bytes().size() == 3; }, 5s).ok());
  EXPECT_EQ(device.received_bytes(), (Bytes{5, 6, 7}));

  const std::size_t ticks_before = device.ticks.size();
  const Time t0 = now_monotonic();
  ASSERT_TRUE((*runner)->run_for(100ms).ok());
  EXPECT_GE(now_monotonic() - t0, 100ms);
  EXPECT_GE(device.ticks.size(), ticks_before + 5);  // a 10 ms timer over 100 ms: ticked repeatedly
  for (std::size_t i = 1; i < device.ticks.size(); ++i) EXPECT_GE(device.ticks[i], device.ticks[i - 1]);

  const Status never = (*runner)->run_until([] { return false; }, 50ms);
  EXPECT_FALSE(never.ok());
}

TEST(PtyRunnerTest, RecordsBothDirectionsAndTheHostRate) {
  TempDir dir;
  const std::string cap_path = (dir.path / "session.cap").string();
  ScriptedEndpoint device{9600};
  answer_with(device, {0x06, 0x02, 0x80});
  auto runner = PtyRunner::create(device);
  ASSERT_TRUE(runner.ok());
  ASSERT_TRUE((*runner)->record(cap_path, DeviceKind::lms200).ok());
  ASSERT_TRUE((*runner)->start().ok());
  auto host = SerialPort::open((*runner)->host_path().c_str(), 9600);
  ASSERT_TRUE(host.ok());
  ASSERT_TRUE(host->write_all(Bytes{0x02, 0x00, 0x01}, 1s).ok());
  EXPECT_EQ(read_port(*host, 3, 2s).size(), 3u);
  ASSERT_TRUE(host->set_baud(38400).ok());
  const Time give_up = now_monotonic() + 2s;
  while ((*runner)->stats().host_baud != 38400 && now_monotonic() < give_up) std::this_thread::sleep_for(1ms);
  (*runner)->stop();
  ASSERT_TRUE((*runner)->stop_recording().ok());

  auto cap = load_capture(cap_path);
  ASSERT_TRUE(cap.ok()) << cap.error().what << " line " << cap.error().detail;
  EXPECT_EQ(cap->device, DeviceKind::lms200);
  EXPECT_EQ(cap->bytes(CaptureDirection::tx), (Bytes{0x02, 0x00, 0x01}));
  EXPECT_EQ(cap->bytes(CaptureDirection::rx), (Bytes{0x06, 0x02, 0x80}));
  std::vector<std::uint32_t> bauds;
  std::int64_t last_us = 0;
  for (const auto& r : cap->records) {
    EXPECT_GE(r.time_us, last_us);  // time never goes back
    last_us = r.time_us;
    if (r.kind == CaptureRecord::Kind::baud) bauds.push_back(r.baud);
  }
  EXPECT_EQ(bauds, (std::vector<std::uint32_t>{9600, 38400}));
}

}  // namespace
}  // namespace teamscan::serial
