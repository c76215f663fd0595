// `teamscan render` end to end: a hand-made data set folder and PCDs in, PNG out (size checked in the
// PNG header, bytes identical across runs); missing and malformed inputs give a message and exit 1.
#include <sys/wait.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "common/dataset/dataset.hpp"
#include "common/dataset/pcd.hpp"

namespace teamscan {
namespace {

namespace fs = std::filesystem;

// ctest sets TEAMSCAN_BINARY_DIR; run by hand, the build tree is three levels above this test binary.
std::string teamscan_binary() {
  const char* b = std::getenv("TEAMSCAN_BINARY_DIR");
  const fs::path root = b != nullptr ? fs::path(b) : fs::read_symlink("/proc/self/exe").parent_path() / ".." / ".." / "..";
  return (root / "tools" / "teamscan" / "teamscan").string();
}

struct CommandRun {
  int exit_code = -1;
  std::string output;  // stdout and stderr
};

CommandRun run(const std::string& args) {
  CommandRun r;
  const std::string cmd = "'" + teamscan_binary() + "' " + args + " 2>&1";
  FILE* p = popen(cmd.c_str(), "r");
  if (p == nullptr) return r;
  char buf[512];
  while (std::fgets(buf, sizeof buf, p) != nullptr) r.output += buf;
  const int status = pclose(p);
  r.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return r;
}

std::vector<std::uint8_t> bytes(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

std::uint32_t be32(const std::vector<std::uint8_t>& b, std::size_t at) {
  return (std::uint32_t{b[at]} << 24) | (std::uint32_t{b[at + 1]} << 16) | (std::uint32_t{b[at + 2]} << 8) | b[at + 3];
}

fs::path fresh_dir(const char* name) {
  const auto d = fs::path(::testing::TempDir()) / (std::string("teamscan_cmd_render_") + name);
  fs::remove_all(d);
  fs::create_directories(d);
  return d;
}

Dataset small_dataset() {
  Dataset d;
  d.scenario = "tiny";
  for (std::uint8_t id : {1, 2}) {
    DatasetRobot r;
    r.id = id;
    r.name = "robot" + std::to_string(id);
    r.role = id == 1 ? "down-laser" : "up-laser";
    d.robots.push_back(r);
  }
  for (int i = 0; i < 200; ++i) {
    LabelledPoint p;
    p.x = static_cast<float>(i % 20) * 0.3f;
    p.y = static_cast<float>(i / 20) * 0.3f;
    p.robot = static_cast<std::uint8_t>(1 + i % 2);
    p.label = i == 55 ? PointClass::robot : PointClass::floor;
    p.flags = i % 17 == 0 ? point_flags::kDirectionFiltered : 0;
    d.points.push_back(p);
  }
  for (int k = 0; k < 10; ++k) {
    TrajectorySample t;
    t.robot = 1;
    t.stamp_ns = k * 100000000LL;
    t.pose = {0.5 * k, 1.0, 0};
    d.truth.push_back(t);
  }
  return d;
}

TEST(CmdRender, DataSetToPngOfTheRequestedSize) {
  const auto dir = fresh_dir("dataset");
  ASSERT_TRUE(write_dataset((dir / "set").string(), small_dataset()).ok());
  for (const char* view : {"top", "side", "perspective"})
    for (const char* color : {"class", "robot", "filter"}) {
      const auto out = dir / (std::string(view) + "_" + color + ".png");
      const CommandRun r = run("render '" + (dir / "set").string() + "' --out '" + out.string() + "' --view " + view + " --color " +
                        color + " --size 320x240");
      ASSERT_EQ(r.exit_code, 0) << r.output;
      const auto png = bytes(out);
      ASSERT_GT(png.size(), 33u);
      EXPECT_EQ(png[1], 'P');
      EXPECT_EQ(be32(png, 16), 320u);
      EXPECT_EQ(be32(png, 20), 240u);
    }
}

TEST(CmdRender, SameInputSamePngBytes) {
  const auto dir = fresh_dir("determinism");
  ASSERT_TRUE(write_dataset((dir / "set").string(), small_dataset()).ok());
  const auto args = "render '" + (dir / "set").string() + "' --view perspective --color robot --out ";
  ASSERT_EQ(run(args + "'" + (dir / "a.png").string() + "'").exit_code, 0);
  ASSERT_EQ(run(args + "'" + (dir / "b.png").string() + "'").exit_code, 0);
  EXPECT_EQ(bytes(dir / "a.png"), bytes(dir / "b.png"));
}

TEST(CmdRender, PlainPcdWithKeepField) {
  const auto dir = fresh_dir("pcd");
  {
    std::ofstream f(dir / "keep.pcd");
    f << "VERSION 0.7\nFIELDS x y z keep\nSIZE 4 4 4 1\nTYPE F F F U\nWIDTH 3\nHEIGHT 1\nDATA ascii\n"
         "0 0 0 1\n1 1 1 0\n2 0 1 1\n";
  }
  const CommandRun r = run("render '" + (dir / "keep.pcd").string() + "' --out '" + (dir / "k.png").string() + "' --color filter");
  EXPECT_EQ(r.exit_code, 0) << r.output;
  EXPECT_TRUE(fs::exists(dir / "k.png"));
}

TEST(CmdRender, MissingInputIsAClearError) {
  const auto dir = fresh_dir("missing");
  const CommandRun r = run("render '" + (dir / "no-such-set").string() + "' --out '" + (dir / "x.png").string() + "'");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.output.find("no-such-set"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("no such"), std::string::npos) << r.output;
  EXPECT_FALSE(fs::exists(dir / "x.png"));
}

TEST(CmdRender, MalformedPcdIsAClearError) {
  const auto dir = fresh_dir("malformed");
  {
    std::ofstream f(dir / "bad.pcd");
    f << "VERSION 0.7\nFIELDS x y z\nSIZE 4 4\nTYPE F F F\nWIDTH 1\nHEIGHT 1\nDATA ascii\n1 2 3\n";
  }
  const CommandRun r = run("render '" + (dir / "bad.pcd").string() + "' --out '" + (dir / "x.png").string() + "'");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.output.find("bad.pcd"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("SIZE"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("line"), std::string::npos) << r.output;
}

TEST(CmdRender, MalformedDataSetNamesTheFile) {
  const auto dir = fresh_dir("malformed_set");
  ASSERT_TRUE(write_dataset((dir / "set").string(), small_dataset()).ok());
  { std::ofstream f(dir / "set" / "scans.csv"); f << "not,the,header\n"; }
  const CommandRun r = run("render '" + (dir / "set").string() + "' --out '" + (dir / "x.png").string() + "'");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.output.find("scans.csv"), std::string::npos) << r.output;
}

TEST(CmdRender, BadOptionsAreRejected) {
  const auto dir = fresh_dir("options");
  ASSERT_TRUE(write_dataset((dir / "set").string(), small_dataset()).ok());
  const auto base = "render '" + (dir / "set").string() + "' --out '" + (dir / "x.png").string() + "' ";
  EXPECT_NE(run(base + "--view front").exit_code, 0);
  EXPECT_NE(run(base + "--color rainbow").exit_code, 0);
  EXPECT_NE(run(base + "--size 12").exit_code, 0);
  EXPECT_NE(run(base + "--size 10x10").exit_code, 0);
  EXPECT_NE(run("render '" + (dir / "set").string() + "'").exit_code, 0);  // --out is required
}

}  // namespace
}  // namespace teamscan
