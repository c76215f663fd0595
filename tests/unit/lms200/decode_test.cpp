// `teamscan decode --device lms200` (tools/teamscan/support_decode_lms200.cpp): JSON lines for both
// directions of a capture, errors for bad input, the summary, and baud changes between chunks.
#include <gtest/gtest.h>

#include <array>
#include <cstdio>
#include <string>
#include <vector>

#include "drivers/lms200/codec.hpp"
#include "tests/unit/lms200/test_util.hpp"
#include "tools/teamscan/decode.hpp"

namespace teamscan::tool {
namespace {

using lms200::test::hex;

std::vector<std::string> decode_lines(const DecodeInput& in) {
  char* buf = nullptr;
  std::size_t size = 0;
  std::FILE* f = open_memstream(&buf, &size);
  EXPECT_EQ(decode_lms200(in, f), 0);
  std::fclose(f);
  std::vector<std::string> lines;
  std::string all{buf, size};
  std::free(buf);
  std::size_t start = 0;
  for (std::size_t i = 0; i < all.size(); ++i)
    if (all[i] == '\n') {
      lines.push_back(all.substr(start, i - start));
      start = i + 1;
    }
  EXPECT_EQ(start, all.size()) << "every object ends with a newline";
  return lines;
}

bool has(const std::string& line, const std::string& part) { return line.find(part) != std::string::npos; }

TEST(DecodeLms200, BothDirectionsOfABringUpStep) {
  DecodeInput in;
  in.chunks.push_back({100, CaptureDirection::tx, 9600, hex("02 00 05 00 3B B4 00 64 00 97 49")});  // L10
  in.chunks.push_back({160, CaptureDirection::rx, 9600, hex("06 02 80 07 00 BB 01 B4 00 64 00 10 5B 30")});  // L19
  in.chunks.push_back({200, CaptureDirection::tx, 9600, hex("02 00 02 00 20 48 58 08")});  // L8
  const auto lines = decode_lines(in);
  ASSERT_EQ(lines.size(), 5u);
  EXPECT_TRUE(has(lines[0], "\"type\":\"command\"") && has(lines[0], "\"name\":\"variant\"") &&
              has(lines[0], "\"fov_deg\":180") && has(lines[0], "\"resolution_cdeg\":100") && has(lines[0], "\"dir\":\"tx\""))
      << lines[0];
  EXPECT_TRUE(has(lines[1], "\"type\":\"ack\"")) << lines[1];
  EXPECT_TRUE(has(lines[2], "\"name\":\"variant\"") && has(lines[2], "\"accepted\":true") && has(lines[2], "\"status\":16"))
      << lines[2];
  EXPECT_TRUE(has(lines[3], "\"new_baud\":500000")) << lines[3];
  EXPECT_EQ(lines[4],
            "{\"summary\":{\"packets\":4,\"telegrams\":3,\"acks\":1,\"naks\":0,\"bad_crc\":0,\"bad_length\":0,"
            "\"discarded_bytes\":0,\"resyncs\":0,\"decode_errors\":0}}");
}

TEST(DecodeLms200, ScanFieldsOfL21) {
  DecodeInput in;
  in.chunks.push_back({0, CaptureDirection::rx, 500000, hex("02 80 0E 00 B0 05 40 E8 03 D0 27 F7 1F FE 1F F4 81 10 0D 0C")});
  const auto lines = decode_lines(in);
  ASSERT_EQ(lines.size(), 2u);
  EXPECT_TRUE(has(lines[0], "\"count\":5")) << lines[0];
  EXPECT_TRUE(has(lines[0], "\"unit\":\"mm\""));
  EXPECT_TRUE(has(lines[0], "\"ranges_mm\":[1000,2000,8183,8190,500]"));
  EXPECT_TRUE(has(lines[0], "\"flags\":[0,1,0,0,4]"));
  EXPECT_TRUE(has(lines[0], "\"status\":16"));
  EXPECT_TRUE(has(lines[0], "\"baud\":500000"));
}

TEST(DecodeLms200, BadInputIsReportedAndCounted) {
  DecodeInput in;
  // Garbage, a telegram with a broken CRC (last byte), then a good one.
  in.chunks.push_back({0, CaptureDirection::rx, 9600, hex("FF EE 02 80 03 00 A0 00 10 16 0B 02 80 03 00 A0 00 10 16 0A")});
  const auto lines = decode_lines(in);
  ASSERT_GE(lines.size(), 4u);
  EXPECT_TRUE(has(lines[0], "\"error\":\"garbage\"") && has(lines[0], "\"bytes\":\"ffee\"")) << lines[0];
  EXPECT_TRUE(has(lines[1], "\"error\":\"bad_crc\"")) << lines[1];
  EXPECT_TRUE(has(lines[lines.size() - 2], "\"result\":\"done\"")) << lines[lines.size() - 2];
  EXPECT_TRUE(has(lines.back(), "\"bad_crc\":1") && has(lines.back(), "\"discarded_bytes\":11") &&
              has(lines.back(), "\"resyncs\":1") && has(lines.back(), "\"telegrams\":1"))
      << lines.back();
}

TEST(DecodeLms200, BaudChangeDropsAHalfTelegramOfTheOldRate) {
  DecodeInput in;
  in.chunks.push_back({0, CaptureDirection::rx, 9600, hex("02 80 03 00 A0")});
  in.chunks.push_back({10, CaptureDirection::rx, 500000, hex("02 80 03 00 A0 00 10 16 0A")});
  const auto lines = decode_lines(in);
  ASSERT_EQ(lines.size(), 3u);
  EXPECT_TRUE(has(lines[0], "\"reason\":\"baud_change\"") && has(lines[0], "\"byte_count\":5")) << lines[0];
  EXPECT_TRUE(has(lines[1], "\"baud\":500000") && has(lines[1], "\"result\":\"done\"")) << lines[1];
}

TEST(DecodeLms200, EmptyInputStillPrintsTheSummary) {
  const auto lines = decode_lines(DecodeInput{});
  ASSERT_EQ(lines.size(), 1u);
  EXPECT_TRUE(has(lines[0], "\"summary\":{\"packets\":0"));
}

}  // namespace
}  // namespace teamscan::tool
