// MCAP record encoders (records.hpp): field order and types as in the specification's record tables.
#include "common/mcap/records.hpp"

#include <zlib.h>

#include <limits>

namespace teamscan::mcap {
namespace {

void put_u8(Bytes& out, std::uint8_t v) { out.push_back(v); }
void put_le(Bytes& out, std::uint64_t v, int bytes) {
  for (int i = 0; i < bytes; ++i) out.push_back(static_cast<std::uint8_t>(v >> (8 * i)));
}
void put_u16(Bytes& out, std::uint16_t v) { put_le(out, v, 2); }
void put_u32(Bytes& out, std::uint32_t v) { put_le(out, v, 4); }
void put_u64(Bytes& out, std::uint64_t v) { put_le(out, v, 8); }
void put_string(Bytes& out, std::string_view s) {
  put_u32(out, static_cast<std::uint32_t>(s.size()));
  out.insert(out.end(), s.begin(), s.end());
}

// Writes the opcode and a placeholder length; returns where the content starts.
std::size_t begin_record(Bytes& out, Op op) {
  put_u8(out, static_cast<std::uint8_t>(op));
  put_u64(out, 0);
  return out.size();
}
void end_record(Bytes& out, std::size_t content_start) {
  const std::uint64_t n = out.size() - content_start;
  for (int i = 0; i < 8; ++i)
    out[content_start - 8 + static_cast<std::size_t>(i)] = static_cast<std::uint8_t>(n >> (8 * i));
}

// Map<uint16, uint64>: uint32 byte length, then key/value pairs.
void put_u16_u64_map(Bytes& out, const std::map<std::uint16_t, std::uint64_t>& m) {
  put_u32(out, static_cast<std::uint32_t>(m.size() * 10));
  for (const auto& [k, v] : m) {
    put_u16(out, k);
    put_u64(out, v);
  }
}

}  // namespace

std::uint32_t crc32(std::span<const std::uint8_t> bytes, std::uint32_t crc) {
  // zlib takes uInt lengths: feed large spans in pieces.
  uLong c = crc;
  std::size_t pos = 0;
  while (pos < bytes.size()) {
    const std::size_t n = std::min<std::size_t>(bytes.size() - pos, std::numeric_limits<uInt>::max());
    c = ::crc32(c, bytes.data() + pos, static_cast<uInt>(n));
    pos += n;
  }
  return static_cast<std::uint32_t>(c);
}

void append_header(Bytes& out, std::string_view profile, std::string_view library) {
  const std::size_t s = begin_record(out, Op::kHeader);
  put_string(out, profile);
  put_string(out, library);
  end_record(out, s);
}

void append_schema(Bytes& out, const Schema& sc) {
  const std::size_t s = begin_record(out, Op::kSchema);
  put_u16(out, sc.id);
  put_string(out, sc.name);
  put_string(out, sc.encoding);
  put_string(out, sc.data);  // uint32 length-prefixed bytes
  end_record(out, s);
}

void append_channel(Bytes& out, const Channel& c) {
  const std::size_t s = begin_record(out, Op::kChannel);
  put_u16(out, c.id);
  put_u16(out, c.schema_id);
  put_string(out, c.topic);
  put_string(out, c.message_encoding);
  std::uint32_t map_bytes = 0;
  for (const auto& [k, v] : c.metadata) map_bytes += static_cast<std::uint32_t>(8 + k.size() + v.size());
  put_u32(out, map_bytes);
  for (const auto& [k, v] : c.metadata) {
    put_string(out, k);
    put_string(out, v);
  }
  end_record(out, s);
}

void append_message(Bytes& out, const MessageHeader& h, std::span<const std::uint8_t> data) {
  const std::size_t s = begin_record(out, Op::kMessage);
  put_u16(out, h.channel_id);
  put_u32(out, h.sequence);
  put_u64(out, h.log_time_ns);
  put_u64(out, h.publish_time_ns);
  out.insert(out.end(), data.begin(), data.end());
  end_record(out, s);
}

void append_chunk(Bytes& out, const ChunkHeader& h, std::span<const std::uint8_t> records) {
  const std::size_t s = begin_record(out, Op::kChunk);
  put_u64(out, h.message_start_time_ns);
  put_u64(out, h.message_end_time_ns);
  put_u64(out, h.uncompressed_size);
  put_u32(out, h.uncompressed_crc);
  put_string(out, h.compression);
  put_u64(out, records.size());  // uint64 length-prefixed bytes
  out.insert(out.end(), records.begin(), records.end());
  end_record(out, s);
}

void append_message_index(Bytes& out, std::uint16_t channel_id,
                          std::span<const std::pair<std::uint64_t, std::uint64_t>> entries) {
  const std::size_t s = begin_record(out, Op::kMessageIndex);
  put_u16(out, channel_id);
  put_u32(out, static_cast<std::uint32_t>(entries.size() * 16));  // Array: uint32 byte length
  for (const auto& [log_time, offset] : entries) {
    put_u64(out, log_time);
    put_u64(out, offset);
  }
  end_record(out, s);
}

void append_chunk_index(Bytes& out, const ChunkIndex& c) {
  const std::size_t s = begin_record(out, Op::kChunkIndex);
  put_u64(out, c.message_start_time_ns);
  put_u64(out, c.message_end_time_ns);
  put_u64(out, c.chunk_start_offset);
  put_u64(out, c.chunk_length);
  put_u16_u64_map(out, c.message_index_offsets);
  put_u64(out, c.message_index_length);
  put_string(out, c.compression);
  put_u64(out, c.compressed_size);
  put_u64(out, c.uncompressed_size);
  end_record(out, s);
}

void append_statistics(Bytes& out, const Statistics& st) {
  const std::size_t s = begin_record(out, Op::kStatistics);
  put_u64(out, st.message_count);
  put_u16(out, st.schema_count);
  put_u32(out, st.channel_count);
  put_u32(out, st.attachment_count);
  put_u32(out, st.metadata_count);
  put_u32(out, st.chunk_count);
  put_u64(out, st.message_start_time_ns);
  put_u64(out, st.message_end_time_ns);
  put_u16_u64_map(out, st.channel_message_counts);
  end_record(out, s);
}

void append_summary_offset(Bytes& out, Op group_opcode, std::uint64_t group_start, std::uint64_t group_length) {
  const std::size_t s = begin_record(out, Op::kSummaryOffset);
  put_u8(out, static_cast<std::uint8_t>(group_opcode));
  put_u64(out, group_start);
  put_u64(out, group_length);
  end_record(out, s);
}

void append_data_end(Bytes& out, std::uint32_t data_section_crc) {
  const std::size_t s = begin_record(out, Op::kDataEnd);
  put_u32(out, data_section_crc);
  end_record(out, s);
}

void append_footer(Bytes& out, std::uint64_t summary_start, std::uint64_t summary_offset_start,
                   std::uint32_t summary_crc) {
  const std::size_t s = begin_record(out, Op::kFooter);
  put_u64(out, summary_start);
  put_u64(out, summary_offset_start);
  put_u32(out, summary_crc);
  end_record(out, s);
}

}  // namespace teamscan::mcap
