// `teamscan decode --device arcos` (tools/teamscan/support_decode_arcos.cpp): a recorded client vs
// emulator session decodes into one JSON line per packet in both directions plus a summary; corrupted
// bytes are reported as errors and counted.
#include <gtest/gtest.h>

#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "drivers/arcos/client.hpp"
#include "drivers/arcos/emulator.hpp"
#include "tests/unit/arcos/test_support.hpp"
#include "tools/teamscan/decode.hpp"

namespace teamscan::arcos {
namespace {

std::vector<std::string> run_decode(const tool::DecodeInput& in) {
  char* buf = nullptr;
  std::size_t len = 0;
  std::FILE* f = ::open_memstream(&buf, &len);
  EXPECT_EQ(tool::decode_arcos(in, f), 0);
  std::fclose(f);
  std::vector<std::string> lines;
  std::string s{buf, len};
  std::free(buf);
  std::size_t start = 0;
  for (std::size_t i = 0; i < s.size(); ++i) {
    if (s[i] == '\n') {
      lines.push_back(s.substr(start, i - start));
      start = i + 1;
    }
  }
  return lines;
}

std::size_t count_containing(const std::vector<std::string>& lines, const std::string& needle) {
  std::size_t n = 0;
  for (const auto& l : lines) n += l.find(needle) != std::string::npos ? 1 : 0;
  return n;
}

// Records the bytes of both directions as capture-like chunks.
struct Recorder final : serial::SerialEndpoint {
  serial::SerialEndpoint& inner;
  tool::DecodeInput& in;
  tool::DecodeInput& dev;
  Recorder(serial::SerialEndpoint& i, tool::DecodeInput& host_tx, tool::DecodeInput& dev_tx) : inner{i}, in{host_tx}, dev{dev_tx} {}
  void on_rx(std::span<const std::uint8_t> b, Time now) override {
    dev.chunks.push_back({now.us(), CaptureDirection::rx, 9600, {b.begin(), b.end()}});
    inner.on_rx(b, now);
  }
  void on_tick(Time now) override { inner.on_tick(now); }
  std::size_t take_tx(std::span<std::uint8_t> out) override {
    const std::size_t n = inner.take_tx(out);
    if (n > 0) in.chunks.push_back({0, CaptureDirection::tx, 9600, {out.begin(), out.begin() + static_cast<std::ptrdiff_t>(n)}});
    return n;
  }
  std::uint32_t baud() const override { return inner.baud(); }
  Time next_deadline() const override { return inner.next_deadline(); }
};

TEST(ArcosDecode, SessionDecodesBothDirections) {
  ArcosClient client;
  PioneerEmulatorOptions eo;
  eo.subclass = "p3at";
  PioneerEmulator robot{eo};
  tool::DecodeInput tx, rx;
  Recorder rec{client, tx, rx};
  test::Loop loop{rec, robot};
  ASSERT_TRUE(loop.run_until([&] { return client.connected(); }, 5s));
  client.set_velocity(200, 0, loop.now);
  loop.run_for(1s);
  tool::DecodeInput all;
  for (auto& c : tx.chunks) all.chunks.push_back(c);
  for (auto& c : rx.chunks) all.chunks.push_back(c);
  const auto lines = run_decode(all);
  ASSERT_FALSE(lines.empty());
  const auto client_stats = client.statistics();
  // One line per packet in each direction + the summary.
  const std::size_t rx_packets = client_stats.parser.packets;
  EXPECT_EQ(count_containing(lines, "\"dir\":\"rx\""), rx_packets);
  EXPECT_EQ(count_containing(lines, "\"name\":\"SIP\""), client_stats.sips);
  EXPECT_EQ(count_containing(lines, "\"subclass\":\"p3at\""), 1U);
  EXPECT_EQ(count_containing(lines, "\"dist_conv_mm\":0.465"), client_stats.sips);  // from the SYNC2 reply
  EXPECT_EQ(count_containing(lines, "\"name\":\"VEL\",\"arg\":200"), count_containing(lines, "\"name\":\"RVEL\",\"arg\":0"));
  EXPECT_GE(count_containing(lines, "\"name\":\"VEL\",\"arg\":200"), 2U);  // set + keep-alive
  EXPECT_EQ(count_containing(lines, "\"name\":\"ENABLE\",\"arg\":1"), 1U);
  EXPECT_EQ(count_containing(lines, "\"error\""), 0U);
  const std::string& summary = lines.back();
  EXPECT_EQ(summary.rfind("{\"summary\":", 0), 0U);
  const std::size_t total = count_containing(lines, "\"dir\":");
  EXPECT_NE(summary.find("\"packets\":" + std::to_string(total) + ","), std::string::npos) << summary;
  EXPECT_NE(summary.find("\"bad_crc\":0,"), std::string::npos);
}

TEST(ArcosDecode, CorruptedBytesAreReportedAndCounted) {
  tool::DecodeChunk c;
  c.direction = CaptureDirection::rx;
  c.bytes = test::hex("00 11 FA FB 06 0B 3B 88 00 D3 3B FA FB 01 FA FB 0B 90 40 E2 01 00 0F 04 F6 FF 77 B9 FA FB 06");
  tool::DecodeInput in;
  in.chunks.push_back(c);
  const auto lines = run_decode(in);
  EXPECT_EQ(count_containing(lines, "\"error\":\"bad_crc\""), 1U);
  EXPECT_EQ(count_containing(lines, "\"error\":\"bad_length\""), 2U);  // count 1, and the cut packet at the end
  EXPECT_GE(count_containing(lines, "\"error\":\"garbage\""), 2U);
  EXPECT_EQ(count_containing(lines, "\"name\":\"ENCODERpac\",\"left\":123456,\"right\":-654321"), 1U);
  EXPECT_NE(lines.back().find("\"packets\":1,\"bad_crc\":1,\"bad_length\":2,\"discarded_bytes\":" +
                              std::to_string(c.bytes.size() - 14) + ","),
            std::string::npos)
      << lines.back();
}

}  // namespace
}  // namespace teamscan::arcos
