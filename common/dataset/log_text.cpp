// A log's text, plain or xz (log_text.hpp).
#include "common/dataset/log_text.hpp"

#include <lzma.h>

#include <cstdint>
#include <cstring>
#include <vector>

#include "common/dataset/pcd.hpp"

namespace teamscan {
namespace {

constexpr std::uint8_t kXzMagic[6] = {0xFD, '7', 'z', 'X', 'Z', 0x00};

Result<std::string> decompress_xz(const std::vector<std::uint8_t>& in) {
  lzma_stream s = LZMA_STREAM_INIT;
  if (lzma_stream_decoder(&s, UINT64_MAX, LZMA_CONCATENATED) != LZMA_OK) return Error{"xz: cannot start the decoder"};
  std::string out;
  std::vector<std::uint8_t> chunk(1 << 20);
  s.next_in = in.data();
  s.avail_in = in.size();
  lzma_ret r = LZMA_OK;
  while (r == LZMA_OK) {
    s.next_out = chunk.data();
    s.avail_out = chunk.size();
    r = lzma_code(&s, s.avail_in == 0 ? LZMA_FINISH : LZMA_RUN);
    out.append(reinterpret_cast<const char*>(chunk.data()), chunk.size() - s.avail_out);
  }
  lzma_end(&s);
  if (r != LZMA_STREAM_END) return Error{"xz: corrupt or truncated stream"};
  return out;
}

}  // namespace

Result<std::string> read_log_text(const std::string& path) {
  auto bytes = read_file_bytes(path);
  if (!bytes) return bytes.error();
  if (bytes->size() >= sizeof kXzMagic && std::memcmp(bytes->data(), kXzMagic, sizeof kXzMagic) == 0) return decompress_xz(*bytes);
  return std::string(bytes->begin(), bytes->end());
}

}  // namespace teamscan
