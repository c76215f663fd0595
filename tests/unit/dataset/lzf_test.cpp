// LZF decompressor on hand-encoded blocks (liblzf format: literal runs and back-references).
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "common/dataset/pcd.hpp"

namespace teamscan {
namespace {

std::string decompress(const std::vector<std::uint8_t>& in, std::size_t capacity) {
  std::vector<std::uint8_t> out(capacity);
  const auto n = lzf_decompress(in, out);
  if (!n) return std::string("ERROR: ") + n.error().what;
  return std::string(out.begin(), out.begin() + static_cast<long>(*n));
}

TEST(Lzf, LiteralRun) {
  // ctrl 0x02 = a literal run of 3 bytes.
  EXPECT_EQ(decompress({0x02, 'a', 'b', 'c'}, 16), "abc");
}

TEST(Lzf, EmptyInputGivesNothing) { EXPECT_EQ(decompress({}, 4), ""); }

TEST(Lzf, BackReferenceCopiesEarlierBytes) {
  // "abc" then ctrl 0x20 (length 1+2 = 3, offset high 0), offset low 2 -> start 3 bytes back.
  EXPECT_EQ(decompress({0x02, 'a', 'b', 'c', 0x20, 0x02}, 16), "abcabc");
}

TEST(Lzf, OverlappingBackReferenceRepeats) {
  // "a" then length 2+2 = 4 from 1 byte back: run-length expansion.
  EXPECT_EQ(decompress({0x00, 'a', 0x40, 0x00}, 16), "aaaaa");
}

TEST(Lzf, LongBackReferenceUsesExtraLengthByte) {
  // ctrl 0xE0: length field 7, so the next byte (5) adds: 7 + 5 + 2 = 14 copies.
  EXPECT_EQ(decompress({0x00, 'x', 0xE0, 0x05, 0x00}, 32), std::string(15, 'x'));
}

TEST(Lzf, HighOffsetBits) {
  // 300 literal bytes then a 3-byte copy from 300 back: offset 299 = 0x12B -> ctrl 0x21, low 0x2B.
  std::vector<std::uint8_t> in;
  std::string expect;
  for (int chunk = 0; chunk < 10; ++chunk) {
    in.push_back(29);  // 30 literal bytes
    for (int i = 0; i < 30; ++i) {
      const auto c = static_cast<char>('A' + (chunk * 30 + i) % 26);
      in.push_back(static_cast<std::uint8_t>(c));
      expect += c;
    }
  }
  in.push_back(0x21);
  in.push_back(0x2B);
  expect += expect.substr(0, 3);
  EXPECT_EQ(decompress(in, 400), expect);
}

TEST(Lzf, MalformedInputIsAnErrorNotACrash) {
  EXPECT_EQ(decompress({0x20, 0x00}, 16).rfind("ERROR", 0), 0u);            // reference before the start
  EXPECT_EQ(decompress({0x05, 'a'}, 16).rfind("ERROR", 0), 0u);              // literal run cut short
  EXPECT_EQ(decompress({0x00, 'a', 0x40}, 16).rfind("ERROR", 0), 0u);        // offset byte missing
  EXPECT_EQ(decompress({0x00, 'a', 0xE0}, 16).rfind("ERROR", 0), 0u);        // length byte missing
  EXPECT_EQ(decompress({0x02, 'a', 'b', 'c'}, 2).rfind("ERROR", 0), 0u);     // output too small
  EXPECT_EQ(decompress({0x00, 'a', 0x40, 0x00}, 3).rfind("ERROR", 0), 0u);   // copy past the output
}

}  // namespace
}  // namespace teamscan
