// Interoperability with PCL's own reader and writer (pcl-tools): our binary points.pcd read by PCL and
// written back as ascii, binary and binary_compressed must hold exactly our values. Skipped only if
// pcl_convert_pcd_ascii_binary is not installed (CI installs pcl-tools).
#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "common/dataset/pcd.hpp"
#include "tests/support/real_data.hpp"
#include "tests/unit/dataset/test_util.hpp"

namespace teamscan {
namespace {

bool have_pcl_tools() { return std::system("command -v pcl_convert_pcd_ascii_binary >/dev/null 2>&1") == 0; }

int pcl_convert(const std::string& in, const std::string& out, int mode) {
  const std::string cmd = "pcl_convert_pcd_ascii_binary '" + in + "' '" + out + "' " + std::to_string(mode) + " >/dev/null 2>&1";
  return std::system(cmd.c_str());
}

std::vector<LabelledPoint> cloud_to_save() {
  std::vector<LabelledPoint> pts;
  for (int i = 0; i < 257; ++i) {
    LabelledPoint p;
    p.x = static_cast<float>(std::sin(i * 0.37) * 4.5);
    p.y = static_cast<float>(std::cos(i * 0.11) * -3.25);
    p.z = static_cast<float>(i) * 0.0123f;
    p.robot = static_cast<std::uint8_t>(1 + i % 3);
    p.scan = static_cast<std::uint32_t>(i) * 16777259u;
    p.beam = static_cast<std::uint16_t>(i * 251);
    p.label = static_cast<PointClass>(i % 6);
    p.hit_robot = p.label == PointClass::robot ? static_cast<std::uint8_t>(1 + (i + 1) % 3) : 0;
    p.flags = static_cast<std::uint16_t>(i * 97);
    p.tx = p.x - 0.003f;
    p.ty = p.y + 0.002f;
    p.tz = p.z * 0.5f;
    pts.push_back(p);
  }
  return pts;
}

void expect_same(const std::vector<LabelledPoint>& a, const std::vector<LabelledPoint>& b, float tol) {
  ASSERT_EQ(a.size(), b.size());
  for (std::size_t i = 0; i < a.size(); ++i) {
    EXPECT_NEAR(a[i].x, b[i].x, tol * (1 + std::fabs(a[i].x))) << i;
    EXPECT_NEAR(a[i].y, b[i].y, tol * (1 + std::fabs(a[i].y))) << i;
    EXPECT_NEAR(a[i].z, b[i].z, tol * (1 + std::fabs(a[i].z))) << i;
    EXPECT_EQ(a[i].robot, b[i].robot) << i;
    EXPECT_EQ(a[i].scan, b[i].scan) << i;
    EXPECT_EQ(a[i].beam, b[i].beam) << i;
    EXPECT_EQ(a[i].label, b[i].label) << i;
    EXPECT_EQ(a[i].hit_robot, b[i].hit_robot) << i;
    EXPECT_EQ(a[i].flags, b[i].flags) << i;
    EXPECT_NEAR(a[i].tx, b[i].tx, tol * (1 + std::fabs(a[i].tx))) << i;
    EXPECT_NEAR(a[i].tz, b[i].tz, tol * (1 + std::fabs(a[i].tz))) << i;
  }
}

TEST(PcdPcl, PclReadsOurBinaryAndWritesItBackAsAscii) {
  if (!have_pcl_tools()) GTEST_SKIP() << "pcl_convert_pcd_ascii_binary not installed (apt-get install pcl-tools)";
  const auto dir = test::temp_dir();
  const auto ours = (dir / "ours.pcd").string();
  const auto pts = cloud_to_save();
  ASSERT_TRUE(write_labelled_pcd(ours, pts).ok());
  ASSERT_EQ(pcl_convert(ours, (dir / "ascii.pcd").string(), 0), 0);

  // Parse PCL's ascii with a stream, independently of our reader: header, then one line per point.
  std::ifstream in(dir / "ascii.pcd");
  std::string line;
  std::string fields;
  while (std::getline(in, line)) {
    if (line.rfind("FIELDS", 0) == 0) fields = line;
    if (line.rfind("DATA", 0) == 0) {
      EXPECT_EQ(line, "DATA ascii");
      break;
    }
  }
  EXPECT_EQ(fields, "FIELDS x y z robot scan beam label hit_robot flags tx ty tz");
  std::vector<LabelledPoint> back;
  while (std::getline(in, line)) {
    if (line.empty()) continue;
    std::istringstream s(line);
    LabelledPoint p;
    unsigned robot = 0, label = 0, hit = 0, beam = 0, flags = 0;
    s >> p.x >> p.y >> p.z >> robot >> p.scan >> beam >> label >> hit >> flags >> p.tx >> p.ty >> p.tz;
    ASSERT_FALSE(s.fail()) << line;
    p.robot = static_cast<std::uint8_t>(robot);
    p.beam = static_cast<std::uint16_t>(beam);
    p.label = static_cast<PointClass>(label);
    p.hit_robot = static_cast<std::uint8_t>(hit);
    p.flags = static_cast<std::uint16_t>(flags);
    back.push_back(p);
  }
  // PCL prints floats with 7 significant digits: equal within 1e-6 relative.
  expect_same(pts, back, 1e-6f);
}

TEST(PcdPcl, WeReadPclBinaryAndBinaryCompressedExactly) {
  if (!have_pcl_tools()) GTEST_SKIP() << "pcl_convert_pcd_ascii_binary not installed (apt-get install pcl-tools)";
  const auto dir = test::temp_dir();
  const auto ours = (dir / "ours.pcd").string();
  const auto pts = cloud_to_save();
  ASSERT_TRUE(write_labelled_pcd(ours, pts).ok());
  for (const int mode : {1, 2}) {
    const auto out = (dir / ("pcl" + std::to_string(mode) + ".pcd")).string();
    ASSERT_EQ(pcl_convert(ours, out, mode), 0);
    const auto back = read_labelled_pcd(out);
    ASSERT_TRUE(back.ok()) << back.error().what;
    expect_same(pts, *back, 0.0f);
  }
}

TEST(PcdPcl, RealFileThroughPclAsciiMatchesOurBinaryCompressedRead) {
  if (!have_pcl_tools()) GTEST_SKIP() << "pcl_convert_pcd_ascii_binary not installed (apt-get install pcl-tools)";
  const auto dir = test::temp_dir();
  const auto src = teamscan::test::real_data_path("room_scan1.pcd");
  const auto ascii = (dir / "room_ascii.pcd").string();
  ASSERT_EQ(pcl_convert(src, ascii, 0), 0);
  const auto compressed = read_pcd(src);
  const auto text = read_pcd(ascii);
  ASSERT_TRUE(compressed.ok()) << compressed.error().what;
  ASSERT_TRUE(text.ok()) << text.error().what;
  ASSERT_EQ(compressed->size(), text->size());
  for (std::size_t i = 0; i < compressed->xyz.size(); ++i)
    ASSERT_NEAR(compressed->xyz[i], text->xyz[i], 1e-6f * (1 + std::fabs(text->xyz[i]))) << i;
}

TEST(PcdPcl, PclReadsOurGeneralWriterWithViewpoint) {
  if (!have_pcl_tools()) GTEST_SKIP() << "pcl_convert_pcd_ascii_binary not installed (apt-get install pcl-tools)";
  const auto dir = test::temp_dir();
  PcdCloud c;
  c.fields = {"x", "y", "z", "keep", "ring", "time"};
  c.columns = {{1.5, -2.25, 0.125}, {0, 1, 2}, {-1, 0.5, 3}, {1, 0, 1}, {-3, 0, 32767}, {0.5, 2.0, 1024.25}};
  const double vp[7] = {1.0, 2.0, 0.5, 0.0, 0.0, 0.0, 1.0};  // 180 deg about z
  std::copy(std::begin(vp), std::end(vp), std::begin(c.viewpoint));
  const std::vector<PcdField> layout = {{"x", 4, 'F', 1}, {"y", 4, 'F', 1}, {"z", 4, 'F', 1},
                                        {"keep", 1, 'U', 1}, {"ring", 2, 'I', 1}, {"time", 8, 'F', 1}};
  const auto ours = (dir / "general.pcd").string();
  ASSERT_TRUE(write_pcd(ours, c, layout).ok());
  const auto ascii = (dir / "general_ascii.pcd").string();
  ASSERT_EQ(pcl_convert(ours, ascii, 0), 0);
  std::ifstream in(ascii);
  std::string line, types, viewpoint;
  while (std::getline(in, line)) {
    if (line.rfind("TYPE", 0) == 0) types = line;
    if (line.rfind("VIEWPOINT", 0) == 0) viewpoint = line;
  }
  EXPECT_EQ(types, "TYPE F F F U I F");
  EXPECT_EQ(viewpoint, "VIEWPOINT 1 2 0.5 0 0 0 1");
  const auto back = read_pcd(ascii);
  ASSERT_TRUE(back.ok()) << back.error().what;
  ASSERT_EQ(back->size(), 3u);
  for (std::size_t f = 0; f < c.fields.size(); ++f)
    for (std::size_t i = 0; i < 3; ++i) EXPECT_EQ(back->columns[f][i], c.columns[f][i]) << c.fields[f] << " " << i;
}

}  // namespace
}  // namespace teamscan
