// The ring's one seam to the operating system (STYLE.md 4): the preallocated ring file on the robot's
// storage, read and written a slot at a time with pread/pwrite and made durable with fdatasync. Every call
// retries EINTR and returns an error value; nothing here allocates after open().
#pragma once

#include <cstdint>
#include <span>
#include <string>

#include "common/result.hpp"

namespace teamscan::onboard::ring {

class RingFile {
 public:
  // Opens (creating if missing) `path` and makes it exactly slots * slot_bytes long, the blocks
  // allocated now (posix_fallocate) so that a write never fails for want of space later. A longer file
  // (a ring made larger before) is cut to size. The folder must exist.
  [[nodiscard]] static Result<RingFile> open(const std::string& path, std::uint64_t slots, std::size_t slot_bytes);

  RingFile(RingFile&& other) noexcept;
  RingFile& operator=(RingFile&& other) noexcept;
  RingFile(const RingFile&) = delete;
  RingFile& operator=(const RingFile&) = delete;
  ~RingFile();

  // `count` consecutive slots from `first` into `out` (count * slot_bytes bytes).
  [[nodiscard]] Status read_slots(std::uint64_t first, std::uint64_t count, std::span<std::uint8_t> out) const;
  // The bytes of one record at the start of slot `slot` (at most slot_bytes).
  [[nodiscard]] Status write_slot(std::uint64_t slot, std::span<const std::uint8_t> bytes);
  // fdatasync: every record written so far survives a power cut.
  [[nodiscard]] Status sync();

  [[nodiscard]] std::uint64_t slots() const { return slots_; }
  [[nodiscard]] std::size_t slot_bytes() const { return slot_bytes_; }
  [[nodiscard]] bool created() const { return created_; }  // the file did not exist (or was empty)

 private:
  RingFile(int fd, std::uint64_t slots, std::size_t slot_bytes, bool created)
      : fd_{fd}, slots_{slots}, slot_bytes_{slot_bytes}, created_{created} {}
  int fd_ = -1;
  std::uint64_t slots_ = 0;
  std::size_t slot_bytes_ = 0;
  bool created_ = false;
};

}  // namespace teamscan::onboard::ring
