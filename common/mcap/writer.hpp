// An MCAP file writer (https://mcap.dev/spec): messages batched into uncompressed Chunks, a Message
// Index per channel after each chunk, Data End, then the Summary section (Schema, Channel, Chunk Index,
// Statistics) with a Summary Offset per group, the Footer and the closing magic, every CRC filled in.
// Indexed so that a reader (Foxglove, @mcap/core's indexed reader) seeks by time without a full scan.
#pragma once

#include <cstdint>
#include <cstdio>
#include <map>
#include <memory>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include "common/mcap/records.hpp"
#include "common/result.hpp"

namespace teamscan::mcap {

struct WriterOptions {
  std::string profile = "ros2";      // the Header's profile (a well-known one: ros2)
  std::string library = "teamscan";  // the Header's library (name and version of the writer)
  // A chunk is closed once its records reach this many bytes (the message that crosses it included).
  std::uint64_t chunk_bytes = 1u << 20;
};

struct WriterCounters {
  std::uint64_t messages = 0;
  std::uint32_t chunks = 0;
  std::uint64_t bytes = 0;  // written so far (the whole file after close())
};

class Writer {
 public:
  // Creates (truncates) `path`; the magic and the Header are written at once.
  [[nodiscard]] static Result<std::unique_ptr<Writer>> to_file(const std::string& path, const WriterOptions& options);
  // Appends the file to `out` (tests; the caller keeps `out` alive until close()).
  [[nodiscard]] static std::unique_ptr<Writer> to_memory(Bytes& out, const WriterOptions& options);
  ~Writer();  // closes the file if close() was not called (no summary then: call close())
  Writer(const Writer&) = delete;
  Writer& operator=(const Writer&) = delete;

  // Ids count from 1. The record goes into the current chunk, ahead of any message that uses it.
  [[nodiscard]] std::uint16_t add_schema(const std::string& name, const std::string& encoding, const std::string& data);
  [[nodiscard]] std::uint16_t add_channel(std::uint16_t schema_id, const std::string& topic,
                                          const std::string& message_encoding,
                                          const std::map<std::string, std::string>& metadata = {});
  // One message on a channel added before (a contract). Times in ns (MCAP Timestamp).
  [[nodiscard]] Status write(std::uint16_t channel_id, std::uint32_t sequence, std::uint64_t log_time_ns,
                             std::uint64_t publish_time_ns, std::span<const std::uint8_t> data);
  // Ends the data section and writes the summary, the footer and the magic; the file is complete.
  [[nodiscard]] Status close();

  [[nodiscard]] const WriterCounters& counters() const { return counters_; }

 private:
  Writer(std::FILE* file, Bytes* memory, const WriterOptions& options);
  [[nodiscard]] Status emit(std::span<const std::uint8_t> bytes);  // to the file or memory, CRC'd
  [[nodiscard]] Status flush_chunk();

  std::FILE* file_ = nullptr;
  Bytes* memory_ = nullptr;
  WriterOptions options_;
  bool closed_ = false;
  std::uint64_t offset_ = 0;    // bytes emitted so far
  std::uint32_t data_crc_ = 0;  // over every byte from the leading magic on, until Data End

  std::vector<Schema> schemas_;
  std::vector<Channel> channels_;
  std::vector<ChunkIndex> chunk_indexes_;
  Statistics stats_;

  // The open chunk: its records, their time span and per-channel (log time, offset) index.
  Bytes chunk_;
  std::uint64_t chunk_start_ns_ = 0, chunk_end_ns_ = 0;
  bool chunk_has_messages_ = false;
  std::map<std::uint16_t, std::vector<std::pair<std::uint64_t, std::uint64_t>>> chunk_index_;
  Bytes scratch_;
  WriterCounters counters_;
};

}  // namespace teamscan::mcap
