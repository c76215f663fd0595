// The `teamscan decode` framework (tools/teamscan/decode.hpp): capture/raw input into chunks with the
// right rate and direction, and the JSON line writer's exact output.
#include "tools/teamscan/decode.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <string>

namespace teamscan::tool {
namespace {

using Bytes = std::vector<std::uint8_t>;

// Runs `write` on a memory FILE and returns what it printed.
template <class F>
std::string printed(F&& write) {
  char* buf = nullptr;
  std::size_t len = 0;
  std::FILE* f = ::open_memstream(&buf, &len);
  write(f);
  std::fclose(f);
  std::string out{buf, len};
  std::free(buf);
  return out;
}

TEST(DecodeInputTest, CaptureChunksCarryTheRateInForceAndTheirDirection) {
  const std::string cap =
      "# recorded on the bench\n"
      "#teamscan-capture 1\n#device lms200\n"
      "100 tx 02 00 01\n"
      "#baud 150 9600\n"
      "200 rx 06\n"
      "#baud 300 500000\n"
      "400 rx 02 80\n";
  auto in = make_decode_input(cap, 38400);
  ASSERT_TRUE(in.ok()) << in.error().what;
  EXPECT_EQ(in->device, DeviceKind::lms200);
  ASSERT_EQ(in->chunks.size(), 3u);
  EXPECT_EQ(in->chunks[0].time_us, 100);
  EXPECT_EQ(in->chunks[0].direction, CaptureDirection::tx);
  EXPECT_EQ(in->chunks[0].baud, 38400u);  // before the first #baud: the --baud default
  EXPECT_EQ(in->chunks[0].bytes, (Bytes{0x02, 0x00, 0x01}));
  EXPECT_EQ(in->chunks[1].baud, 9600u);
  EXPECT_EQ(in->chunks[1].direction, CaptureDirection::rx);
  EXPECT_EQ(in->chunks[2].baud, 500000u);
  EXPECT_EQ(in->chunks[2].bytes, (Bytes{0x02, 0x80}));
}

TEST(DecodeInputTest, RawBytesAreOneChunkAtTheGivenRate) {
  const std::string raw{"\x02\x80\x00#teamscan-capture", 20};  // the magic not at the start: raw
  auto in = make_decode_input(raw, 500000, CaptureDirection::tx);
  ASSERT_TRUE(in.ok());
  EXPECT_EQ(in->device, DeviceKind::unknown);
  ASSERT_EQ(in->chunks.size(), 1u);
  EXPECT_EQ(in->chunks[0].direction, CaptureDirection::tx);
  EXPECT_EQ(in->chunks[0].baud, 500000u);
  EXPECT_EQ(in->chunks[0].bytes.size(), 20u);
  EXPECT_EQ(in->chunks[0].bytes[2], 0x00);

  auto empty = make_decode_input("", 9600);
  ASSERT_TRUE(empty.ok());
  EXPECT_TRUE(empty->chunks.empty());
}

TEST(DecodeInputTest, MalformedCaptureIsAnErrorWithItsLine) {
  auto in = make_decode_input("#teamscan-capture 1\n#device arcos\n10 rx FA\n11 sideways FB\n", 9600);
  ASSERT_FALSE(in.ok());
  EXPECT_EQ(in.error().detail, 4);
  EXPECT_FALSE(looks_like_capture("#device arcos\n#teamscan-capture 1\n"));
  EXPECT_TRUE(looks_like_capture("\n# c\n#teamscan-capture 1\n"));
}

TEST(JsonLineTest, WritesOneObjectPerLineWithExactSyntax) {
  const std::vector<int> ranges{1, -2, 30000};
  const std::vector<std::uint8_t> flags{0, 255};
  const Bytes raw{0xFA, 0xFB, 0x0A};
  const std::string out = printed([&](std::FILE* f) {
    JsonLine j{f};
    j.field("type", "sip").field("x_mm", 12).field("ok", true).field("big", std::uint64_t{18446744073709551615u});
    j.field("ratio", 0.5).array("ranges_mm", ranges).array("flags", flags).hex("raw", raw);
    j.begin_object("summary").field("packets", 3).end_object();
    j.end();
  });
  EXPECT_EQ(out,
            "{\"type\":\"sip\",\"x_mm\":12,\"ok\":true,\"big\":18446744073709551615,\"ratio\":0.5,"
            "\"ranges_mm\":[1,-2,30000],\"flags\":[0,255],\"raw\":\"fafb0a\",\"summary\":{\"packets\":3}}\n");
}

TEST(JsonLineTest, EscapesStringsAndWritesNonFiniteAsNull) {
  const std::string out = printed([](std::FILE* f) {
    JsonLine j{f};
    j.field("s", std::string_view{"a\"b\\c\nd\x01\x7f\xc3\xa9", 11}).field("nan", std::nan("")).field("inf", HUGE_VAL);
    const std::vector<std::string_view> names{"x\"", "y"};
    j.array("names", names);
  });  // the destructor ends the line
  EXPECT_EQ(out, "{\"s\":\"a\\\"b\\\\c\\nd\\u0001\x7f\xc3\xa9\",\"nan\":null,\"inf\":null,\"names\":[\"x\\\"\",\"y\"]}\n");
}

TEST(JsonLineTest, EndClosesOpenObjectsAndEmptyObjectIsValid) {
  EXPECT_EQ(printed([](std::FILE* f) { JsonLine{f}.end(); }), "{}\n");
  EXPECT_EQ(printed([](std::FILE* f) {
              JsonLine j{f};
              j.begin_object("summary").field("bad_crc", 0).begin_object("inner");
              j.end();
            }),
            "{\"summary\":{\"bad_crc\":0,\"inner\":{}}}\n");
}

}  // namespace
}  // namespace teamscan::tool
