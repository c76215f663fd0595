// LZF decompression (Marc Lehmann's liblzf format), the codec of PCD's DATA binary_compressed.
// Every read and every back-reference is bounds-checked: malformed input is an Error, never a crash.
#include <cstring>

#include "common/dataset/pcd.hpp"

namespace teamscan {

// Format (liblzf lzf_d.c): a control byte c.
//   c < 32:  a literal run of c + 1 bytes follows.
//   c >= 32: a back-reference; length = (c >> 5) + 2, or if (c >> 5) == 7 one more byte adds to it;
//            the next byte is the low 8 bits of the offset, whose high 5 bits are c & 0x1f; the copy
//            starts (offset + 1) bytes before the output position and may overlap the output.
Result<std::size_t> lzf_decompress(std::span<const std::uint8_t> in, std::span<std::uint8_t> out) {
  std::size_t ip = 0, op = 0;
  while (ip < in.size()) {
    const unsigned ctrl = in[ip++];
    if (ctrl < 32) {
      const std::size_t run = ctrl + 1u;
      if (ip + run > in.size()) return Error{"LZF: literal run past the end of the input", 0, static_cast<long>(ip)};
      if (op + run > out.size()) return Error{"LZF: output larger than declared", 0, static_cast<long>(ip)};
      std::memcpy(out.data() + op, in.data() + ip, run);
      ip += run;
      op += run;
      continue;
    }
    std::size_t len = ctrl >> 5;
    if (len == 7) {
      if (ip >= in.size()) return Error{"LZF: back-reference length past the end of the input", 0, static_cast<long>(ip)};
      len += in[ip++];
    }
    len += 2;
    if (ip >= in.size()) return Error{"LZF: back-reference offset past the end of the input", 0, static_cast<long>(ip)};
    const std::size_t back = ((static_cast<std::size_t>(ctrl & 0x1fu) << 8) | in[ip++]) + 1u;
    if (back > op) return Error{"LZF: back-reference before the start of the output", 0, static_cast<long>(ip)};
    if (op + len > out.size()) return Error{"LZF: output larger than declared", 0, static_cast<long>(ip)};
    // Byte by byte: the source may overlap the destination (run-length style repeats).
    std::size_t ref = op - back;
    for (std::size_t k = 0; k < len; ++k) out[op++] = out[ref++];
  }
  return op;
}

}  // namespace teamscan
