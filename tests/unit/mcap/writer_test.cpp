// A whole MCAP file from the writer, walked record by record as an indexed reader would: magic at both
// ends, the Footer's offsets, the Summary Offsets, each Chunk Index pointing at its chunk and its Message
// Indexes, each index entry at a Message record, and every CRC (chunk, data section, summary) recomputed.
#include "common/mcap/writer.hpp"

#include <gtest/gtest.h>

#include <cstring>
#include <map>
#include <vector>

#include "common/mcap/records.hpp"

namespace teamscan::mcap {
namespace {

std::uint64_t le(const Bytes& b, std::size_t at, int n) {
  std::uint64_t v = 0;
  for (int i = 0; i < n; ++i) v |= static_cast<std::uint64_t>(b.at(at + static_cast<std::size_t>(i))) << (8 * i);
  return v;
}

struct Record {
  std::uint8_t op = 0;
  std::size_t start = 0;    // the opcode's offset
  std::size_t content = 0;  // the content's offset
  std::uint64_t length = 0;
};

Record record_at(const Bytes& b, std::size_t at) { return {b.at(at), at, at + 9, le(b, at + 1, 8)}; }

// Every record from `from` up to `to`.
std::vector<Record> walk(const Bytes& b, std::size_t from, std::size_t to) {
  std::vector<Record> out;
  while (from < to) {
    out.push_back(record_at(b, from));
    from += 9 + out.back().length;
  }
  EXPECT_EQ(from, to);
  return out;
}

std::uint32_t crc_of(const Bytes& b, std::size_t from, std::size_t to) {
  return crc32(std::span<const std::uint8_t>(b.data() + from, to - from));
}

class McapWriterFile : public ::testing::Test {
 protected:
  // Two channels, five messages, chunks of at most ~100 bytes: several chunks.
  void SetUp() override {
    WriterOptions o;
    o.library = "test";
    o.chunk_bytes = 100;
    auto w = Writer::to_memory(file_, o);
    const std::uint16_t s = w->add_schema("pkg/msg/A", "ros2msg", "int32 a");
    const std::uint16_t c1 = w->add_channel(s, "/one", "cdr");
    const std::uint16_t c2 = w->add_channel(s, "/two", "cdr", {{"offered_qos_profiles", ""}});
    const Bytes payload(40, 0x5A);
    for (std::uint64_t i = 0; i < 5; ++i) {
      ASSERT_TRUE(w->write(i % 2 == 0 ? c1 : c2, static_cast<std::uint32_t>(i), 1000 + i, 900 + i, payload).ok());
    }
    ASSERT_TRUE(w->close().ok());
    EXPECT_EQ(w->counters().messages, 5u);
    EXPECT_EQ(w->counters().bytes, file_.size());
    chunks_ = w->counters().chunks;
  }
  Bytes file_;
  std::uint32_t chunks_ = 0;
};

TEST_F(McapWriterFile, StartsWithMagicAndHeaderEndsWithFooterAndMagic) {
  ASSERT_GT(file_.size(), 16u + 29u);
  EXPECT_EQ(0, std::memcmp(file_.data(), kMagic, 8));
  EXPECT_EQ(0, std::memcmp(file_.data() + file_.size() - 8, kMagic, 8));
  EXPECT_EQ(record_at(file_, 8).op, static_cast<std::uint8_t>(Op::kHeader));
  const Record footer = record_at(file_, file_.size() - 8 - 29);
  EXPECT_EQ(footer.op, static_cast<std::uint8_t>(Op::kFooter));
  EXPECT_EQ(footer.length, 20u);
}

TEST_F(McapWriterFile, DataSectionIsChunksWithMessageIndexesThenDataEnd) {
  const std::size_t footer_at = file_.size() - 8 - 29;
  const std::uint64_t summary_start = le(file_, footer_at + 9, 8);
  const Record header = record_at(file_, 8);
  const auto data = walk(file_, header.content + header.length, summary_start);
  ASSERT_FALSE(data.empty());
  EXPECT_EQ(data.back().op, static_cast<std::uint8_t>(Op::kDataEnd));
  // Data End's CRC: every byte before it, from the leading magic on.
  EXPECT_EQ(le(file_, data.back().content, 4), crc_of(file_, 0, data.back().start));
  std::uint32_t chunks = 0;
  for (std::size_t i = 0; i + 1 < data.size(); ++i) {
    const Record& r = data[i];
    ASSERT_TRUE(r.op == static_cast<std::uint8_t>(Op::kChunk) || r.op == static_cast<std::uint8_t>(Op::kMessageIndex));
    if (r.op != static_cast<std::uint8_t>(Op::kChunk)) continue;
    ++chunks;
    const std::uint64_t size = le(file_, r.content + 16, 8);
    const std::uint32_t crc = static_cast<std::uint32_t>(le(file_, r.content + 24, 4));
    EXPECT_EQ(le(file_, r.content + 28, 4), 0u) << "compression \"\"";
    EXPECT_EQ(le(file_, r.content + 32, 8), size);
    const std::size_t records = r.content + 40;
    EXPECT_EQ(crc, crc_of(file_, records, records + size));
    EXPECT_EQ(records + size, r.content + r.length);
  }
  EXPECT_EQ(chunks, chunks_);
  EXPECT_GE(chunks, 2u);
}

TEST_F(McapWriterFile, SummaryOffsetsLocateEachGroupAndTheFooterCrcCoversTheSummary) {
  const std::size_t footer_at = file_.size() - 8 - 29;
  const std::uint64_t summary_start = le(file_, footer_at + 9, 8);
  const std::uint64_t offsets_start = le(file_, footer_at + 17, 8);
  const std::uint32_t summary_crc = static_cast<std::uint32_t>(le(file_, footer_at + 25, 4));
  EXPECT_EQ(summary_crc, crc_of(file_, summary_start, footer_at + 25));

  const auto offsets = walk(file_, offsets_start, footer_at);
  std::map<std::uint8_t, std::pair<std::uint64_t, std::uint64_t>> groups;
  for (const Record& r : offsets) {
    ASSERT_EQ(r.op, static_cast<std::uint8_t>(Op::kSummaryOffset));
    groups[file_.at(r.content)] = {le(file_, r.content + 1, 8), le(file_, r.content + 9, 8)};
  }
  ASSERT_EQ(groups.size(), 4u);  // Schema, Channel, Chunk Index, Statistics
  std::map<std::uint8_t, int> counts;
  for (const auto& [op, span] : groups) {
    for (const Record& r : walk(file_, span.first, span.first + span.second)) {
      EXPECT_EQ(r.op, op);
      ++counts[op];
    }
  }
  EXPECT_EQ(counts[static_cast<std::uint8_t>(Op::kSchema)], 1);
  EXPECT_EQ(counts[static_cast<std::uint8_t>(Op::kChannel)], 2);
  EXPECT_EQ(counts[static_cast<std::uint8_t>(Op::kChunkIndex)], static_cast<int>(chunks_));
  EXPECT_EQ(counts[static_cast<std::uint8_t>(Op::kStatistics)], 1);

  // Statistics: 5 messages, 1 schema, 2 channels, the chunks, first and last log time.
  const Record st = record_at(file_, groups[static_cast<std::uint8_t>(Op::kStatistics)].first);
  EXPECT_EQ(le(file_, st.content, 8), 5u);
  EXPECT_EQ(le(file_, st.content + 8, 2), 1u);
  EXPECT_EQ(le(file_, st.content + 10, 4), 2u);
  EXPECT_EQ(le(file_, st.content + 22, 4), chunks_);
  EXPECT_EQ(le(file_, st.content + 26, 8), 1000u);
  EXPECT_EQ(le(file_, st.content + 34, 8), 1004u);
}

TEST_F(McapWriterFile, ChunkIndexesPointAtChunksWhoseMessageIndexesPointAtMessages) {
  const std::size_t footer_at = file_.size() - 8 - 29;
  const std::uint64_t offsets_start = le(file_, footer_at + 17, 8);
  std::uint64_t ci_start = 0, ci_len = 0;
  for (const Record& r : walk(file_, offsets_start, footer_at)) {
    if (file_.at(r.content) == static_cast<std::uint8_t>(Op::kChunkIndex)) {
      ci_start = le(file_, r.content + 1, 8);
      ci_len = le(file_, r.content + 9, 8);
    }
  }
  std::uint64_t messages = 0;
  std::uint64_t previous_end_time = 0;
  for (const Record& ci : walk(file_, ci_start, ci_start + ci_len)) {
    const std::uint64_t start_time = le(file_, ci.content, 8), end_time = le(file_, ci.content + 8, 8);
    EXPECT_LE(start_time, end_time);
    EXPECT_GE(start_time, previous_end_time);
    previous_end_time = end_time;
    const std::uint64_t chunk_at = le(file_, ci.content + 16, 8);
    const std::uint64_t chunk_len = le(file_, ci.content + 24, 8);
    const Record chunk = record_at(file_, chunk_at);
    ASSERT_EQ(chunk.op, static_cast<std::uint8_t>(Op::kChunk));
    EXPECT_EQ(9 + chunk.length, chunk_len);
    const std::size_t records = chunk.content + 40;
    const std::uint32_t map_bytes = static_cast<std::uint32_t>(le(file_, ci.content + 32, 4));
    for (std::size_t p = ci.content + 36; p < ci.content + 36 + map_bytes; p += 10) {
      const std::uint16_t channel = static_cast<std::uint16_t>(le(file_, p, 2));
      const Record mi = record_at(file_, le(file_, p + 2, 8));
      ASSERT_EQ(mi.op, static_cast<std::uint8_t>(Op::kMessageIndex));
      EXPECT_EQ(le(file_, mi.content, 2), channel);
      const std::uint32_t entries_bytes = static_cast<std::uint32_t>(le(file_, mi.content + 2, 4));
      for (std::size_t e = mi.content + 6; e < mi.content + 6 + entries_bytes; e += 16) {
        const std::uint64_t log_time = le(file_, e, 8);
        const Record m = record_at(file_, records + le(file_, e + 8, 8));
        ASSERT_EQ(m.op, static_cast<std::uint8_t>(Op::kMessage));
        EXPECT_EQ(le(file_, m.content, 2), channel);
        EXPECT_EQ(le(file_, m.content + 6, 8), log_time);
        EXPECT_EQ(le(file_, m.content + 14, 8), log_time - 100) << "publish time kept";
        EXPECT_EQ(m.length, 22u + 40u);
        ++messages;
      }
    }
    // The Message Indexes follow the chunk directly and fill message_index_length.
    EXPECT_EQ(le(file_, ci.content + 36 + map_bytes, 8) > 0, map_bytes > 0);
  }
  EXPECT_EQ(messages, 5u);
}

TEST(McapWriter, EmptyFileHasHeaderDataEndSummaryAndFooter) {
  Bytes file;
  auto w = Writer::to_memory(file, WriterOptions{});
  ASSERT_TRUE(w->close().ok());
  EXPECT_EQ(w->counters().chunks, 0u);
  EXPECT_EQ(0, std::memcmp(file.data() + file.size() - 8, kMagic, 8));
  const Record header = record_at(file, 8);
  const Record data_end = record_at(file, header.content + header.length);
  EXPECT_EQ(data_end.op, static_cast<std::uint8_t>(Op::kDataEnd));
}

TEST(McapWriter, UnwritableFileIsAnError) {
  auto w = Writer::to_file("/nonexistent-dir/x.mcap", WriterOptions{});
  ASSERT_FALSE(w.ok());
  EXPECT_NE(w.error().sys_errno, 0);
}

}  // namespace
}  // namespace teamscan::mcap
