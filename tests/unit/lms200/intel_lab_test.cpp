// Real data: every scan of the Intel Research Lab log (tests/data/real/intel-lab-every5th.clf, 180
// beams in metres, SOURCES.md) encoded as 0xB0 telegrams in cm units with the encoder the emulator
// uses, parsed as one byte stream and decoded by the driver: every range equal after cm rounding.
//
// 81.83 m in this log is "no return" (SOURCES.md). In cm units it is 8183 = 0x1FF7, exactly the LMS
// reserved code "value > maximum" of §2.7, so it maps to that code on encoding and decodes as an
// invalid beam with reason over_range (ranges_mm keeps 81830, the code × 10 mm).
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "drivers/lms200/codec.hpp"
#include "drivers/lms200/parser.hpp"
#include "drivers/lms200/scan.hpp"
#include "tests/support/real_data.hpp"

namespace teamscan::lms200 {
namespace {

std::vector<std::vector<double>> load_intel_scans() {
  const std::string path = teamscan::test::real_data_path("intel-lab-every5th.clf");
  std::ifstream in{path};
  std::vector<std::vector<double>> scans;
  std::string line;
  while (std::getline(in, line)) {
    if (line.rfind("FLASER ", 0) != 0) continue;
    std::istringstream fields{line.substr(7)};
    std::size_t n = 0;
    fields >> n;
    std::vector<double> r(n);
    for (auto& x : r) fields >> x;
    if (fields) scans.push_back(std::move(r));
  }
  return scans;
}

TEST(IntelLabRealData, EveryScanRoundTripsThroughTelegramsInCentimetres) {
  const auto scans = load_intel_scans();
  ASSERT_EQ(scans.size(), 2726u) << "SOURCES.md: 2726 scans";

  // Encode every scan; concatenate into one stream as the scanner would send it.
  std::vector<std::uint8_t> stream;
  std::array<std::uint16_t, kMaxBeams> words{};
  std::array<std::uint8_t, kMaxLmsTelegram> t{};
  std::size_t no_return = 0;
  for (const auto& s : scans) {
    ASSERT_EQ(s.size(), 180u);
    for (std::size_t i = 0; i < s.size(); ++i) {
      const auto mm = static_cast<std::uint32_t>(std::lround(s[i] * 1000.0));
      words[i] = encode_value_word(mm, 0, BeamInvalid::none, Unit::cm, MeasuringMode::m8_fields_dazzle);
    }
    const std::size_t n = build_scan_reply(t, CountWord{180, 0, false, 0}.encode(), std::span{words}.first(180),
                                           std::nullopt);
    ASSERT_EQ(n, 6u + 1 + 2 + 360 + 1);
    stream.insert(stream.end(), t.begin(), t.begin() + static_cast<std::ptrdiff_t>(n));
  }

  LmsParser parser;
  std::span<const std::uint8_t> in{stream};
  std::size_t scan_index = 0;
  std::size_t mismatches = 0;
  ScanTelegram decoded;
  while (!in.empty()) {
    in = in.subspan(parser.feed(in));
    LmsEvent e;
    while (parser.next(e)) {
      ASSERT_EQ(e.kind, LmsEvent::Kind::telegram);
      ASSERT_LT(scan_index, scans.size());
      ASSERT_TRUE(decode_scan(e.bytes, MeasuringMode::m8_fields_dazzle, decoded).ok());
      ASSERT_EQ(decoded.count, 180);
      ASSERT_EQ(decoded.unit, Unit::cm);
      const auto& truth = scans[scan_index++];
      for (std::size_t i = 0; i < 180; ++i) {
        const long cm = std::lround(truth[i] * 100.0);
        if (cm >= 8183) {  // no return -> over-range code
          ++no_return;
          if (decoded.invalid[i] != BeamInvalid::over_range || decoded.ranges_mm[i] != 81830u) ++mismatches;
        } else if (decoded.invalid[i] != BeamInvalid::none || decoded.ranges_mm[i] != static_cast<std::uint32_t>(cm * 10)) {
          ++mismatches;
        }
        if (decoded.flags[i] != 0) ++mismatches;
      }
    }
  }
  EXPECT_EQ(scan_index, scans.size());
  EXPECT_EQ(mismatches, 0u);
  EXPECT_GT(no_return, 0u);
  EXPECT_EQ(parser.statistics().telegrams, scans.size());
  EXPECT_EQ(parser.statistics().discarded_bytes, 0u);
  EXPECT_EQ(parser.statistics().bad_crc, 0u);
}

TEST(IntelLabRealData, RangesAreWithinTheDocumentedInterval) {
  const auto scans = load_intel_scans();
  ASSERT_FALSE(scans.empty());
  double lo = 1e9;
  double hi = 0.0;
  for (const auto& s : scans)
    for (double r : s) {
      lo = std::min(lo, r);
      hi = std::max(hi, r);
    }
  // SOURCES.md: 0.21–81.83 m; 81.83 m is the cm-mode maximum the over-range code stands for.
  EXPECT_NEAR(lo, 0.21, 1e-9);
  EXPECT_NEAR(hi, 81.83, 1e-9);
  EXPECT_EQ(reserved_code(BeamInvalid::over_range, 13), 8183);
}

}  // namespace
}  // namespace teamscan::lms200
