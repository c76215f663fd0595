// The MCAP writer (writer.hpp): chunking, per-chunk message indexes, the summary section and the CRCs.
#include "common/mcap/writer.hpp"

#include <cerrno>

namespace teamscan::mcap {

Result<std::unique_ptr<Writer>> Writer::to_file(const std::string& path, const WriterOptions& options) {
  std::FILE* f = std::fopen(path.c_str(), "wb");
  if (f == nullptr) return Error{"mcap: cannot create the output file", errno};
  std::unique_ptr<Writer> w(new Writer(f, nullptr, options));
  Bytes head(std::begin(kMagic), std::end(kMagic));
  append_header(head, options.profile, options.library);
  if (Status st = w->emit(head); !st.ok()) return st.error();
  return w;
}

std::unique_ptr<Writer> Writer::to_memory(Bytes& out, const WriterOptions& options) {
  std::unique_ptr<Writer> w(new Writer(nullptr, &out, options));
  Bytes head(std::begin(kMagic), std::end(kMagic));
  append_header(head, options.profile, options.library);
  (void)w->emit(head);  // memory never fails
  return w;
}

Writer::Writer(std::FILE* file, Bytes* memory, const WriterOptions& options)
    : file_{file}, memory_{memory}, options_{options} {}

Writer::~Writer() {
  if (file_ != nullptr) std::fclose(file_);
}

Status Writer::emit(std::span<const std::uint8_t> bytes) {
  if (!closed_) data_crc_ = crc32(bytes, data_crc_);
  offset_ += bytes.size();
  counters_.bytes = offset_;
  if (memory_ != nullptr) {
    memory_->insert(memory_->end(), bytes.begin(), bytes.end());
    return ok_status();
  }
  if (std::fwrite(bytes.data(), 1, bytes.size(), file_) != bytes.size()) {
    return Error{"mcap: cannot write the output file", errno};
  }
  return ok_status();
}

std::uint16_t Writer::add_schema(const std::string& name, const std::string& encoding, const std::string& data) {
  TEAMSCAN_EXPECTS(!closed_ && schemas_.size() < 0xFFFF);
  Schema s{static_cast<std::uint16_t>(schemas_.size() + 1), name, encoding, data};
  append_schema(chunk_, s);
  schemas_.push_back(std::move(s));
  return schemas_.back().id;
}

std::uint16_t Writer::add_channel(std::uint16_t schema_id, const std::string& topic,
                                  const std::string& message_encoding,
                                  const std::map<std::string, std::string>& metadata) {
  TEAMSCAN_EXPECTS(!closed_ && channels_.size() < 0xFFFF && schema_id <= schemas_.size());
  Channel c{static_cast<std::uint16_t>(channels_.size() + 1), schema_id, topic, message_encoding, metadata};
  append_channel(chunk_, c);
  channels_.push_back(std::move(c));
  return channels_.back().id;
}

Status Writer::write(std::uint16_t channel_id, std::uint32_t sequence, std::uint64_t log_time_ns,
                     std::uint64_t publish_time_ns, std::span<const std::uint8_t> data) {
  TEAMSCAN_EXPECTS(!closed_ && channel_id >= 1 && channel_id <= channels_.size());
  chunk_index_[channel_id].emplace_back(log_time_ns, chunk_.size());
  append_message(chunk_, MessageHeader{channel_id, sequence, log_time_ns, publish_time_ns}, data);
  if (!chunk_has_messages_ || log_time_ns < chunk_start_ns_) chunk_start_ns_ = log_time_ns;
  if (!chunk_has_messages_ || log_time_ns > chunk_end_ns_) chunk_end_ns_ = log_time_ns;
  chunk_has_messages_ = true;
  if (stats_.message_count == 0 || log_time_ns < stats_.message_start_time_ns)
    stats_.message_start_time_ns = log_time_ns;
  if (stats_.message_count == 0 || log_time_ns > stats_.message_end_time_ns) stats_.message_end_time_ns = log_time_ns;
  ++stats_.message_count;
  ++stats_.channel_message_counts[channel_id];
  ++counters_.messages;
  if (chunk_.size() >= options_.chunk_bytes) return flush_chunk();
  return ok_status();
}

Status Writer::flush_chunk() {
  if (chunk_.empty()) return ok_status();
  ChunkIndex ci;
  ci.message_start_time_ns = chunk_has_messages_ ? chunk_start_ns_ : 0;
  ci.message_end_time_ns = chunk_has_messages_ ? chunk_end_ns_ : 0;
  ci.chunk_start_offset = offset_;
  ci.compression = "";
  ci.compressed_size = chunk_.size();
  ci.uncompressed_size = chunk_.size();

  scratch_.clear();
  append_chunk(scratch_,
               ChunkHeader{ci.message_start_time_ns, ci.message_end_time_ns, chunk_.size(), crc32(chunk_), ""}, chunk_);
  ci.chunk_length = scratch_.size();
  // The Message Index records follow the chunk, one per channel with messages in it (ascending ids).
  const std::uint64_t index_start = offset_ + scratch_.size();
  for (const auto& [channel, entries] : chunk_index_) {
    ci.message_index_offsets[channel] = offset_ + scratch_.size();
    append_message_index(scratch_, channel, entries);
  }
  ci.message_index_length = offset_ + scratch_.size() - index_start;
  if (Status st = emit(scratch_); !st.ok()) return st;

  chunk_indexes_.push_back(std::move(ci));
  ++counters_.chunks;
  chunk_.clear();
  chunk_index_.clear();
  chunk_has_messages_ = false;
  return ok_status();
}

Status Writer::close() {
  TEAMSCAN_EXPECTS(!closed_);
  if (Status st = flush_chunk(); !st.ok()) return st;
  Bytes out;
  append_data_end(out, data_crc_);  // the CRC of every byte before this record, magic included
  if (Status st = emit(out); !st.ok()) return st;
  closed_ = true;

  // Summary: records grouped by opcode, each group located by a Summary Offset record.
  const std::uint64_t summary_start = offset_;
  Bytes summary;
  struct Group {
    Op op;
    std::uint64_t start, length;
  };
  std::vector<Group> groups;
  auto group = [&](Op op, auto&& append_all) {
    const std::size_t before = summary.size();
    append_all();
    if (summary.size() > before) groups.push_back({op, summary_start + before, summary.size() - before});
  };
  group(Op::kSchema, [&] {
    for (const Schema& s : schemas_) append_schema(summary, s);
  });
  group(Op::kChannel, [&] {
    for (const Channel& c : channels_) append_channel(summary, c);
  });
  group(Op::kChunkIndex, [&] {
    for (const ChunkIndex& c : chunk_indexes_) append_chunk_index(summary, c);
  });
  stats_.schema_count = static_cast<std::uint16_t>(schemas_.size());
  stats_.channel_count = static_cast<std::uint32_t>(channels_.size());
  stats_.chunk_count = static_cast<std::uint32_t>(chunk_indexes_.size());
  group(Op::kStatistics, [&] { append_statistics(summary, stats_); });

  const std::uint64_t summary_offset_start = summary_start + summary.size();
  for (const Group& g : groups) append_summary_offset(summary, g.op, g.start, g.length);

  // Footer: its CRC covers the summary, the summary offsets and the footer up to summary_crc.
  Bytes footer;
  append_footer(footer, summary_start, summary_offset_start, 0);
  std::uint32_t crc = crc32(summary);
  crc = crc32(std::span<const std::uint8_t>(footer.data(), footer.size() - 4), crc);
  for (int i = 0; i < 4; ++i)
    footer[footer.size() - 4 + static_cast<std::size_t>(i)] = static_cast<std::uint8_t>(crc >> (8 * i));
  footer.insert(footer.end(), std::begin(kMagic), std::end(kMagic));

  if (Status st = emit(summary); !st.ok()) return st;
  if (Status st = emit(footer); !st.ok()) return st;
  if (file_ != nullptr) {
    const bool ok = std::fflush(file_) == 0;
    const int err = errno;
    const bool closed_ok = std::fclose(file_) == 0;
    file_ = nullptr;
    if (!ok || !closed_ok) return Error{"mcap: cannot write the output file", err};
  }
  return ok_status();
}

}  // namespace teamscan::mcap
