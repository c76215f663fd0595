// LmsClient and LmsEmulator joined by serial::VirtualLink (the simulator's cable: bytes arrive at the
// sender's rate, garbage on a rate mismatch, a Capture of the session): bring-up, stream rates at
// 500000 and 38400, and the recorded capture decoded by the lms200 decode back-end.
#include <gtest/gtest.h>

#include <cstdio>
#include <string>

#include "drivers/lms200/client.hpp"
#include "drivers/lms200/emulator.hpp"
#include "drivers/serial/virtual_link.hpp"
#include "tools/teamscan/decode.hpp"

namespace teamscan::lms200 {
namespace {

int count(const std::string& text, const std::string& part) {
  int n = 0;
  for (std::size_t at = text.find(part); at != std::string::npos; at = text.find(part, at + 1)) ++n;
  return n;
}

struct Counter final : ScanSink {
  void on_scan(const ScanTelegram& s, const ScanArrival& a) override {
    ++scans;
    last_count = s.count;
    last = a;
  }
  int scans = 0;
  int last_count = 0;
  ScanArrival last{};
};

struct Pair {
  explicit Pair(std::uint32_t baud) : client{options(baud)} { client.set_scan_sink(&sink); }
  static LmsClientOptions options(std::uint32_t baud) {
    LmsClientOptions co;
    co.target_baud = baud;
    co.variant = {180, 50};
    return co;
  }
  LmsEmulator emulator{};  // pace_output = false: the link paces
  LmsClient client;
  Counter sink;
};

TEST(LmsVirtualLink, BringUpAndStreamAt500k) {
  Pair s{500000};
  const Time t0 = Time::from_seconds(100.0);
  serial::VirtualLinkOptions lo;
  lo.device = DeviceKind::lms200;
  lo.start = t0;
  serial::VirtualLink link{s.client, s.emulator, lo};
  s.emulator.power_up(t0);
  s.client.start(t0);
  link.run_for(3s);
  ASSERT_TRUE(s.client.streaming()) << s.client.state_name() << " " << s.client.last_error();
  EXPECT_EQ(s.emulator.baud(), 500000u);
  const int before = s.sink.scans;
  link.run_for(2s);
  // 37.5 scans/s for 0.5° (two revolutions a scan), all carried at 500 kBd.
  EXPECT_GE(s.sink.scans - before, 74);
  EXPECT_LE(s.sink.scans - before, 76);
  EXPECT_EQ(s.sink.last_count, 361);
  EXPECT_EQ(s.emulator.statistics().scans_skipped, 0u);

  // The recorded session decodes cleanly, both directions, the baud switch respected.
  tool::DecodeInput in;
  std::uint32_t baud = 9600;
  for (const auto& r : link.capture().records) {
    if (r.kind == CaptureRecord::Kind::baud) {
      baud = r.baud;
      continue;
    }
    in.chunks.push_back(tool::DecodeChunk{r.time_us, r.direction, baud, r.bytes});
  }
  char* buf = nullptr;
  std::size_t size = 0;
  std::FILE* f = open_memstream(&buf, &size);
  EXPECT_EQ(tool::decode_lms200(in, f), 0);
  std::fclose(f);
  const std::string out{buf, size};
  std::free(buf);
  EXPECT_LE(count(out, "\"error\""), 1);  // at most the scan on the line when the run stopped
  EXPECT_NE(out.find("\"naks\":0,\"bad_crc\":0,\"bad_length\":0,"), std::string::npos);
  EXPECT_GE(count(out, "\"name\":\"measured_values\""), s.sink.scans);
}

TEST(LmsVirtualLink, ThirtyEightFourHundredCarriesAboutFiveScansASecond) {
  Pair s{38400};
  const Time t0 = Time::from_seconds(100.0);
  serial::VirtualLinkOptions lo;
  lo.start = t0;
  lo.record = false;
  serial::VirtualLink link{s.client, s.emulator, lo};
  s.emulator.power_up(t0);
  s.client.start(t0);
  link.run_for(5s);
  ASSERT_TRUE(s.client.streaming()) << s.client.state_name();
  const int before = s.sink.scans;
  link.run_for(10s);
  // §2.10: 732 bytes take 190.6 ms at 38400; plus waiting up to one 26.7 ms sweep for the next scan.
  const int per_10s = s.sink.scans - before;
  EXPECT_GE(per_10s, 46);
  EXPECT_LE(per_10s, 53);
  EXPECT_GT(s.emulator.statistics().scans_skipped, 0u);
  // The arrival carries what back-dating needs: 732 bytes at 38400 baud = 190.625 ms.
  EXPECT_EQ(s.sink.last.telegram_bytes, 732);
  EXPECT_EQ(s.sink.last.baud, 38400u);
  EXPECT_EQ(s.sink.last.transmission(), Duration{190'625'000});
}

}  // namespace
}  // namespace teamscan::lms200
