// The data set folder: exact round trip of every file, deterministic bytes, and malformed or missing
// files reported with the file's name and the line.
#include <cmath>
#include <cstring>
#include <functional>
#include <filesystem>
#include <limits>
#include <string>

#include <gtest/gtest.h>

#include "common/dataset/dataset.hpp"
#include "common/dataset/pcd.hpp"
#include "tests/unit/dataset/test_util.hpp"

namespace teamscan {
namespace {

namespace fs = std::filesystem;

Dataset sample_dataset() {
  Dataset d;
  d.scenario = "lap2 \"quoted\" \\ name";
  d.seed = 18446744073709551615ull;  // above int64: stored as a string in TOML
  d.duration_s = 0.1 + 0.2;          // not a short decimal: needs all digits to round-trip
  d.room_m[0] = 10; d.room_m[1] = 7.5; d.room_m[2] = 1e-300;
  for (std::uint8_t id = 1; id <= 3; ++id) {
    DatasetRobot r;
    r.id = id;
    r.name = "robot" + std::to_string(id);
    r.role = id == 1 ? "down-laser" : "up-laser";
    r.subclass = id == 3 ? "p3at-sh" : "p3at";
    r.mount_xyz_m[0] = 0.1 * id; r.mount_xyz_m[2] = 0.45;
    r.mount_rpy_rad[1] = (id == 1 ? 1 : -1) * M_PI / 9;
    r.fov_deg = 180;
    r.resolution_cdeg = id == 2 ? 50 : 100;
    r.lms_baud = id == 3 ? 38400 : 500000;
    r.registration = {1.0 / 3.0, -2.0, M_PI / 2};
    r.footprint_m[0] = 0.626; r.footprint_m[1] = 0.505;
    r.height_m = 0.277;
    d.robots.push_back(r);
  }
  for (int i = 0; i < 50; ++i) {
    LabelledPoint p;
    p.x = static_cast<float>(i) * 0.1f; p.y = -static_cast<float>(i); p.z = 0.01f;
    p.robot = static_cast<std::uint8_t>(1 + i % 3); p.scan = static_cast<std::uint32_t>(i / 5); p.beam = static_cast<std::uint16_t>(i);
    p.label = i % 7 == 0 ? PointClass::robot : PointClass::floor; p.hit_robot = i % 7 == 0 ? 2 : 0;
    d.points.push_back(p);
  }
  for (int i = 0; i < 10; ++i) {
    ScanRecord s;
    s.robot = static_cast<std::uint8_t>(1 + i % 3); s.scan = static_cast<std::uint32_t>(i);
    s.stamp_ns = 1763780000123456789LL + i * 13333333LL; s.beams = 181; s.points = 170;
    s.origin = {std::sqrt(2.0) * i, -1e-17, 0.45};
    s.pose = {0.1 * i, 0.2 * i, std::atan2(1.0, 3.0)};
    s.true_pose = {0.1 * i + 1e-9, 0.2 * i, -M_PI};
    d.scans.push_back(s);
  }
  for (int i = 0; i < 20; ++i) {
    TrajectorySample t;
    t.robot = static_cast<std::uint8_t>(1 + i % 2); t.stamp_ns = -5 + i * 100000000LL;
    t.pose = {std::exp(0.1 * i), -0.0, std::sin(i)}; t.v_mps = 0.3; t.w_radps = -0.05 * i;
    d.truth.push_back(t);
    t.pose.x_m += 0.001;
    d.odom.push_back(t);
  }
  return d;
}

void expect_equal(const Dataset& a, const Dataset& b) {
  EXPECT_EQ(a.scenario, b.scenario);
  EXPECT_EQ(a.seed, b.seed);
  EXPECT_EQ(a.duration_s, b.duration_s);
  for (int k = 0; k < 3; ++k) EXPECT_EQ(a.room_m[k], b.room_m[k]);
  ASSERT_EQ(a.robots.size(), b.robots.size());
  for (std::size_t i = 0; i < a.robots.size(); ++i) {
    const auto &r = a.robots[i], &s = b.robots[i];
    EXPECT_EQ(r.id, s.id); EXPECT_EQ(r.name, s.name); EXPECT_EQ(r.role, s.role); EXPECT_EQ(r.subclass, s.subclass);
    for (int k = 0; k < 3; ++k) { EXPECT_EQ(r.mount_xyz_m[k], s.mount_xyz_m[k]); EXPECT_EQ(r.mount_rpy_rad[k], s.mount_rpy_rad[k]); }
    EXPECT_EQ(r.fov_deg, s.fov_deg); EXPECT_EQ(r.resolution_cdeg, s.resolution_cdeg); EXPECT_EQ(r.lms_baud, s.lms_baud);
    EXPECT_EQ(r.registration.x_m, s.registration.x_m); EXPECT_EQ(r.registration.y_m, s.registration.y_m);
    EXPECT_EQ(r.registration.theta_rad, s.registration.theta_rad);
    EXPECT_EQ(r.footprint_m[0], s.footprint_m[0]); EXPECT_EQ(r.footprint_m[1], s.footprint_m[1]);
    EXPECT_EQ(r.height_m, s.height_m);
  }
  ASSERT_EQ(a.points.size(), b.points.size());
  for (std::size_t i = 0; i < a.points.size(); ++i) {
    EXPECT_EQ(a.points[i].x, b.points[i].x); EXPECT_EQ(a.points[i].label, b.points[i].label);
    EXPECT_EQ(a.points[i].scan, b.points[i].scan); EXPECT_EQ(a.points[i].hit_robot, b.points[i].hit_robot);
  }
  ASSERT_EQ(a.scans.size(), b.scans.size());
  for (std::size_t i = 0; i < a.scans.size(); ++i) {
    const auto &r = a.scans[i], &s = b.scans[i];
    EXPECT_EQ(r.robot, s.robot); EXPECT_EQ(r.scan, s.scan); EXPECT_EQ(r.stamp_ns, s.stamp_ns); EXPECT_EQ(r.beams, s.beams);
    EXPECT_EQ(r.points, s.points); EXPECT_EQ(r.origin.x, s.origin.x); EXPECT_EQ(r.origin.y, s.origin.y);
    EXPECT_EQ(r.origin.z, s.origin.z); EXPECT_EQ(r.pose.x_m, s.pose.x_m); EXPECT_EQ(r.pose.y_m, s.pose.y_m);
    EXPECT_EQ(r.pose.theta_rad, s.pose.theta_rad); EXPECT_EQ(r.true_pose.x_m, s.true_pose.x_m);
    EXPECT_EQ(r.true_pose.y_m, s.true_pose.y_m); EXPECT_EQ(r.true_pose.theta_rad, s.true_pose.theta_rad);
    EXPECT_EQ(r.source_stamp_us, s.source_stamp_us);
  }
  for (const auto* pair : {&a.truth, &a.odom}) {
    const auto& other = pair == &a.truth ? b.truth : b.odom;
    ASSERT_EQ(pair->size(), other.size());
    for (std::size_t i = 0; i < pair->size(); ++i) {
      const auto &t = (*pair)[i], &u = other[i];
      EXPECT_EQ(t.robot, u.robot); EXPECT_EQ(t.stamp_ns, u.stamp_ns); EXPECT_EQ(t.pose.x_m, u.pose.x_m);
      EXPECT_EQ(t.pose.y_m, u.pose.y_m); EXPECT_EQ(std::signbit(t.pose.y_m), std::signbit(u.pose.y_m));
      EXPECT_EQ(t.pose.theta_rad, u.pose.theta_rad); EXPECT_EQ(t.v_mps, u.v_mps); EXPECT_EQ(t.w_radps, u.w_radps);
    }
  }
}

TEST(Dataset, RoundTripIsExact) {
  const auto dir = test::temp_dir();
  const Dataset d = sample_dataset();
  ASSERT_TRUE(write_dataset((dir / "set").string(), d).ok());
  for (const char* f : {"dataset.toml", "points.pcd", "scans.csv", "truth.csv", "odom.csv"})
    EXPECT_TRUE(fs::exists(dir / "set" / f)) << f;
  const auto back = read_dataset((dir / "set").string());
  ASSERT_TRUE(back.ok()) << back.error().what << " line " << back.error().detail;
  expect_equal(d, *back);
}

// An imported log's exact source stamps (source_stamps.csv, only written when a scan has one).
TEST(Dataset, SourceStampsRoundTrip) {
  const auto dir = test::temp_dir();
  Dataset d = sample_dataset();
  ASSERT_TRUE(write_dataset((dir / "plain").string(), d).ok());
  EXPECT_FALSE(fs::exists(dir / "plain" / "source_stamps.csv"));
  for (std::size_t i = 0; i < d.scans.size(); ++i) d.scans[i].source_stamp_us = 976052857337284 - static_cast<std::int64_t>(i % 2) * 300000;
  ASSERT_TRUE(write_dataset((dir / "set").string(), d).ok());
  EXPECT_TRUE(fs::exists(dir / "set" / "source_stamps.csv"));
  const auto back = read_dataset((dir / "set").string());
  ASSERT_TRUE(back.ok()) << back.error().what << " line " << back.error().detail;
  expect_equal(d, *back);
  // A row that names another scan than scans.csv's row is refused, naming the file.
  test::write_file(dir / "set" / "source_stamps.csv", "robot,scan,source_stamp_us\n1,5,1\n");
  const auto bad = read_dataset((dir / "set").string());
  ASSERT_FALSE(bad.ok());
  EXPECT_NE(std::string(bad.error().what).find("source_stamps.csv"), std::string::npos) << bad.error().what;
}

TEST(Dataset, EmptyDataSetRoundTrips) {
  const auto dir = test::temp_dir();
  Dataset d;
  d.scenario = "empty";
  ASSERT_TRUE(write_dataset(dir.string(), d).ok());
  const auto back = read_dataset(dir.string());
  ASSERT_TRUE(back.ok()) << back.error().what;
  expect_equal(d, *back);
}

TEST(Dataset, DeterministicBytes) {
  const auto dir = test::temp_dir();
  const Dataset d = sample_dataset();
  ASSERT_TRUE(write_dataset((dir / "a").string(), d).ok());
  ASSERT_TRUE(write_dataset((dir / "b").string(), d).ok());
  for (const char* f : {"dataset.toml", "points.pcd", "scans.csv", "truth.csv", "odom.csv"})
    EXPECT_EQ(test::file_bytes(dir / "a" / f), test::file_bytes(dir / "b" / f)) << f;
}

TEST(Dataset, DocumentedHeaderRowsAndCounts) {
  const auto dir = test::temp_dir();
  ASSERT_TRUE(write_dataset(dir.string(), sample_dataset()).ok());
  const auto first_line = [&](const char* f) {
    const auto b = test::file_bytes(dir / f);
    const std::string s(b.begin(), b.end());
    return s.substr(0, s.find('\n'));
  };
  EXPECT_EQ(first_line("scans.csv"),
            "robot,scan,stamp_ns,beams,points,origin_x_m,origin_y_m,origin_z_m,odom_x_m,odom_y_m,odom_theta_rad,"
            "true_x_m,true_y_m,true_theta_rad");
  EXPECT_EQ(first_line("truth.csv"), "robot,stamp_ns,x_m,y_m,theta_rad,v_mps,w_radps");
  EXPECT_EQ(first_line("odom.csv"), "robot,stamp_ns,x_m,y_m,theta_rad,v_mps,w_radps");
  const auto toml = test::file_bytes(dir / "dataset.toml");
  const std::string t(toml.begin(), toml.end());
  EXPECT_NE(t.find("ghost_points = 8\n"), std::string::npos);  // i % 7 == 0 for i in 0..49
  EXPECT_NE(t.find("points = 50\n"), std::string::npos);
}

// Writes a valid data set, replaces one file's text, and returns the read error.
Error error_after(const char* file, const std::function<std::string(std::string)>& edit) {
  const auto dir = test::temp_dir(std::string("_") + file);
  EXPECT_TRUE(write_dataset(dir.string(), sample_dataset()).ok());
  const auto b = test::file_bytes(dir / file);
  test::write_file(dir / file, edit(std::string(b.begin(), b.end())));
  const auto r = read_dataset(dir.string());
  EXPECT_FALSE(r.ok()) << file;
  return r.ok() ? Error{"(no error)"} : r.error();
}

std::string replace_line(const std::string& text, int line_1based, const std::string& with) {
  std::size_t start = 0;
  for (int i = 1; i < line_1based; ++i) start = text.find('\n', start) + 1;
  const std::size_t end = text.find('\n', start);
  return text.substr(0, start) + with + text.substr(end);
}

bool names(const Error& e, const char* file) { return std::string(e.what).find(file) != std::string::npos; }

TEST(DatasetErrors, MissingFolderAndFiles) {
  const auto dir = test::temp_dir();
  const auto none = read_dataset((dir / "does-not-exist").string());
  ASSERT_FALSE(none.ok());
  EXPECT_TRUE(names(none.error(), "does-not-exist")) << none.error().what;
  for (const char* f : {"dataset.toml", "points.pcd", "scans.csv", "truth.csv", "odom.csv"}) {
    const auto set = dir / (std::string("set_") + f);
    ASSERT_TRUE(write_dataset(set.string(), sample_dataset()).ok());
    fs::remove(set / f);
    const auto r = read_dataset(set.string());
    ASSERT_FALSE(r.ok()) << f;
    EXPECT_TRUE(names(r.error(), f)) << r.error().what;
  }
}

TEST(DatasetErrors, MalformedCsvNamesFileAndLine) {
  {
    const auto e = error_after("scans.csv", [](std::string t) { return replace_line(t, 3, "1,2,3"); });
    EXPECT_TRUE(names(e, "scans.csv")) << e.what;
    EXPECT_EQ(e.detail, 3);
  }
  {
    const auto e = error_after("truth.csv", [](std::string t) { return replace_line(t, 5, "1,2,abc,0,0,0,0"); });
    EXPECT_TRUE(names(e, "truth.csv")) << e.what;
    EXPECT_EQ(e.detail, 5);
  }
  {
    const auto e = error_after("odom.csv", [](std::string t) { return replace_line(t, 1, "robot,t,x,y"); });
    EXPECT_TRUE(names(e, "odom.csv")) << e.what;
    EXPECT_EQ(e.detail, 1);
  }
  {  // robot id 300 does not fit uint8
    const auto e = error_after("odom.csv", [](std::string t) { return replace_line(t, 2, "300,0,0,0,0,0,0"); });
    EXPECT_EQ(e.detail, 2);
  }
}

// A robot id is checked where a data set enters (the fusion core trusts it): 0 and ids above
// kMaxRobots are refused with the file and line.
TEST(DatasetErrors, RobotIdOutOfRangeNamesFileAndLine) {
  {
    const auto e = error_after("odom.csv", [](std::string t) { return replace_line(t, 2, "0,0,0,0,0,0,0"); });
    EXPECT_TRUE(names(e, "odom.csv")) << e.what;
    EXPECT_EQ(e.detail, 2);
  }
  {
    const auto e = error_after("truth.csv", [](std::string t) { return replace_line(t, 2, "33,0,0,0,0,0,0"); });
    EXPECT_TRUE(names(e, "truth.csv")) << e.what;
    EXPECT_EQ(e.detail, 2);
  }
  {
    const auto e = error_after("scans.csv", [](std::string t) { return replace_line(t, 2, "0,1,0,0,0,0,0,0,0,0,0,0,0,0"); });
    EXPECT_TRUE(names(e, "scans.csv")) << e.what;
    EXPECT_EQ(e.detail, 2);
  }
}

TEST(DatasetErrors, MalformedTomlNamesFileAndLine) {
  {
    const auto e = error_after("dataset.toml", [](std::string t) { return replace_line(t, 4, "scenario = \"unterminated"); });
    EXPECT_TRUE(names(e, "dataset.toml")) << e.what;
    EXPECT_EQ(e.detail, 4);
  }
  {
    const auto e = error_after("dataset.toml", [](std::string t) { return replace_line(t, 6, "duration_s = \"long\""); });
    EXPECT_TRUE(names(e, "duration_s")) << e.what;
    EXPECT_EQ(e.detail, 6);
  }
  {
    const auto e = error_after("dataset.toml", [](std::string t) { return replace_line(t, 4, "# no scenario"); });
    EXPECT_TRUE(names(e, "scenario")) << e.what;
  }
  {  // robot id out of range
    const auto e = error_after("dataset.toml", [](std::string t) {
      const auto p = t.find("id = 2\n");
      return t.replace(p, 7, "id = 40\n");
    });
    EXPECT_TRUE(names(e, "id")) << e.what;
  }
}

TEST(DatasetErrors, CountsCatchATruncatedFile) {
  const auto e = error_after("truth.csv", [](std::string t) {
    t.pop_back();
    return t.substr(0, t.rfind('\n') + 1);  // drop the last sample
  });
  EXPECT_TRUE(names(e, "truth_samples")) << e.what;
  const auto p = error_after("points.pcd", [](std::string t) { return t.substr(0, t.size() - 35); });
  EXPECT_TRUE(names(p, "points.pcd")) << p.what;
}

}  // namespace
}  // namespace teamscan
