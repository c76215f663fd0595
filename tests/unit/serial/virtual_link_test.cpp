// VirtualLink: byte timing at the sender's rate, queueing, garbling on a rate mismatch, rate switches,
// ticks, the recorded capture and determinism.
#include "drivers/serial/virtual_link.hpp"

#include <gtest/gtest.h>

#include <numeric>

#include "tests/unit/serial/scripted_endpoint.hpp"

namespace teamscan::serial {
namespace {

using testing::ScriptedEndpoint;
using Bytes = std::vector<std::uint8_t>;

Bytes counting(std::size_t n, std::uint8_t first = 0) {
  Bytes b(n);
  std::iota(b.begin(), b.end(), first);
  return b;
}

TEST(VirtualLinkTest, BytesArriveWhenTheirLastBitHasAtTheSendersRate) {
  ScriptedEndpoint host{9600}, device{9600};
  const Time t0 = Time::from_ns(10'000'000);
  device.send_at(t0, counting(100));
  VirtualLink link{host, device};
  link.run_until(Time::from_ns(1'000'000'000));

  EXPECT_EQ(host.received_bytes(), counting(100));
  ASSERT_FALSE(host.received.empty());
  std::int64_t arrived = 0;
  for (const auto& piece : host.received) {
    arrived += static_cast<std::int64_t>(piece.bytes.size());
    // The piece's last byte started after the `arrived - 1` before it: 10 bits per byte at 9600.
    EXPECT_EQ(piece.time, t0 + serial_transmission_time(arrived, 9600)) << "after byte " << arrived;
  }
  EXPECT_EQ(host.received.back().time - t0, serial_transmission_time(100, 9600));  // 104.17 ms
  EXPECT_EQ(link.now(), Time::from_ns(1'000'000'000));
  EXPECT_EQ(link.stats().bytes_to_host, 100u);
  EXPECT_EQ(link.stats().garbled_bytes, 0u);
}

TEST(VirtualLinkTest, PiecesAreAtMostOneMillisecondOfLineTime) {
  ScriptedEndpoint host{500000}, device{500000};
  device.send_at(Time{}, counting(200));
  VirtualLink link{host, device};
  link.run_until(Time::from_ns(50'000'000));
  EXPECT_EQ(host.received_bytes(), counting(200));
  for (const auto& piece : host.received) EXPECT_LE(piece.bytes.size(), 50u);  // 1 ms at 500 kBd = 50 bytes
  EXPECT_EQ(host.received.back().time, Time{} + serial_transmission_time(200, 500000));  // 4 ms
}

TEST(VirtualLinkTest, ASecondSendQueuesBehindTheFirst) {
  ScriptedEndpoint host{19200}, device{19200};
  device.send_at(Time{}, counting(10));
  device.send_at(Time::from_ns(1'000'000), counting(10, 100));  // while the first is still on the wire
  VirtualLink link{host, device};
  link.run_until(Time::from_ns(100'000'000));
  Bytes expected = counting(10);
  const Bytes second = counting(10, 100);
  expected.insert(expected.end(), second.begin(), second.end());
  EXPECT_EQ(host.received_bytes(), expected);
  EXPECT_EQ(host.received.back().time, Time{} + serial_transmission_time(20, 19200));
}

TEST(VirtualLinkTest, RequestAndAnswerTakeTwoLineTimes) {
  ScriptedEndpoint host{9600}, device{9600};
  device.responder = [](ScriptedEndpoint& self, std::span<const std::uint8_t> bytes, Time) {
    if (bytes.size() == 1 && bytes[0] == 0x10) self.send_now({0x06});
  };
  host.send_at(Time::from_ns(5'000'000), {0x10});
  VirtualLink link{host, device};
  link.run_until(Time::from_ns(100'000'000));
  ASSERT_EQ(device.received.size(), 1u);
  EXPECT_EQ(device.received[0].time, Time::from_ns(5'000'000) + serial_transmission_time(1, 9600));
  ASSERT_EQ(host.received.size(), 1u);
  EXPECT_EQ(host.received[0].bytes, Bytes{0x06});
  EXPECT_EQ(host.received[0].time, Time::from_ns(5'000'000) + 2 * serial_transmission_time(1, 9600));
}

TEST(VirtualLinkTest, RateMismatchGarblesBothDirectionsButKeepsTheCount) {
  ScriptedEndpoint host{9600}, device{38400};
  device.send_at(Time{}, counting(64));
  host.send_at(Time{}, counting(32, 7));
  VirtualLink link{host, device};
  link.run_until(Time::from_ns(200'000'000));

  const Bytes at_host = host.received_bytes();
  const Bytes at_device = device.received_bytes();
  ASSERT_EQ(at_host.size(), 64u);
  ASSERT_EQ(at_device.size(), 32u);
  const Bytes sent_by_device = counting(64), sent_by_host = counting(32, 7);
  for (std::size_t i = 0; i < at_host.size(); ++i) EXPECT_NE(at_host[i], sent_by_device[i]) << i;
  for (std::size_t i = 0; i < at_device.size(); ++i) EXPECT_NE(at_device[i], sent_by_host[i]) << i;
  EXPECT_EQ(link.stats().garbled_bytes, 96u);
  // The capture shows tx as the host sent it and rx as the host received it.
  EXPECT_EQ(link.capture().bytes(CaptureDirection::tx), sent_by_host);
  EXPECT_EQ(link.capture().bytes(CaptureDirection::rx), at_host);
}

TEST(VirtualLinkTest, RateSwitchAfterAnAckKeepsTheAckAndTheCaptureNotesTheHostRate) {
  // The LMS pattern (PROTOCOLS.md §2.11): the host asks for 500000 at 9600, the device ACKs at 9600 and
  // switches; the host switches on the ACK and talks at 500000.
  ScriptedEndpoint host{9600}, device{9600};
  device.responder = [](ScriptedEndpoint& self, std::span<const std::uint8_t> bytes, Time) {
    if (bytes.size() == 1 && bytes[0] == 0x20) {
      self.send_now({0x06});
      self.switch_baud_after_send(500000);
    } else {
      self.send_now(Bytes(bytes.begin(), bytes.end()));  // echo
    }
  };
  Time host_switched{};
  host.responder = [&](ScriptedEndpoint& self, std::span<const std::uint8_t> bytes, Time now) {
    if (bytes.size() == 1 && bytes[0] == 0x06 && self.baud() == 9600) {
      self.set_baud(500000);
      host_switched = now;
      self.send_now({0x42, 0x43});
    }
  };
  host.send_at(Time::from_ns(1'000'000), {0x20});
  VirtualLink link{host, device, VirtualLinkOptions{.device = DeviceKind::lms200}};
  link.run_until(Time::from_ns(50'000'000));

  ASSERT_GE(host.received.size(), 1u);
  EXPECT_EQ(host.received[0].bytes, Bytes{0x06});
  EXPECT_EQ(device.baud(), 500000u);
  EXPECT_EQ(host.received_bytes(), (Bytes{0x06, 0x42, 0x43}));  // the echo came back intact at 500000
  EXPECT_EQ(link.stats().garbled_bytes, 0u);

  const Capture& cap = link.capture();
  EXPECT_EQ(cap.device, DeviceKind::lms200);
  std::vector<std::pair<std::int64_t, std::uint32_t>> bauds;
  for (const auto& r : cap.records)
    if (r.kind == CaptureRecord::Kind::baud) bauds.emplace_back(r.time_us, r.baud);
  ASSERT_EQ(bauds.size(), 2u);
  EXPECT_EQ(bauds[0], (std::pair<std::int64_t, std::uint32_t>{0, 9600}));
  EXPECT_EQ(bauds[1].second, 500000u);
  EXPECT_EQ(bauds[1].first, host_switched.ns() / 1000);
  // Text round trip of the capture.
  auto parsed = parse_capture(format_capture(cap));
  ASSERT_TRUE(parsed.ok());
  EXPECT_EQ(format_capture(*parsed), format_capture(cap));
}

TEST(VirtualLinkTest, TicksAtDeadlinesAndIdleEndpointsDoNotStallTime) {
  ScriptedEndpoint host{9600}, device{9600};
  device.set_period(Time::from_ns(100'000'000), std::chrono::milliseconds(100));
  // The host has no timer at all: next_deadline() is "never". Add an endpoint whose deadline is
  // always in the past to check the idle rule.
  struct Stuck : ScriptedEndpoint {
    Stuck() : ScriptedEndpoint{9600} {}
    [[nodiscard]] Time next_deadline() const override { return Time{}; }
  } stuck;
  VirtualLink link{host, device};
  link.run_until(Time::from_ns(1'000'000'000));
  ASSERT_EQ(device.ticks.size(), 10u);
  for (std::size_t i = 0; i < device.ticks.size(); ++i)
    EXPECT_EQ(device.ticks[i], Time::from_ns(static_cast<std::int64_t>(i + 1) * 100'000'000));
  EXPECT_TRUE(host.ticks.empty());

  ScriptedEndpoint other{9600};
  VirtualLink idle{stuck, other, VirtualLinkOptions{.idle_tick = std::chrono::milliseconds(10)}};
  idle.run_until(Time::from_ns(100'000'000));
  EXPECT_EQ(stuck.ticks.size(), 11u);  // t = 0, 10, ..., 100 ms
}

Capture run_session() {
  ScriptedEndpoint host{9600}, device{9600};
  std::uint32_t seed = 1;
  for (int i = 0; i < 50; ++i) {
    seed = seed * 1103515245u + 12345u;
    host.send_at(Time::from_ns(static_cast<std::int64_t>(seed % 900'000'000)), counting(1 + seed % 17, static_cast<std::uint8_t>(i)));
  }
  device.responder = [](ScriptedEndpoint& self, std::span<const std::uint8_t> bytes, Time) {
    Bytes reply(bytes.begin(), bytes.end());
    for (auto& b : reply) b = static_cast<std::uint8_t>(b ^ 0xFF);
    self.send_now(reply);
    if (bytes[0] == 30) self.switch_baud_after_send(19200);  // mid-session mismatch: garbling
  };
  VirtualLink link{host, device, VirtualLinkOptions{.device = DeviceKind::arcos}};
  link.run_until(Time::from_ns(1'500'000'000));
  return link.take_capture();
}

TEST(VirtualLinkTest, SameEndpointsGiveTheSameCapture) {
  const std::string a = format_capture(run_session());
  const std::string b = format_capture(run_session());
  EXPECT_GT(a.size(), 200u);
  EXPECT_EQ(a, b);
}

}  // namespace
}  // namespace teamscan::serial
