// MCAP records (https://mcap.dev/spec, format version 0): the opcodes and one encoder per record the
// writer emits, each appending `<opcode u8><content length u64><content>` to a byte buffer, all
// integers little-endian. Pure: no file, no clock; the CRC is IEEE 802.3 CRC-32 (zlib's crc32).
#pragma once

#include <cstdint>
#include <map>
#include <span>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace teamscan::mcap {

using Bytes = std::vector<std::uint8_t>;

// The 8 bytes that open and close every MCAP file: 0x89 "MCAP" '0' (major version) "\r\n".
inline constexpr std::uint8_t kMagic[8] = {0x89, 'M', 'C', 'A', 'P', '0', '\r', '\n'};

enum class Op : std::uint8_t {
  kHeader = 0x01,
  kFooter = 0x02,
  kSchema = 0x03,
  kChannel = 0x04,
  kMessage = 0x05,
  kChunk = 0x06,
  kMessageIndex = 0x07,
  kChunkIndex = 0x08,
  kStatistics = 0x0B,
  kSummaryOffset = 0x0E,
  kDataEnd = 0x0F,
};

// Opcode + uint64 length in front of every record.
inline constexpr std::size_t kRecordPrefixBytes = 9;

// IEEE 802.3 CRC-32 (the one MCAP names), continued from `crc` (0 to start).
[[nodiscard]] std::uint32_t crc32(std::span<const std::uint8_t> bytes, std::uint32_t crc = 0);

struct Schema {
  std::uint16_t id = 0;  // never 0
  std::string name;      // e.g. sensor_msgs/msg/PointCloud2
  std::string encoding;  // e.g. ros2msg
  std::string data;      // the definition text
};

struct Channel {
  std::uint16_t id = 0;
  std::uint16_t schema_id = 0;
  std::string topic;
  std::string message_encoding;  // e.g. cdr
  std::map<std::string, std::string> metadata;
};

struct MessageHeader {
  std::uint16_t channel_id = 0;
  std::uint32_t sequence = 0;
  std::uint64_t log_time_ns = 0;
  std::uint64_t publish_time_ns = 0;
};

struct ChunkHeader {
  std::uint64_t message_start_time_ns = 0;
  std::uint64_t message_end_time_ns = 0;
  std::uint64_t uncompressed_size = 0;
  std::uint32_t uncompressed_crc = 0;
  std::string compression;  // "" = none
};

struct ChunkIndex {
  std::uint64_t message_start_time_ns = 0;
  std::uint64_t message_end_time_ns = 0;
  std::uint64_t chunk_start_offset = 0;
  std::uint64_t chunk_length = 0;                                // the whole Chunk record, opcode and length included
  std::map<std::uint16_t, std::uint64_t> message_index_offsets;  // channel -> file offset of its Message Index
  std::uint64_t message_index_length = 0;
  std::string compression;
  std::uint64_t compressed_size = 0;
  std::uint64_t uncompressed_size = 0;
};

struct Statistics {
  std::uint64_t message_count = 0;
  std::uint16_t schema_count = 0;
  std::uint32_t channel_count = 0;
  std::uint32_t attachment_count = 0;
  std::uint32_t metadata_count = 0;
  std::uint32_t chunk_count = 0;
  std::uint64_t message_start_time_ns = 0;
  std::uint64_t message_end_time_ns = 0;
  std::map<std::uint16_t, std::uint64_t> channel_message_counts;
};

// Each appends one whole record (prefix included) to `out`.
void append_header(Bytes& out, std::string_view profile, std::string_view library);
void append_schema(Bytes& out, const Schema& s);
void append_channel(Bytes& out, const Channel& c);
void append_message(Bytes& out, const MessageHeader& h, std::span<const std::uint8_t> data);
// The chunk's records (uncompressed: `compression` must be "").
void append_chunk(Bytes& out, const ChunkHeader& h, std::span<const std::uint8_t> records);
// (log_time, offset into the chunk's records) per message of `channel_id` in the chunk.
void append_message_index(Bytes& out, std::uint16_t channel_id,
                          std::span<const std::pair<std::uint64_t, std::uint64_t>> entries);
void append_chunk_index(Bytes& out, const ChunkIndex& c);
void append_statistics(Bytes& out, const Statistics& s);
void append_summary_offset(Bytes& out, Op group_opcode, std::uint64_t group_start, std::uint64_t group_length);
void append_data_end(Bytes& out, std::uint32_t data_section_crc);
// The footer's fields; `summary_crc` covers the summary through summary_offset_start (see writer.cpp).
void append_footer(Bytes& out, std::uint64_t summary_start, std::uint64_t summary_offset_start,
                   std::uint32_t summary_crc);

}  // namespace teamscan::mcap
