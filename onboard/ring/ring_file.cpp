// The ring file (ring_file.hpp).
#include "onboard/ring/ring_file.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <utility>

#include "drivers/serial/posix_call.hpp"

namespace teamscan::onboard::ring {

using serial::posix_call;

Result<RingFile> RingFile::open(const std::string& path, std::uint64_t slots, std::size_t slot_bytes) {
  const auto fd = posix_call([&] { return ::open(path.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0640); });
  if (!fd.ok()) return Error{"ring: cannot open the ring file", fd.err};
  const int f = static_cast<int>(fd.value);
  struct stat st {};
  if (::fstat(f, &st) != 0) {
    const int e = errno;
    ::close(f);
    return Error{"ring: cannot stat the ring file", e};
  }
  const auto bytes = static_cast<off_t>(slots * slot_bytes);
  if (st.st_size > bytes) {
    const auto t = posix_call([&] { return ::ftruncate(f, bytes); });
    if (!t.ok()) {
      ::close(f);
      return Error{"ring: cannot cut the ring file to size", t.err};
    }
  }
  // posix_fallocate returns the error number itself (not -1/errno).
  int rc;
  do rc = ::posix_fallocate(f, 0, bytes);
  while (rc == EINTR);
  if (rc != 0) {
    ::close(f);
    return Error{"ring: cannot allocate the ring file's blocks (disk full?)", rc, static_cast<long>(bytes)};
  }
  return RingFile{f, slots, slot_bytes, st.st_size == 0};
}

RingFile::RingFile(RingFile&& other) noexcept
    : fd_{std::exchange(other.fd_, -1)},
      slots_{other.slots_},
      slot_bytes_{other.slot_bytes_},
      created_{other.created_} {}

RingFile& RingFile::operator=(RingFile&& other) noexcept {
  if (this != &other) {
    if (fd_ >= 0) ::close(fd_);
    fd_ = std::exchange(other.fd_, -1);
    slots_ = other.slots_;
    slot_bytes_ = other.slot_bytes_;
    created_ = other.created_;
  }
  return *this;
}

RingFile::~RingFile() {
  if (fd_ >= 0) ::close(fd_);
}

Status RingFile::read_slots(std::uint64_t first, std::uint64_t count, std::span<std::uint8_t> out) const {
  if (first + count > slots_ || out.size() < count * slot_bytes_) return Error{"ring: read outside the file"};
  std::size_t done = 0;
  const std::size_t want = count * slot_bytes_;
  while (done < want) {
    const auto n = posix_call(
        [&] { return ::pread(fd_, out.data() + done, want - done, static_cast<off_t>(first * slot_bytes_ + done)); });
    if (!n.ok()) return Error{"ring: read failed", n.err};
    if (n.value == 0) return Error{"ring: the file ends early"};
    done += static_cast<std::size_t>(n.value);
  }
  return ok_status();
}

Status RingFile::write_slot(std::uint64_t slot, std::span<const std::uint8_t> bytes) {
  if (slot >= slots_ || bytes.size() > slot_bytes_) return Error{"ring: write outside the file"};
  std::size_t done = 0;
  while (done < bytes.size()) {
    const auto n = posix_call([&] {
      return ::pwrite(fd_, bytes.data() + done, bytes.size() - done, static_cast<off_t>(slot * slot_bytes_ + done));
    });
    if (!n.ok()) return Error{"ring: write failed", n.err};
    done += static_cast<std::size_t>(n.value);
  }
  return ok_status();
}

Status RingFile::sync() {
  const auto r = posix_call([&] { return ::fdatasync(fd_); });
  if (!r.ok()) return Error{"ring: fdatasync failed", r.err};
  return ok_status();
}

}  // namespace teamscan::onboard::ring
