// MCAP record encoders byte for byte: opcode, little-endian uint64 content length, fields in the order
// and widths of the specification's tables (https://mcap.dev/spec), written out by hand here.
#include "common/mcap/records.hpp"

#include <gtest/gtest.h>

#include <string>
#include <vector>

namespace teamscan::mcap {
namespace {

Bytes hex(const std::string& h) {
  Bytes b;
  std::string digits;
  for (char c : h)
    if (c != ' ') digits += c;
  for (std::size_t i = 0; i + 1 < digits.size(); i += 2)
    b.push_back(static_cast<std::uint8_t>(std::stoul(digits.substr(i, 2), nullptr, 16)));
  return b;
}

TEST(McapCrc, CheckValueOfTheIeeeCrc32) {
  // The CRC-32/ISO-HDLC check value: crc32("123456789") = 0xCBF43926.
  const std::string s = "123456789";
  EXPECT_EQ(crc32(std::span<const std::uint8_t>(reinterpret_cast<const std::uint8_t*>(s.data()), s.size())),
            0xCBF43926u);
  EXPECT_EQ(crc32({}), 0u);
}

TEST(McapCrc, ContinuesAcrossPieces) {
  const std::string s = "123456789";
  const auto* p = reinterpret_cast<const std::uint8_t*>(s.data());
  const std::uint32_t first = crc32(std::span<const std::uint8_t>(p, 4));
  EXPECT_EQ(crc32(std::span<const std::uint8_t>(p + 4, 5), first), 0xCBF43926u);
}

TEST(McapRecords, Header) {
  Bytes out;
  append_header(out, "ros2", "x");
  // 01 | length 13 | string "ros2" | string "x"
  EXPECT_EQ(out, hex("01 0d00000000000000 04000000 726f7332 01000000 78"));
}

TEST(McapRecords, SchemaWithEmptyData) {
  Bytes out;
  append_schema(out, Schema{2, "a/msg/B", "ros2msg", ""});
  EXPECT_EQ(out, hex("03 1c00000000000000 0200 07000000 612f6d73672f42 07000000 726f73326d7367 00000000"));
}

TEST(McapRecords, ChannelWithMetadata) {
  Bytes out;
  append_channel(out, Channel{1, 2, "/t", "cdr", {{"k", "v"}}});
  // id 1, schema 2, "/t", "cdr", map of 10 bytes: "k" -> "v"
  EXPECT_EQ(out, hex("04 1f00000000000000 0100 0200 02000000 2f74 03000000 636472 0a000000 01000000 6b 01000000 76"));
}

TEST(McapRecords, Message) {
  Bytes out;
  const Bytes data = {0xAA, 0xBB};
  append_message(out, MessageHeader{3, 7, 0x0102030405060708ull, 9}, data);
  EXPECT_EQ(out, hex("05 1800000000000000 0300 07000000 0807060504030201 0900000000000000 aabb"));
}

TEST(McapRecords, ChunkCarriesItsRecordsUncompressed) {
  Bytes out;
  const Bytes records = {1, 2, 3};
  append_chunk(out, ChunkHeader{10, 20, 3, 0x11223344u, ""}, records);
  EXPECT_EQ(out, hex("06 2b00000000000000 0a00000000000000 1400000000000000 0300000000000000 44332211 00000000 "
                     "0300000000000000 010203"));
}

TEST(McapRecords, MessageIndexIsAnArrayOfTimeOffsetPairs) {
  Bytes out;
  const std::vector<std::pair<std::uint64_t, std::uint64_t>> entries = {{5, 0}, {6, 40}};
  append_message_index(out, 4, entries);
  EXPECT_EQ(out, hex("07 2600000000000000 0400 20000000 0500000000000000 0000000000000000 0600000000000000 "
                     "2800000000000000"));
}

TEST(McapRecords, ChunkIndex) {
  Bytes out;
  ChunkIndex c;
  c.message_start_time_ns = 1;
  c.message_end_time_ns = 2;
  c.chunk_start_offset = 3;
  c.chunk_length = 4;
  c.message_index_offsets = {{1, 5}};
  c.message_index_length = 6;
  c.compressed_size = 7;
  c.uncompressed_size = 7;
  append_chunk_index(out, c);
  EXPECT_EQ(out, hex("08 4a00000000000000 0100000000000000 0200000000000000 0300000000000000 0400000000000000 "
                     "0a000000 0100 0500000000000000 0600000000000000 00000000 0700000000000000 0700000000000000"));
}

TEST(McapRecords, Statistics) {
  Bytes out;
  Statistics s;
  s.message_count = 3;
  s.schema_count = 1;
  s.channel_count = 2;
  s.chunk_count = 1;
  s.message_start_time_ns = 10;
  s.message_end_time_ns = 11;
  s.channel_message_counts = {{1, 2}, {2, 1}};
  append_statistics(out, s);
  EXPECT_EQ(out, hex("0b 4200000000000000 0300000000000000 0100 02000000 00000000 00000000 01000000 "
                     "0a00000000000000 0b00000000000000 14000000 0100 0200000000000000 0200 0100000000000000"));
}

TEST(McapRecords, SummaryOffsetDataEndFooter) {
  Bytes out;
  append_summary_offset(out, Op::kChunkIndex, 100, 200);
  append_data_end(out, 0xDEADBEEFu);
  append_footer(out, 1, 2, 3);
  EXPECT_EQ(out, hex("0e 1100000000000000 08 6400000000000000 c800000000000000 "
                     "0f 0400000000000000 efbeadde "
                     "02 1400000000000000 0100000000000000 0200000000000000 03000000"));
}

}  // namespace
}  // namespace teamscan::mcap
