// RANSAC floor plane: recovery on synthetic clouds, determinism, floor constraints, and agreement with
// PCL's SACSegmentation plane (pcl_sac_segmentation_plane from pcl-tools) within the threshold.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include <unistd.h>

#include "common/dataset/pcd.hpp"
#include "groundstation/mapping/ransac.hpp"
#include "tests/support/real_data.hpp"

namespace teamscan::mapping {
namespace {

// A room corner: floor z = floor_z (σ noise), a wall x = 0 and a ceiling z = 2.5, plus clutter.
std::vector<MapPoint> room_cloud(std::size_t floor_points, double floor_z, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(0.0, 4.0), h(0.0, 2.5);
  std::normal_distribution<double> noise(0.0, 0.004);
  std::vector<MapPoint> c;
  for (std::size_t i = 0; i < floor_points; ++i)
    c.push_back({static_cast<float>(u(rng)), static_cast<float>(u(rng)), static_cast<float>(floor_z + noise(rng))});
  for (std::size_t i = 0; i < floor_points / 3; ++i)
    c.push_back({static_cast<float>(noise(rng)), static_cast<float>(u(rng)), static_cast<float>(h(rng))});
  for (std::size_t i = 0; i < floor_points / 2; ++i)
    c.push_back({static_cast<float>(u(rng)), static_cast<float>(u(rng)), static_cast<float>(2.5 + noise(rng))});
  for (std::size_t i = 0; i < floor_points / 5; ++i)
    c.push_back({static_cast<float>(u(rng)), static_cast<float>(u(rng)), static_cast<float>(h(rng))});
  return c;
}

TEST(Ransac, RecoversTheFloorAndItsInliers) {
  const auto cloud = room_cloud(5000, 0.0, 7);
  RansacOptions o;
  o.threshold_m = 0.02;
  const PlaneFit fit = fit_plane_ransac(cloud, o);
  ASSERT_TRUE(fit.found);
  EXPECT_GT(fit.plane.normal.z(), std::cos(1.0 * kPi / 180.0));  // within 1° of +z
  EXPECT_NEAR(fit.plane.d, 0.0, 0.003);
  // All 5000 floor points (|noise| ≤ 5σ = 2 cm) plus the few clutter and wall points within 2 cm.
  EXPECT_GE(fit.inliers, 4990u);
  EXPECT_LE(fit.inliers, 5000u + 60u);
  EXPECT_NEAR(fit.inlier_share, static_cast<double>(fit.inliers) / static_cast<double>(cloud.size()), 1e-12);
  EXPECT_LT(fit.rms_error_m, 0.01);
  EXPECT_LE(std::abs(fit.signed_mean_error_m), fit.mean_abs_error_m);
  EXPECT_LE(fit.mean_abs_error_m, fit.rms_error_m + 1e-15);
}

TEST(Ransac, CeilingWithMorePointsLosesToTheFloorUnderTheHeightConstraint) {
  auto cloud = room_cloud(2000, 0.0, 3);
  // Add a dense ceiling patch so the ceiling has the most inliers.
  for (int i = 0; i < 6000; ++i) cloud.push_back({0.001f * static_cast<float>(i % 1000), 0.5f + 0.0003f * static_cast<float>(i / 1000), 2.5f});
  RansacOptions o;
  const PlaneFit floor = fit_plane_ransac(cloud, o);
  ASSERT_TRUE(floor.found);
  EXPECT_NEAR(floor.plane.d, 0.0, 0.01);
  o.max_height_m = INFINITY;
  const PlaneFit any = fit_plane_ransac(cloud, o);
  ASSERT_TRUE(any.found);
  EXPECT_NEAR(any.plane.d, 2.5, 0.01);
}

TEST(Ransac, DeterministicForASeedAndRespectsTheRemovedMask) {
  const auto cloud = room_cloud(3000, 0.1, 11);
  RansacOptions o;
  o.seed = 99;
  const PlaneFit a = fit_plane_ransac(cloud, o), b = fit_plane_ransac(cloud, o);
  EXPECT_EQ(a.inliers, b.inliers);
  EXPECT_EQ(a.signed_mean_error_m, b.signed_mean_error_m);
  std::vector<std::uint8_t> removed(cloud.size(), 0);
  for (std::size_t i = 0; i < 3000; ++i) removed[i] = 1;  // drop the whole floor
  const PlaneFit no_floor = fit_plane_ransac(cloud, o, removed);
  EXPECT_EQ(no_floor.points, cloud.size() - 3000);
  EXPECT_LT(no_floor.inliers, 200u);  // only clutter near z 0.1 is left
}

TEST(Ransac, TooFewPointsGivesNoPlane) {
  const std::vector<MapPoint> two{{0, 0, 0}, {1, 0, 0}};
  EXPECT_FALSE(fit_plane_ransac(two, {}).found);
  const std::vector<MapPoint> collinear{{0, 0, 0}, {1, 0, 0}, {2, 0, 0}, {3, 0, 0}};
  EXPECT_FALSE(fit_plane_ransac(collinear, {}).found);
}

TEST(Ransac, SignedErrorAgainstTheRefitPlaneIsNearZeroByConstruction) {
  const auto cloud = room_cloud(4000, 0.0, 5);
  RansacOptions o;
  o.error_reference = PlaneErrorReference::refit;
  const PlaneFit fit = fit_plane_ransac(cloud, o);
  ASSERT_TRUE(fit.found);
  EXPECT_LT(std::abs(fit.signed_mean_error_m), 2e-4);  // LS plane passes through its inliers' centroid
}

// ---- agreement with PCL ----

struct PclPlane {
  bool ok = false;
  double a = 0, b = 0, c = 0, d = 0;  // a x + b y + c z + d = 0 (PCL's convention)
};

PclPlane run_pcl(const std::string& pcd, double threshold_m, int iterations) {
  // The tool writes the plane's inliers: into the temporary folder, never beside the repository's data.
  const std::string out =
      (std::filesystem::temp_directory_path() / ("teamscan_pcl_plane_" + std::to_string(getpid()) + ".pcd")).string();
  std::ostringstream cmd;
  cmd << "timeout 60 pcl_sac_segmentation_plane " << pcd << " " << out << " -thresh " << threshold_m << " -max_it "
      << iterations << " 2>&1";
  PclPlane plane;
  FILE* p = popen(cmd.str().c_str(), "r");
  if (!p) return plane;
  std::string text;
  char buf[512];
  while (std::fgets(buf, sizeof buf, p)) text += buf;
  pclose(p);
  std::error_code ignored;
  std::filesystem::remove(out, ignored);
  const auto at = text.find("Model coefficients: [");
  if (at == std::string::npos) return plane;
  std::istringstream in(text.substr(at + 21));
  in >> plane.a >> plane.b >> plane.c >> plane.d;
  plane.ok = static_cast<bool>(in);
  return plane;
}

bool have_pcl_tool() { return std::system("command -v pcl_sac_segmentation_plane > /dev/null 2>&1") == 0; }

void expect_agreement(const std::vector<MapPoint>& cloud, const std::string& pcd, double threshold_m) {
  RansacOptions o;
  o.threshold_m = threshold_m;
  o.iterations = 1000;
  o.max_tilt_deg = 0;           // unconstrained, like SACMODEL_PLANE
  o.max_height_m = INFINITY;
  const PlaneFit mine = fit_plane_ransac(cloud, o);
  ASSERT_TRUE(mine.found);
  const PclPlane pcl = run_pcl(pcd, threshold_m, 1000);
  ASSERT_TRUE(pcl.ok) << "could not read PCL's coefficients";
  const double norm = std::sqrt(pcl.a * pcl.a + pcl.b * pcl.b + pcl.c * pcl.c);
  // Over every one of our inliers the two planes lie within the threshold of each other.
  std::size_t checked = 0;
  for (const MapPoint& q : cloud) {
    const double ours = mine.plane.signed_distance(q);
    if (std::abs(ours) > threshold_m) continue;
    const double theirs = (pcl.a * q.x + pcl.b * q.y + pcl.c * q.z + pcl.d) / norm;
    ASSERT_LT(std::abs(std::abs(theirs) - std::abs(ours)), threshold_m) << "at (" << q.x << ", " << q.y << ", " << q.z << ")";
    ++checked;
  }
  EXPECT_EQ(checked, mine.inliers);
  // Normals parallel to within 2°.
  const double cosang = std::abs(mine.plane.normal.x() * pcl.a + mine.plane.normal.y() * pcl.b + mine.plane.normal.z() * pcl.c) / norm;
  EXPECT_GT(cosang, std::cos(2.0 * kPi / 180.0));
}

TEST(RansacVsPcl, SyntheticRoomFloorAgreesWithSacSegmentation) {
  if (!have_pcl_tool()) GTEST_SKIP() << "pcl_sac_segmentation_plane (pcl-tools) not installed";
  const auto cloud = room_cloud(20000, -0.05, 21);
  const std::string dir = ::testing::TempDir() + "/mapping_ransac_" + std::to_string(::getpid());
  std::filesystem::create_directories(dir);
  const std::string pcd = dir + "/room.pcd";
  std::vector<float> xyz;
  for (const MapPoint& p : cloud) xyz.insert(xyz.end(), {p.x, p.y, p.z});
  ASSERT_TRUE(write_xyz_pcd(pcd, xyz).ok());  // common/dataset's writer, read by PCL
  expect_agreement(cloud, pcd, 0.02);
  std::filesystem::remove_all(dir);
}

TEST(RansacVsPcl, PclsOwnPlaneTestCloudAgrees) {
  if (!have_pcl_tool()) GTEST_SKIP() << "pcl_sac_segmentation_plane (pcl-tools) not installed";
  const std::string path = teamscan::test::real_data_path("sac_plane_test.pcd");
  std::ifstream in(path);
  ASSERT_TRUE(in) << "cannot read " << path;
  // ASCII PCD: header up to DATA, then x y z nx ny nz curvature per line.
  std::string line;
  while (std::getline(in, line) && line.rfind("DATA", 0) != 0) {}
  std::vector<MapPoint> cloud;
  while (std::getline(in, line)) {
    std::istringstream row(line);
    MapPoint p;
    if (row >> p.x >> p.y >> p.z) cloud.push_back(p);
  }
  ASSERT_EQ(cloud.size(), 3283u);  // SOURCES.md
  expect_agreement(cloud, path, 0.02);
}

}  // namespace
}  // namespace teamscan::mapping
