// The capture format: round trip, exact text, and bad input named with its line.
#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>

#include "common/capture.hpp"

namespace teamscan {
namespace {

TEST(Capture, ParsesHeadersChunksAndBaudChanges) {
  const auto cap = parse_capture(
      "#teamscan-capture 1\n#device lms200\n#baud 0 9600\n# a comment\n"
      "1234 tx 02 00 01 00 31 15 12\n1301 rx 06\n#baud 250000 500000\n250100 rx 02 80\n");
  ASSERT_TRUE(cap.ok()) << cap.error().what;
  EXPECT_EQ(cap->device, DeviceKind::lms200);
  ASSERT_EQ(cap->records.size(), 5u);
  EXPECT_EQ(cap->records[0].kind, CaptureRecord::Kind::baud);
  EXPECT_EQ(cap->records[0].baud, 9600u);
  EXPECT_EQ(cap->records[1].time_us, 1234);
  EXPECT_EQ(cap->records[1].direction, CaptureDirection::tx);
  EXPECT_EQ(cap->records[1].bytes, (std::vector<std::uint8_t>{0x02, 0x00, 0x01, 0x00, 0x31, 0x15, 0x12}));
  EXPECT_EQ(cap->records[3].baud, 500000u);
  EXPECT_EQ(cap->records[3].time_us, 250000);
  EXPECT_EQ(cap->bytes(CaptureDirection::rx), (std::vector<std::uint8_t>{0x06, 0x02, 0x80}));
}

TEST(Capture, WriterOutputParsesBackIdentically) {
  const auto path = std::filesystem::temp_directory_path() / "teamscan_capture_test.cap";
  {
    auto w = CaptureWriter::create(path.string(), DeviceKind::arcos, 9600);
    ASSERT_TRUE(w.ok());
    const std::uint8_t sync0[] = {0xFA, 0xFB, 0x03, 0x00, 0x00, 0x00};
    ASSERT_TRUE(w->chunk(10, CaptureDirection::tx, sync0).ok());
    ASSERT_TRUE(w->chunk(20, CaptureDirection::rx, sync0).ok());
    ASSERT_TRUE(w->baud(30, 38400).ok());
    ASSERT_TRUE(w->close().ok());
  }
  const auto cap = load_capture(path.string());
  ASSERT_TRUE(cap.ok());
  EXPECT_EQ(cap->device, DeviceKind::arcos);
  ASSERT_EQ(cap->records.size(), 4u);
  EXPECT_EQ(format_capture(*cap),
            "#teamscan-capture 1\n#device arcos\n#baud 0 9600\n10 tx FA FB 03 00 00 00\n20 rx FA FB 03 00 00 00\n"
            "#baud 30 38400\n");
  std::filesystem::remove(path);
}

TEST(Capture, RejectsMalformedInputNamingTheLine) {
  struct Case { const char* text; long line; };
  const Case cases[] = {
      {"1 rx 00\n", 1},                                         // no magic
      {"#teamscan-capture 2\n", 1},                             // version
      {"#teamscan-capture 1\n#device toaster\n", 2},            // device
      {"#teamscan-capture 1\n#device\n", 2},                     // device missing
      {"#teamscan-capture 1\n12 up 00\n", 2},                   // direction
      {"#teamscan-capture 1\n12 rx 0G\n", 2},                   // hex
      {"#teamscan-capture 1\n12 rx 001\n", 2},                  // hex width
      {"#teamscan-capture 1\nx12 rx 00\n", 2},                  // time
      {"#teamscan-capture 1\n#baud 12\n", 2},                   // baud
      {"#teamscan-capture 1\n12 rx\n", 2},                      // no bytes
  };
  for (const auto& c : cases) {
    const auto cap = parse_capture(c.text);
    ASSERT_FALSE(cap.ok()) << c.text;
    EXPECT_EQ(cap.error().detail, c.line) << c.text;
  }
  EXPECT_FALSE(load_capture("/nonexistent/x.cap").ok());
}

}  // namespace
}  // namespace teamscan

namespace teamscan {
namespace {
TEST(Capture, UnknownDeviceRoundTrips) {
  Capture cap;
  cap.records.push_back({CaptureRecord::Kind::chunk, 5, CaptureDirection::rx, 0, {0x01}});
  const auto back = parse_capture(format_capture(cap));
  ASSERT_TRUE(back.ok()) << back.error().what;
  EXPECT_EQ(back->device, DeviceKind::unknown);
  EXPECT_EQ(back->records.size(), 1u);
}
}  // namespace
}  // namespace teamscan
