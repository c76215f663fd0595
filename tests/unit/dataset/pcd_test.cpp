// PCD parsing on hand-made files (ascii, binary, binary_compressed; types, counts, NaN, errors) and the
// exact bytes of the labelled and xyz writers (layout in docs/formats.md).
#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "common/dataset/pcd.hpp"
#include "tests/unit/dataset/test_util.hpp"

namespace teamscan {
namespace {

using test::bytes_of;

template <class T>
void append(std::vector<std::uint8_t>& out, T v) {
  std::uint8_t b[sizeof v];
  std::memcpy(b, &v, sizeof v);
  out.insert(out.end(), b, b + sizeof v);
}

// An LZF block of literal runs only (valid liblzf output, no compression).
std::vector<std::uint8_t> lzf_literal(const std::vector<std::uint8_t>& plain) {
  std::vector<std::uint8_t> out;
  for (std::size_t i = 0; i < plain.size(); i += 32) {
    const std::size_t n = std::min<std::size_t>(32, plain.size() - i);
    out.push_back(static_cast<std::uint8_t>(n - 1));
    out.insert(out.end(), plain.begin() + static_cast<long>(i), plain.begin() + static_cast<long>(i + n));
  }
  return out;
}

TEST(PcdAscii, ReadsFieldsCountsAndDropsNaN) {
  const std::string text =
      "# .PCD v0.7 - Point Cloud Data file format\nVERSION 0.7\nFIELDS x y z intensity hist\nSIZE 4 4 4 4 4\n"
      "TYPE F F F F F\nCOUNT 1 1 1 1 3\nWIDTH 3\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS 3\nDATA ascii\n"
      "1 2 3 10 7 8 9\nnan nan nan 11 0 0 0\n-1.5 0.25 4e2 12 5 5 5\n";
  const auto cloud = parse_pcd(bytes_of(text));
  ASSERT_TRUE(cloud.ok()) << cloud.error().what;
  ASSERT_EQ(cloud->size(), 2u);
  EXPECT_EQ(cloud->fields, (std::vector<std::string>{"x", "y", "z", "intensity", "hist"}));
  EXPECT_EQ(cloud->xyz, (std::vector<float>{1, 2, 3, -1.5f, 0.25f, 400}));
  ASSERT_EQ(cloud->field("intensity"), 3);
  EXPECT_EQ(cloud->field("nope"), -1);
  EXPECT_EQ(cloud->columns[3], (std::vector<double>{10, 12}));
  EXPECT_EQ(cloud->columns[4], (std::vector<double>{7, 5}));  // first element of a COUNT 3 field
  EXPECT_EQ(cloud->width, 3u);
  EXPECT_EQ(cloud->height, 1u);
}

TEST(PcdBinary, ReadsEveryTypeAndSize) {
  std::string header =
      "VERSION .7\nFIELDS x y z a b c d e\nSIZE 4 4 8 1 2 4 8 1\nTYPE F F F I U I U U\nWIDTH 2\nHEIGHT 1\nDATA binary\n";
  auto bytes = bytes_of(header);
  for (int i = 0; i < 2; ++i) {
    append(bytes, 1.5f + static_cast<float>(i));
    append(bytes, -2.0f);
    append(bytes, 1e-3);
    append(bytes, std::int8_t{-7});
    append(bytes, std::uint16_t{65535});
    append(bytes, std::int32_t{-100000});
    append(bytes, std::uint64_t{1} << 40);
    append(bytes, std::uint8_t{200});
  }
  const auto cloud = parse_pcd(bytes);
  ASSERT_TRUE(cloud.ok()) << cloud.error().what;
  ASSERT_EQ(cloud->size(), 2u);
  EXPECT_EQ(cloud->xyz[3], 2.5f);
  EXPECT_EQ(cloud->xyz[5], static_cast<float>(1e-3));
  EXPECT_EQ(cloud->columns[3][1], -7);
  EXPECT_EQ(cloud->columns[4][1], 65535);
  EXPECT_EQ(cloud->columns[5][1], -100000);
  EXPECT_EQ(cloud->columns[6][1], 1099511627776.0);
  EXPECT_EQ(cloud->columns[7][1], 200);
}

TEST(PcdBinaryCompressed, ReadsFieldMajorLzfBlockAndOrganisedNaN) {
  // 2x2 organised cloud, fields x y z (F4) and label (U1); point 2 is NaN. Field-major data.
  const float xs[4] = {1, 2, std::numeric_limits<float>::quiet_NaN(), 4};
  const float ys[4] = {10, 20, 30, 40};
  const float zs[4] = {-1, -2, -3, -4};
  const std::uint8_t labels[4] = {5, 6, 7, 8};
  std::vector<std::uint8_t> plain;
  for (float v : xs) append(plain, v);
  for (float v : ys) append(plain, v);
  for (float v : zs) append(plain, v);
  for (auto v : labels) append(plain, v);
  const auto block = lzf_literal(plain);
  auto bytes = bytes_of("VERSION 0.7\nFIELDS x y z label\nSIZE 4 4 4 1\nTYPE F F F U\nCOUNT 1 1 1 1\nWIDTH 2\nHEIGHT 2\n"
                        "VIEWPOINT 0 0 0 1 0 0 0\nPOINTS 4\nDATA binary_compressed\n");
  append(bytes, static_cast<std::uint32_t>(block.size()));
  append(bytes, static_cast<std::uint32_t>(plain.size()));
  bytes.insert(bytes.end(), block.begin(), block.end());
  const auto cloud = parse_pcd(bytes);
  ASSERT_TRUE(cloud.ok()) << cloud.error().what;
  ASSERT_EQ(cloud->size(), 3u);
  EXPECT_EQ(cloud->xyz, (std::vector<float>{1, 10, -1, 2, 20, -2, 4, 40, -4}));
  EXPECT_EQ(cloud->columns[3], (std::vector<double>{5, 6, 8}));
  EXPECT_EQ(cloud->width, 2u);
  EXPECT_EQ(cloud->height, 2u);
}

struct BadHeaderCase {
  const char* text;
  long line;  // expected detail (header line), or -1 for "any"
};

TEST(PcdErrors, MalformedHeadersNameTheLine) {
  const BadHeaderCase cases[] = {
      {"VERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nWIDTH 1\nHEIGHT 1\n", 6},                 // no DATA
      {"FIELDS x y z\nSIZE 4 4\nTYPE F F F\nWIDTH 1\nHEIGHT 1\nDATA ascii\n1 2 3\n", 6},               // SIZE short
      {"FIELDS x y z\nSIZE 4 4 4\nTYPE F F Q\nWIDTH 1\nHEIGHT 1\nDATA ascii\n1 2 3\n", 6},             // bad TYPE
      {"FIELDS x y z\nSIZE 4 4 2\nTYPE F F F\nWIDTH 1\nHEIGHT 1\nDATA ascii\n1 2 3\n", 6},             // F2
      {"FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nWIDTH 2\nHEIGHT 1\nPOINTS 3\nDATA ascii\n1 2 3\n", 7},   // W*H != POINTS
      {"FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nWIDTH two\nHEIGHT 1\nDATA ascii\n1 2 3\n", 4},           // WIDTH text
      {"FIELDS x y z\nBOGUS 1\nSIZE 4 4 4\n", 2},                                                        // unknown key
      {"FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nWIDTH 1\nHEIGHT 1\nDATA lzma\n", 6},                      // DATA kind
      {"SIZE 4 4 4\nTYPE F F F\nWIDTH 1\nHEIGHT 1\nDATA ascii\n1 2 3\n", 5},                            // no FIELDS
      {"FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 0 1\nWIDTH 1\nHEIGHT 1\nDATA ascii\n", 4},        // COUNT 0
      {"FIELDS a b c\nSIZE 4 4 4\nTYPE F F F\nWIDTH 1\nHEIGHT 1\nDATA ascii\n1 2 3\n", -1},            // no xyz
  };
  for (const auto& c : cases) {
    const auto cloud = parse_pcd(bytes_of(c.text));
    ASSERT_FALSE(cloud.ok()) << c.text;
    EXPECT_NE(std::string(cloud.error().what).find("PCD"), std::string::npos) << cloud.error().what;
    if (c.line >= 0) {
      EXPECT_EQ(cloud.error().detail, c.line) << c.text << " -> " << cloud.error().what;
    }
  }
}

TEST(PcdErrors, TruncatedAndMismatchedData) {
  const std::string head = "FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nWIDTH 2\nHEIGHT 1\n";
  // ascii: one line short; a line with a missing value; a non-number.
  EXPECT_FALSE(parse_pcd(bytes_of(head + "DATA ascii\n1 2 3\n")).ok());
  {
    const auto r = parse_pcd(bytes_of(head + "DATA ascii\n1 2 3\n1 2\n"));
    ASSERT_FALSE(r.ok());
    EXPECT_EQ(r.error().detail, 2);  // second data line
  }
  EXPECT_FALSE(parse_pcd(bytes_of(head + "DATA ascii\n1 2 3\n1 2 x\n")).ok());
  // binary: 23 of 24 bytes.
  auto bin = bytes_of(head + "DATA binary\n");
  bin.resize(bin.size() + 23, 0);
  const auto r = parse_pcd(bin);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(std::string(r.error().what).find("truncated"), std::string::npos);
  // binary_compressed: declared uncompressed size differs from POINTS x point size.
  std::vector<std::uint8_t> plain(24, 0);
  const auto block = lzf_literal(plain);
  auto comp = bytes_of(head + "DATA binary_compressed\n");
  append(comp, static_cast<std::uint32_t>(block.size()));
  append(comp, std::uint32_t{20});
  comp.insert(comp.end(), block.begin(), block.end());
  EXPECT_FALSE(parse_pcd(comp).ok());
  // binary_compressed: block cut short; a huge claimed size must fail without allocating it.
  auto cut = bytes_of(head + "DATA binary_compressed\n");
  append(cut, static_cast<std::uint32_t>(block.size()));
  append(cut, std::uint32_t{24});
  cut.insert(cut.end(), block.begin(), block.begin() + 5);
  EXPECT_FALSE(parse_pcd(cut).ok());
  auto huge = bytes_of("FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nWIDTH 300000000\nHEIGHT 1\nDATA binary_compressed\n");
  append(huge, std::uint32_t{2});
  append(huge, std::uint32_t{3600000000u});
  huge.push_back(0x00);
  huge.push_back(0x00);
  EXPECT_FALSE(parse_pcd(huge).ok());
  // POINTS x point size overflowing 64 bits.
  EXPECT_FALSE(parse_pcd(bytes_of("FIELDS x y z\nSIZE 8 8 8\nTYPE F F F\nWIDTH 18446744073709551615\nHEIGHT 1\nDATA binary\n")).ok());
}

LabelledPoint sample_point(int i) {
  LabelledPoint p;
  p.x = 1.25f * static_cast<float>(i) - 3.0f;
  p.y = -0.1f * static_cast<float>(i);
  p.z = 0.001f * static_cast<float>(i * i);
  p.robot = static_cast<std::uint8_t>(1 + i % 32);
  p.scan = 4294967295u - static_cast<std::uint32_t>(i);
  p.beam = static_cast<std::uint16_t>(400 - i);
  p.label = static_cast<PointClass>(i % 6);
  p.hit_robot = p.label == PointClass::robot ? 2 : 0;
  p.flags = static_cast<std::uint16_t>(0xFFFF >> (i % 16));
  p.tx = p.x + 0.005f;
  p.ty = p.y - 0.005f;
  p.tz = -p.z;
  return p;
}

TEST(PcdLabelled, ExactHeaderAndByteLayout) {
  LabelledPoint p;
  p.x = 1.0f; p.y = -2.0f; p.z = 0.5f;
  p.robot = 3; p.scan = 0x01020304u; p.beam = 0x0506; p.label = PointClass::robot; p.hit_robot = 7;
  p.flags = 0x0809; p.tx = 4.0f; p.ty = 8.0f; p.tz = -1.0f;
  const std::vector<LabelledPoint> points{p};
  const auto bytes = encode_labelled_pcd(points);
  const std::string header =
      "# .PCD v0.7 - Point Cloud Data file format\nVERSION 0.7\n"
      "FIELDS x y z robot scan beam label hit_robot flags tx ty tz\n"
      "SIZE 4 4 4 1 4 2 1 1 2 4 4 4\nTYPE F F F U U U U U U F F F\nCOUNT 1 1 1 1 1 1 1 1 1 1 1 1\n"
      "WIDTH 1\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS 1\nDATA binary\n";
  ASSERT_EQ(bytes.size(), header.size() + 35);
  EXPECT_EQ(std::string(bytes.begin(), bytes.begin() + static_cast<long>(header.size())), header);
  // IEEE-754 little-endian: 1.0f = 00 00 80 3F, -2.0f = 00 00 00 C0, 0.5f = 00 00 00 3F,
  // 4.0f = 00 00 80 40, 8.0f = 00 00 00 41, -1.0f = 00 00 80 BF.
  const std::vector<std::uint8_t> expect = {0x00, 0x00, 0x80, 0x3F, 0x00, 0x00, 0x00, 0xC0, 0x00, 0x00, 0x00, 0x3F,
                                            0x03, 0x04, 0x03, 0x02, 0x01, 0x06, 0x05, 0x05, 0x07, 0x09, 0x08,
                                            0x00, 0x00, 0x80, 0x40, 0x00, 0x00, 0x00, 0x41, 0x00, 0x00, 0x80, 0xBF};
  EXPECT_EQ(std::vector<std::uint8_t>(bytes.begin() + static_cast<long>(header.size()), bytes.end()), expect);
}

TEST(PcdLabelled, RoundTripIsExactAndDeterministic) {
  std::vector<LabelledPoint> points;
  for (int i = 0; i < 1000; ++i) points.push_back(sample_point(i));
  const auto dir = test::temp_dir();
  const auto path = (dir / "points.pcd").string();
  ASSERT_TRUE(write_labelled_pcd(path, points).ok());
  EXPECT_EQ(test::file_bytes(path), encode_labelled_pcd(points));
  EXPECT_EQ(encode_labelled_pcd(points), encode_labelled_pcd(points));
  const auto back = read_labelled_pcd(path);
  ASSERT_TRUE(back.ok()) << back.error().what;
  ASSERT_EQ(back->size(), points.size());
  for (std::size_t i = 0; i < points.size(); ++i) {
    const auto& a = points[i];
    const auto& b = (*back)[i];
    ASSERT_EQ(std::memcmp(&a.x, &b.x, 4), 0);
    EXPECT_EQ(a.y, b.y); EXPECT_EQ(a.z, b.z); EXPECT_EQ(a.robot, b.robot); EXPECT_EQ(a.scan, b.scan);
    EXPECT_EQ(a.beam, b.beam); EXPECT_EQ(a.label, b.label); EXPECT_EQ(a.hit_robot, b.hit_robot);
    EXPECT_EQ(a.flags, b.flags); EXPECT_EQ(a.tx, b.tx); EXPECT_EQ(a.ty, b.ty); EXPECT_EQ(a.tz, b.tz);
  }
  // The generic reader sees the same cloud with every field.
  const auto generic = read_pcd(path);
  ASSERT_TRUE(generic.ok());
  ASSERT_EQ(generic->size(), points.size());
  EXPECT_EQ(generic->columns[static_cast<std::size_t>(generic->field("scan"))][5], points[5].scan);
  EXPECT_EQ(generic->columns[static_cast<std::size_t>(generic->field("flags"))][7], points[7].flags);
}

TEST(PcdLabelled, EmptyCloud) {
  const auto bytes = encode_labelled_pcd({});
  const auto back = parse_labelled_pcd(bytes);
  ASSERT_TRUE(back.ok()) << back.error().what;
  EXPECT_TRUE(back->empty());
}

TEST(PcdLabelled, OtherLayoutsGoThroughTheGenericReader) {
  // The same twelve fields in ascii, different order and types.
  const std::string text =
      "FIELDS label x y z robot scan beam hit_robot flags tx ty tz\nSIZE 4 8 8 8 4 8 4 4 4 4 4 4\n"
      "TYPE I F F F I U I I I F F F\nWIDTH 1\nHEIGHT 1\nDATA ascii\n5 1 2 3 2 9 100 1 8 1.5 2.5 3.5\n";
  const auto back = parse_labelled_pcd(bytes_of(text));
  ASSERT_TRUE(back.ok()) << back.error().what;
  ASSERT_EQ(back->size(), 1u);
  EXPECT_EQ((*back)[0].label, PointClass::robot);
  EXPECT_EQ((*back)[0].robot, 2);
  EXPECT_EQ((*back)[0].scan, 9u);
  EXPECT_EQ((*back)[0].beam, 100);
  EXPECT_EQ((*back)[0].hit_robot, 1);
  EXPECT_EQ((*back)[0].flags, 8);
  EXPECT_EQ((*back)[0].tz, 3.5f);
  // Out-of-range label or a negative robot id: an error, not a wrapped value.
  EXPECT_FALSE(parse_labelled_pcd(bytes_of(
      "FIELDS label x y z robot scan beam hit_robot flags tx ty tz\nSIZE 4 8 8 8 4 8 4 4 4 4 4 4\n"
      "TYPE I F F F I U I I I F F F\nWIDTH 1\nHEIGHT 1\nDATA ascii\n9 1 2 3 2 9 100 1 8 1.5 2.5 3.5\n")).ok());
  EXPECT_FALSE(parse_labelled_pcd(bytes_of(
      "FIELDS label x y z robot scan beam hit_robot flags tx ty tz\nSIZE 4 8 8 8 4 8 4 4 4 4 4 4\n"
      "TYPE I F F F I U I I I F F F\nWIDTH 1\nHEIGHT 1\nDATA ascii\n1 1 2 3 -2 9 100 1 8 1.5 2.5 3.5\n")).ok());
  // A PCD without the labelled fields.
  EXPECT_FALSE(parse_labelled_pcd(bytes_of("FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nWIDTH 1\nHEIGHT 1\nDATA ascii\n1 2 3\n")).ok());
}

TEST(PcdXyz, ExactBytesAndRoundTrip) {
  const std::vector<float> xyz = {1, 2, 3, -0.5f, 0.25f, 100};
  const auto bytes = encode_xyz_pcd(xyz);
  const std::string header =
      "# .PCD v0.7 - Point Cloud Data file format\nVERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\n"
      "WIDTH 2\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS 2\nDATA binary\n";
  ASSERT_EQ(bytes.size(), header.size() + 24);
  EXPECT_EQ(std::string(bytes.begin(), bytes.begin() + static_cast<long>(header.size())), header);
  const auto cloud = parse_pcd(bytes);
  ASSERT_TRUE(cloud.ok());
  EXPECT_EQ(cloud->xyz, xyz);
}

}  // namespace
}  // namespace teamscan

namespace teamscan {
namespace {

PcdCloud general_cloud() {
  PcdCloud c;
  c.fields = {"x", "y", "z", "keep", "ring", "time", "intensity"};
  c.columns = {{1.5, -2.25, 0.1}, {0, 1, 2}, {-1, 0.5, 1e-3}, {1, 0, 1}, {-3, 0, 32767}, {0.1, 1e-12, 123456.789}, {7, 8, 9}};
  const double vp[7] = {1.0, 2.0, 0.5, 0.70710678118654757, 0.0, 0.0, 0.70710678118654746};
  std::copy(std::begin(vp), std::end(vp), std::begin(c.viewpoint));
  return c;
}
const std::vector<PcdField> kGeneralLayout = {{"x", 4, 'F', 1}, {"y", 4, 'F', 1}, {"z", 4, 'F', 1}, {"keep", 1, 'U', 1},
                                              {"ring", 2, 'I', 1}, {"time", 8, 'F', 1}, {"intensity", 4, 'U', 1}};

TEST(PcdGeneralWriter, BinaryAndAsciiRoundTripWithTypesAndViewpoint) {
  const PcdCloud c = general_cloud();
  for (const PcdData kind : {PcdData::binary, PcdData::ascii}) {
    const auto bytes = encode_pcd(c, kGeneralLayout, kind);
    ASSERT_TRUE(bytes.ok()) << bytes.error().what;
    const auto back = parse_pcd(*bytes);
    ASSERT_TRUE(back.ok()) << back.error().what;
    EXPECT_EQ(back->fields, c.fields);
    ASSERT_EQ(back->size(), 3u);
    for (std::size_t f = 0; f < c.fields.size(); ++f)
      for (std::size_t i = 0; i < 3; ++i) {
        // F 4 fields hold the float nearest the double; the others exactly.
        const double expect = kGeneralLayout[f].type == 'F' && kGeneralLayout[f].size == 4
                                  ? static_cast<double>(static_cast<float>(c.columns[f][i]))
                                  : c.columns[f][i];
        EXPECT_EQ(back->columns[f][i], expect) << c.fields[f] << " " << i;
      }
    for (int k = 0; k < 7; ++k) EXPECT_EQ(back->viewpoint[k], c.viewpoint[k]);
  }
  // The binary header, exactly.
  const auto bytes = encode_pcd(c, kGeneralLayout);
  const std::string text(bytes->begin(), bytes->end());
  EXPECT_EQ(text.substr(0, text.find("DATA binary\n") + 12),
            "# .PCD v0.7 - Point Cloud Data file format\nVERSION 0.7\nFIELDS x y z keep ring time intensity\n"
            "SIZE 4 4 4 1 2 8 4\nTYPE F F F U I F U\nCOUNT 1 1 1 1 1 1 1\nWIDTH 3\nHEIGHT 1\n"
            "VIEWPOINT 1 2 0.5 0.70710678118654757 0 0 0.70710678118654746\nPOINTS 3\nDATA binary\n");
  EXPECT_EQ(bytes->size(), text.find("DATA binary\n") + 12 + 3 * (12 + 1 + 2 + 8 + 4));
}

TEST(PcdGeneralWriter, RefusesWhatItCannotWrite) {
  PcdCloud c = general_cloud();
  auto layout = kGeneralLayout;
  c.columns[3][1] = 256;  // keep is U 1
  EXPECT_FALSE(encode_pcd(c, layout).ok());
  c = general_cloud();
  c.columns[4][0] = -32769;  // ring is I 2
  EXPECT_FALSE(encode_pcd(c, layout).ok());
  c = general_cloud();
  layout[6] = {"intensity", 8, 'U', 1};
  c.columns[6][0] = 18446744073709551616.0;  // 2^64 does not fit U 8
  EXPECT_FALSE(encode_pcd(c, layout).ok());
  c = general_cloud();
  c.columns[1].pop_back();
  EXPECT_FALSE(encode_pcd(c, kGeneralLayout).ok());
  c = general_cloud();
  layout = kGeneralLayout;
  layout[0].type = 'Q';
  EXPECT_FALSE(encode_pcd(c, layout).ok());
  EXPECT_FALSE(encode_pcd(c, kGeneralLayout, PcdData::binary_compressed).ok());
  PcdCloud no_xyz;
  no_xyz.fields = {"a"};
  no_xyz.columns = {{1}};
  EXPECT_FALSE(encode_pcd(no_xyz, {}).ok());
  // Default layout: every field F 4.
  const auto plain = encode_pcd(general_cloud(), {});
  ASSERT_TRUE(plain.ok());
  EXPECT_NE(std::string(plain->begin(), plain->end()).find("TYPE F F F F F F F\n"), std::string::npos);
}

}  // namespace
}  // namespace teamscan
