// VirtualLink with the real device models: the LMS client's whole bring-up against the emulated
// LMS-200 in simulated time (PROTOCOLS.md §2.11), ending in a 500 kBd stream; the capture holds the
// session with the rate switch, and the same run twice gives the same capture.
#include <gtest/gtest.h>

#include <cstdio>

#include "drivers/lms200/client.hpp"
#include "drivers/lms200/emulator.hpp"
#include "drivers/serial/virtual_link.hpp"

namespace teamscan::serial {
namespace {

struct LinkRun {
  bool streaming = false;
  std::uint64_t scans = 0;
  std::uint32_t device_baud = 0;
  VirtualLinkStats stats;
  Capture capture;
};

LinkRun bring_up(bool pace_in_emulator, Duration simulated) {
  lms200::LmsEmulatorOptions eo;
  eo.pace_output = pace_in_emulator;
  lms200::LmsEmulator device{eo};
  lms200::LmsClient host{};
  const Time t0 = Time::from_ns(1'000'000'000);
  device.power_up(t0);
  host.start(t0);
  VirtualLink link{host, device, VirtualLinkOptions{.device = DeviceKind::lms200, .start = t0}};
  link.run_for(simulated);
  LinkRun r;
  r.streaming = host.streaming();
  r.scans = host.statistics().scans;
  r.device_baud = device.baud();
  r.stats = link.stats();
  r.capture = link.take_capture();
  return r;
}

TEST(VirtualLinkLmsTest, BringUpReaches500kBdStreamingAndIsCaptured) {
  const LinkRun r = bring_up(false, std::chrono::seconds(4));
  ASSERT_TRUE(r.streaming);
  EXPECT_EQ(r.device_baud, 500000u);
  // 180°/1° at 500 kBd keeps up with the 75 Hz mirror (§2.10): most of the ~4 s is streaming.
  EXPECT_GT(r.scans, 150u);
  std::printf("simulated 4 s: %llu scans, %llu bytes to the host, %llu events\n", static_cast<unsigned long long>(r.scans),
              static_cast<unsigned long long>(r.stats.bytes_to_host), static_cast<unsigned long long>(r.stats.events));
  std::vector<std::uint32_t> bauds;
  for (const auto& rec : r.capture.records)
    if (rec.kind == CaptureRecord::Kind::baud) bauds.push_back(rec.baud);
  ASSERT_GE(bauds.size(), 2u);
  EXPECT_EQ(bauds.front(), 9600u);
  EXPECT_EQ(bauds.back(), 500000u);
  // Every 0xB0 telegram is 02 80 ...: the stream holds at least that many telegram starts.
  const auto rx = r.capture.bytes(CaptureDirection::rx);
  std::uint64_t starts = 0;
  for (std::size_t i = 0; i + 4 < rx.size(); ++i)
    if (rx[i] == 0x02 && rx[i + 1] == 0x80 && rx[i + 4] == 0xB0) ++starts;
  EXPECT_GE(starts, r.scans);
}

TEST(VirtualLinkLmsTest, SameModelsGiveTheSameCaptureAlsoWithEmulatorPacing) {
  for (bool pace : {false, true}) {
    SCOPED_TRACE(pace);
    const LinkRun a = bring_up(pace, std::chrono::seconds(2));
    const LinkRun b = bring_up(pace, std::chrono::seconds(2));
    EXPECT_TRUE(a.streaming);
    EXPECT_EQ(format_capture(a.capture), format_capture(b.capture));
  }
}

}  // namespace
}  // namespace teamscan::serial
