// scans.bin format: exact bytes of a record, CRC check values, round trip, and bad input (corruption,
// truncation, garbage between records) counted and resynchronised.
#include <gtest/gtest.h>

#include <cstring>
#include <vector>

#include "common/point_flags.hpp"
#include "groundstation/station/scan_record.hpp"

namespace teamscan::station {
namespace {

TEST(Crc32, StandardCheckValue) {
  // CRC-32/ISO-HDLC check value of "123456789" (the catalogue value every CRC-32 implementation meets).
  const char* s = "123456789";
  EXPECT_EQ(crc32_ieee(std::span<const std::uint8_t>(reinterpret_cast<const std::uint8_t*>(s), 9)), 0xCBF43926u);
  EXPECT_EQ(crc32_ieee(std::span<const std::uint8_t>()), 0u);
}

TEST(ScanRecord, FileHeaderBytes) {
  std::uint8_t h[kScanFileHeaderBytes];
  encode_scan_file_header(h);
  const std::uint8_t expected[16] = {'T', 'S', 'S', 'C', 'A', 'N', 'S', '1', 2, 0, 0, 0, 16, 0, 0, 0};
  EXPECT_EQ(std::memcmp(h, expected, 16), 0);
  EXPECT_EQ(scan_file_version(h), 2u);
}

TEST(ScanRecord, ExactBytesOfAOnePointRecord) {
  static ScanPoints s;
  Receipt receipt;
  receipt.recv_realtime_ns = 0x0102030405060708;
  receipt.recv_monotonic_ns = -2;
  s.robot_id = 3;
  s.seq = 0x11223344;
  s.stamp = Time::from_ns(1);
  s.origin_x_mm = -1;
  s.origin_y_mm = 256;
  s.origin_z_mm = 0;
  s.applied = OdomCorrection{-2, 1000, -1'570'796, 0x0A0B0C0D};
  s.count = 1;
  s.points[0] = ScanPoint{-1000, 1000, 7, 400, 5};
  std::uint8_t buf[kScanRecordMaxBytes];
  const std::size_t n = encode_scan_record(s, receipt, buf);
  ASSERT_EQ(n, 8u + 64u + 16u + 4u);
  const std::uint8_t expected[88] = {
      0x54, 0x43, 0x53, 0x52,  80, 0, 0, 0,                        // magic "TCSR", body 64 + 16
      0x08, 0x07, 0x06, 0x05, 0x04, 0x03, 0x02, 0x01,              // recv realtime
      0xFE, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF,              // recv monotonic -2
      3, 0, 0, 0,  0x44, 0x33, 0x22, 0x11,                        // robot, seq
      1, 0, 0, 0, 0, 0, 0, 0,                                      // stamp
      0xFF, 0xFF, 0xFF, 0xFF,  0, 1, 0, 0,  0, 0, 0, 0,            // origin -1, 256, 0
      0xFE, 0xFF, 0xFF, 0xFF,  0xE8, 0x03, 0, 0,                   // applied correction -2, 1000 mm
      0x14, 0x08, 0xE8, 0xFF,  0x0D, 0x0C, 0x0B, 0x0A,             // -1 570 796 µrad, corr_seq
      1, 0,  0, 0,                                                 // count, rejected (0: accepted)
      0x18, 0xFC, 0xFF, 0xFF,  0xE8, 0x03, 0, 0,  7, 0, 0, 0,      // -1000, 1000, 7
      0x90, 0x01,  5, 0};                                          // beam 400, flags 5
  ASSERT_EQ(std::memcmp(buf, expected, 88), 0);
  const std::uint32_t crc = crc32_ieee(std::span<const std::uint8_t>(buf, 88));
  EXPECT_EQ(buf[88], crc & 0xFF);
  EXPECT_EQ(buf[91], crc >> 24);
  static ScanPoints back;
  Receipt back_receipt;
  ScanDecodeStats st;
  ASSERT_EQ(decode_scan_record(std::span<const std::uint8_t>(buf, n), back, back_receipt, st), static_cast<long>(n));
  EXPECT_EQ(back.applied.x_mm, -2);
  EXPECT_EQ(back.applied.y_mm, 1000);
  EXPECT_EQ(back.applied.yaw_urad, -1'570'796);
  EXPECT_EQ(back.applied.seq, 0x0A0B0C0Du);
}

// A version 1 file (before the correction fields, body 48 + 16·count) is still read: no correction.
TEST(ScanRecord, VersionOneFilesAreReadWithoutACorrection) {
  const std::uint8_t record[] = {
      0x54, 0x43, 0x53, 0x52,  64, 0, 0, 0,                        // magic "TCSR", body 48 + 16
      0x08, 0x07, 0x06, 0x05, 0x04, 0x03, 0x02, 0x01,              // recv realtime
      0xFE, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF,              // recv monotonic -2
      3, 0, 0, 0,  0x44, 0x33, 0x22, 0x11,                        // robot, seq
      1, 0, 0, 0, 0, 0, 0, 0,                                      // stamp
      0xFF, 0xFF, 0xFF, 0xFF,  0, 1, 0, 0,  0, 0, 0, 0,            // origin -1, 256, 0
      1, 0,  0, 0,                                                 // count, rejected (0: accepted)
      0x18, 0xFC, 0xFF, 0xFF,  0xE8, 0x03, 0, 0,  7, 0, 0, 0,      // -1000, 1000, 7
      0x90, 0x01,  5, 0};                                          // beam 400, flags 5
  std::vector<std::uint8_t> f = {'T', 'S', 'S', 'C', 'A', 'N', 'S', '1', 1, 0, 0, 0, 16, 0, 0, 0};
  f.insert(f.end(), std::begin(record), std::end(record));
  const std::uint32_t crc = crc32_ieee(std::span<const std::uint8_t>(record, sizeof record));
  for (int i = 0; i < 4; ++i) f.push_back(static_cast<std::uint8_t>(crc >> (8 * i)));
  int n = 0;
  const ScanDecodeStats st = decode_scan_file(std::span<const std::uint8_t>(f), [&](const ScanPoints& s, const Receipt&) {
    ++n;
    EXPECT_EQ(s.seq, 0x11223344u);
    EXPECT_EQ(s.origin_y_mm, 256);
    EXPECT_TRUE(s.applied.none());
    ASSERT_EQ(s.count, 1);
    EXPECT_EQ(s.points[0].y_mm, 1000);
    EXPECT_EQ(s.points[0].beam, 400);
  });
  EXPECT_EQ(n, 1);
  EXPECT_EQ(st.records, 1u);
  EXPECT_FALSE(st.bad_header);
  f[8] = 3;  // an unknown version
  EXPECT_TRUE(decode_scan_file(std::span<const std::uint8_t>(f), [](const ScanPoints&, const Receipt&) {}).bad_header);
}

// The station takes an accepted scan back to the odometry-map frame: the inverse of the correction the
// robot applied, on the origin and the points (a beam without an echo sits at the laser's centre and
// moves with it); points without a pose (coordinates 0) stay.
TEST(ScanRecord, UndoingTheAppliedCorrectionGivesTheOdometryMapFrame) {
  static ScanPoints s;
  s.applied = OdomCorrection{100, 200, 1'570'796, 3};  // (0.1 m, 0.2 m, +90°)
  s.origin_x_mm = 100;  // odometry-map (1000, 0) corrected
  s.origin_y_mm = 1200;
  s.origin_z_mm = 300;
  s.count = 4;
  s.points[0] = ScanPoint{-2900, 1200, 310, 90, 0};   // odometry-map (1000, 3000)
  s.points[1] = ScanPoint{0, 0, 0, 91, kPointNoPose};
  s.points[2] = ScanPoint{-2900, 1200, 310, 92, kPointDirectionFiltered};
  s.points[3] = ScanPoint{100, 1200, 300, 93, kPointInvalid};  // no echo: at the laser's centre
  undo_applied_correction(s);
  EXPECT_EQ(s.origin_x_mm, 1000);
  EXPECT_EQ(s.origin_y_mm, 0);
  EXPECT_EQ(s.origin_z_mm, 300);
  EXPECT_EQ(s.points[0].x_mm, 1000);
  EXPECT_EQ(s.points[0].y_mm, 3000);
  EXPECT_EQ(s.points[0].z_mm, 310);
  EXPECT_EQ(s.points[1].x_mm, 0);
  EXPECT_EQ(s.points[1].y_mm, 0);
  EXPECT_EQ(s.points[2].x_mm, 1000);
  EXPECT_EQ(s.points[2].flags, kPointDirectionFiltered);
  EXPECT_EQ(s.points[3].x_mm, 1000);
  EXPECT_EQ(s.points[3].y_mm, 0);
  EXPECT_EQ(s.applied.seq, 3u);  // the record keeps which one was applied
  // None applied: nothing moves.
  static ScanPoints n;
  n.count = 1;
  n.points[0] = ScanPoint{-2900, 1200, 310, 90, 0};
  undo_applied_correction(n);
  EXPECT_EQ(n.points[0].x_mm, -2900);
}

std::vector<std::uint8_t> file_with(const std::vector<ScanPoints*>& scans) {
  std::vector<std::uint8_t> f(kScanFileHeaderBytes);
  std::uint8_t h[kScanFileHeaderBytes];
  encode_scan_file_header(h);
  std::memcpy(f.data(), h, sizeof h);
  std::uint8_t buf[kScanRecordMaxBytes];
  for (const ScanPoints* s : scans) {
    const std::size_t n = encode_scan_record(*s, Receipt{}, buf);
    f.insert(f.end(), buf, buf + n);
  }
  return f;
}

TEST(ScanRecord, RoundTripOfZeroOneAndFullScans) {
  static ScanPoints a, b, c;
  a.robot_id = 1; a.seq = 1; a.count = 0;
  b.robot_id = 2; b.seq = 2; b.count = 1; b.points[0] = ScanPoint{1, 2, 3, 4, 5};
  c.robot_id = 32; c.seq = 3; c.count = kMaxBeams;
  for (std::uint16_t i = 0; i < kMaxBeams; ++i) c.points[i] = ScanPoint{i, -i, i * 2, i, static_cast<std::uint16_t>(i & 15)};
  const auto f = file_with({&a, &b, &c});
  std::vector<std::pair<std::uint32_t, std::uint16_t>> got;
  std::int32_t last_z = 0;
  const ScanDecodeStats st = decode_scan_file(std::span<const std::uint8_t>(f), [&](const ScanPoints& s, const Receipt&) {
    got.emplace_back(s.seq, s.count);
    if (s.count == kMaxBeams) last_z = s.points[400].z_mm;
  });
  EXPECT_EQ(st.records, 3u);
  EXPECT_EQ(st.bad_crc, 0u);
  EXPECT_FALSE(st.truncated_tail);
  ASSERT_EQ(got.size(), 3u);
  EXPECT_EQ(got[0], std::make_pair(1u, std::uint16_t{0}));
  EXPECT_EQ(got[1], std::make_pair(2u, std::uint16_t{1}));
  EXPECT_EQ(got[2], std::make_pair(3u, static_cast<std::uint16_t>(kMaxBeams)));
  EXPECT_EQ(last_z, 800);
}

// A scan the station refused at receipt is stored raw with its reason (sample_validation.hpp), and a
// count above the record's capacity keeps every point the sample could carry.
TEST(ScanRecord, RefusedScanKeepsItsReasonAndItsPoints) {
  static ScanPoints s, back;
  Receipt receipt, back_receipt;
  s.robot_id = 999999;
  s.seq = 5;
  s.count = 65535;
  receipt.rejected = 2;
  for (std::uint16_t i = 0; i < kMaxBeams; ++i) s.points[i] = ScanPoint{i, 0, 0, i, 0};
  std::uint8_t buf[kScanRecordMaxBytes];
  const std::size_t n = encode_scan_record(s, receipt, buf);
  ASSERT_EQ(n, kScanRecordMaxBytes);
  EXPECT_EQ(buf[8 + 62], 2);  // the rejected field after count
  ScanDecodeStats st;
  ASSERT_EQ(decode_scan_record(std::span<const std::uint8_t>(buf, n), back, back_receipt, st), static_cast<long>(n));
  EXPECT_EQ(back.robot_id, 999999u);
  EXPECT_EQ(back_receipt.rejected, 2);
  EXPECT_EQ(back.count, kMaxBeams);
  EXPECT_EQ(back.points[400].x_mm, 400);
}

TEST(ScanRecord, CorruptRecordIsSkippedAndTheNextOneFound) {
  static ScanPoints a, b, c;
  a.seq = 1; a.count = 3;
  b.seq = 2; b.count = 3;
  c.seq = 3; c.count = 3;
  auto f = file_with({&a, &b, &c});
  const std::size_t rec = kScanRecordFixedBytes + 3 * kScanPointBytes;
  f[kScanFileHeaderBytes + rec + 30] ^= 0x40;  // flip a bit inside record 2
  std::vector<std::uint32_t> seqs;
  const ScanDecodeStats st = decode_scan_file(std::span<const std::uint8_t>(f), [&](const ScanPoints& s, const Receipt&) { seqs.push_back(s.seq); });
  EXPECT_EQ(seqs, (std::vector<std::uint32_t>{1, 3}));
  EXPECT_EQ(st.bad_crc, 1u);
  EXPECT_GT(st.bytes_skipped, 0u);
}

TEST(ScanRecord, TruncatedTailAndGarbageAndBadHeader) {
  static ScanPoints a, b;
  a.seq = 1; a.count = 2;
  b.seq = 2; b.count = 2;
  auto f = file_with({&a, &b});
  f.insert(f.begin() + kScanFileHeaderBytes, {0xDE, 0xAD, 0xBE, 0xEF, 0x54});  // garbage before record 1
  f.resize(f.size() - 7);                                                     // torn last record
  std::vector<std::uint32_t> seqs;
  ScanDecodeStats st = decode_scan_file(std::span<const std::uint8_t>(f), [&](const ScanPoints& s, const Receipt&) { seqs.push_back(s.seq); });
  EXPECT_EQ(seqs, (std::vector<std::uint32_t>{1}));
  EXPECT_TRUE(st.truncated_tail);
  EXPECT_EQ(st.bytes_skipped, 5u);

  f[0] = 'X';
  st = decode_scan_file(std::span<const std::uint8_t>(f), [&](const ScanPoints&, const Receipt&) { ADD_FAILURE(); });
  EXPECT_TRUE(st.bad_header);
}

TEST(ScanRecord, LengthAboveCapacityIsRejected) {
  static ScanPoints a;
  a.count = 1;
  auto f = file_with({&a});
  // body length claiming 402 points
  const std::uint32_t body = 64 + 402 * 16;
  std::memcpy(&f[kScanFileHeaderBytes + 4], &body, 4);
  const ScanDecodeStats st = decode_scan_file(std::span<const std::uint8_t>(f), [&](const ScanPoints&, const Receipt&) { ADD_FAILURE(); });
  EXPECT_EQ(st.records, 0u);
  EXPECT_GE(st.bad_length, 1u);
}

}  // namespace
}  // namespace teamscan::station
