// The matcher on synthetic geometry: rooms, corridors (degenerate), outliers, wrong and far matches.
#include <gtest/gtest.h>

#include <cmath>

#include <Eigen/LU>

#include "groundstation/registration/matcher.hpp"
#include "tests/unit/registration/synthetic_scene.hpp"

namespace teamscan::registration {
namespace {

using testing::Scene;

std::vector<LineFeature> features_of(const std::vector<Vec3>& points) {
  SurfaceGrid g;
  for (const Vec3& p : points) (void)g.add(p);
  std::vector<LineFeature> f;
  g.features(f);
  return f;
}

void build_map(LineMap& map, const Scene& s, std::uint64_t seed) {
  std::mt19937_64 rng{seed};
  map.build(features_of(s.sample({0, 0}, 50, 300000, rng)));
}

Scene furnished_room() {
  Scene s = Scene::room(8, 6, 2.5);
  s.box(-1.0, -1.0, 1.2, 0.6, 0.9);
  s.box(2.5, 2.0, 0.6, 0.8, 1.8);
  return s;
}

TEST(Matcher, RecoversTheCorrectionInAFurnishedRoom) {
  const Scene s = furnished_room();
  LineMap map;
  build_map(map, s, 1);
  std::mt19937_64 rng{2};
  const Pose2 truth{0.06, -0.04, deg_to_rad(1.2)};
  const auto source = features_of(testing::into_odometry(s.sample({1.5, 0.5}, 3.0, 30000, rng), truth));
  const MatchResult m = match(map, source, Pose2{}, MatchOptions{});
  ASSERT_EQ(m.status, MatchStatus::accepted) << to_string(m.status) << " overlap " << m.overlap << " rms " << m.rms_m;
  const Eigen::Vector3d e = difference(m.map_from_odom, truth, m.pivot_m);
  EXPECT_LT(e.head<2>().norm(), 0.005);
  EXPECT_LT(std::abs(rad_to_deg(e(2))), 0.15);
  EXPECT_FALSE(m.degenerate);
  EXPECT_GT(m.overlap, 0.8);
  // A usable covariance: positive definite, centimetres and tenths of a degree.
  EXPECT_GT(m.covariance.determinant(), 0.0);
  EXPECT_LT(std::sqrt(m.covariance(0, 0)), 0.02);
  EXPECT_LT(std::sqrt(m.covariance(2, 2)), deg_to_rad(0.5));
}

TEST(Matcher, CorridorKeepsThePriorAlongItsAxisAndSaysSo) {
  Scene s;
  s.walls = {{{-30, -1.2}, {30, -1.2}, 0, 2.5}, {{30, 1.2}, {-30, 1.2}, 0, 2.5}};
  s.slabs = {{-30, 30, -1.2, 1.2, 0.0}};
  LineMap map;
  std::mt19937_64 rng{3};
  map.build(features_of(s.sample({0, 0}, 40, 300000, rng)));
  const Pose2 truth{0.08, 0.05, deg_to_rad(0.6)};
  const auto source = features_of(testing::into_odometry(s.sample({0, 0}, 3.0, 30000, rng), truth));
  const MatchResult m = match(map, source, Pose2{}, MatchOptions{});
  ASSERT_EQ(m.status, MatchStatus::accepted) << to_string(m.status);
  EXPECT_TRUE(m.degenerate);
  EXPECT_GT(std::abs(m.unconstrained(0)), 0.95);  // along the corridor
  const Eigen::Vector3d got = difference(m.map_from_odom, Pose2{}, m.pivot_m);
  const Eigen::Vector3d want = difference(truth, Pose2{}, m.pivot_m);
  EXPECT_NEAR(got(0), 0.0, 0.01);  // x stays where odometry had it
  EXPECT_NEAR(got(1), want(1), 0.005);
  EXPECT_NEAR(got(2), want(2), deg_to_rad(0.1));
  EXPECT_GT(m.covariance(0, 0), 0.5);  // unconstrained: of the order of MatchOptions::unconstrained_sigma
  EXPECT_LT(m.covariance(1, 1), 0.02 * 0.02);
}

TEST(Matcher, ClutterAndAnObjectMissingFromTheMapDoNotPullIt) {
  const Scene s = furnished_room();
  LineMap map;
  build_map(map, s, 4);
  std::mt19937_64 rng{5};
  Scene with_person = s;
  with_person.box(1.0, 1.5, 0.4, 0.4, 1.7);  // not in the map
  auto points = with_person.sample({1.5, 0.5}, 3.0, 30000, rng);
  std::uniform_real_distribution<double> u(-3.0, 3.0), h(0.1, 2.4);
  for (int i = 0; i < 3000; ++i) points.push_back({u(rng), u(rng), h(rng)});  // scattered outliers
  const Pose2 truth{-0.05, 0.03, deg_to_rad(-0.8)};
  const auto source = features_of(testing::into_odometry(points, truth));
  const MatchResult m = match(map, source, Pose2{}, MatchOptions{});
  ASSERT_EQ(m.status, MatchStatus::accepted) << to_string(m.status) << " overlap " << m.overlap;
  const Eigen::Vector3d e = difference(m.map_from_odom, truth, m.pivot_m);
  EXPECT_LT(e.head<2>().norm(), 0.01);
  EXPECT_LT(std::abs(rad_to_deg(e(2))), 0.15);
}

TEST(Matcher, AWrongPlaceIsRejectedAndThePriorKept) {
  LineMap map;
  build_map(map, furnished_room(), 6);
  Scene other;  // a different room: narrow, angled walls
  other.walls = {{{-1, -4}, {3, 0.5}, 0, 2.5}, {{-2, -3}, {2.2, 1.5}, 0, 2.5}, {{0.5, -1}, {0.7, 2.5}, 0, 1.0}};
  std::mt19937_64 rng{7};
  const auto source = features_of(other.sample({0, 0}, 5.0, 30000, rng));
  const Pose2 prior{0.01, 0.02, 0.001};
  const MatchResult m = match(map, source, prior, MatchOptions{});
  EXPECT_NE(m.status, MatchStatus::accepted);
  EXPECT_EQ(m.map_from_odom.x_m, prior.x_m);
  EXPECT_EQ(m.map_from_odom.theta_rad, prior.theta_rad);
}

TEST(Matcher, AFarSolutionIsNeverAJump) {
  const Scene s = furnished_room();
  LineMap map;
  build_map(map, s, 8);
  std::mt19937_64 rng{9};
  const Pose2 truth{0.25, 0.0, deg_to_rad(4.0)};  // beyond the bounded step
  const auto source = features_of(testing::into_odometry(s.sample({1.5, 0.5}, 3.0, 30000, rng), truth));
  const MatchResult m = match(map, source, Pose2{}, MatchOptions{});
  EXPECT_NE(m.status, MatchStatus::accepted) << "step " << m.step_m << " m " << rad_to_deg(m.step_rad) << "°";
  EXPECT_EQ(m.map_from_odom.x_m, 0.0);
}

TEST(Matcher, FloorAndCeilingAloneAreTooFewFeatures) {
  LineMap map;
  build_map(map, furnished_room(), 10);
  Scene flat;
  flat.slabs = {{-3, 3, -3, 3, 0.0}, {-3, 3, -3, 3, 2.5}};
  std::mt19937_64 rng{11};
  const auto source = features_of(flat.sample({0, 0}, 3.0, 30000, rng));
  EXPECT_EQ(source.size(), 0u);
  EXPECT_EQ(match(map, source, Pose2{}, MatchOptions{}).status, MatchStatus::too_few_features);
}

TEST(Matcher, PerturbDifferenceAndMovePivotAgree) {
  const Pose2 t{1.0, -2.0, 0.3};
  const Vec2 a{0.5, 0.5}, b{3.0, -1.0};
  const Pose2 moved = perturb(t, a, 0.01, -0.02, 0.004);
  const Eigen::Vector3d da = difference(moved, t, a), db = difference(moved, t, b);
  EXPECT_NEAR(da(0), 0.01, 1e-12);
  EXPECT_NEAR(da(1), -0.02, 1e-12);
  // The same motion seen about b: δt_b = δt_a + δθ ẑ × (b − a), to first order.
  Eigen::Matrix3d j = Eigen::Matrix3d::Identity();
  j(0, 2) = -(b.y - a.y);
  j(1, 2) = b.x - a.x;
  EXPECT_NEAR((j * da - db).norm(), 0.0, 1e-4);
  const Eigen::Matrix3d c = Eigen::Vector3d{1e-4, 4e-4, 1e-6}.asDiagonal();
  EXPECT_NEAR((move_pivot(c, a, b) - j * c * j.transpose()).norm(), 0.0, 1e-15);
}

}  // namespace
}  // namespace teamscan::registration

namespace teamscan::registration {
namespace {

TEST(LineMapNearest, ABarePointTakesTheNearestLineWhateverItsNormal) {
  // Two walls meeting at a corner: a line along x at y = 0 (normal +y), one along y at x = 1 (normal +x).
  std::vector<LineFeature> f;
  for (int i = 0; i < 10; ++i) f.push_back({0.1 * i, 0.0, 0.0, 1.0, 1.0f});
  for (int i = 1; i < 10; ++i) f.push_back({1.0, 0.1 * i, 1.0, 0.0, 1.0f});
  LineMap map;
  map.build(f);
  // With a normal, only the agreeing wall answers (the nearest feature is on the other one).
  const std::ptrdiff_t with_normal = map.nearest(0.95, 0.04, 1.0, 0.0, 0.3, 0.8);
  ASSERT_GE(with_normal, 0);
  EXPECT_DOUBLE_EQ(f[static_cast<std::size_t>(with_normal)].nx, 1.0);
  // Without one (a 2-D scan's point, RegistrationOptions::point_source), the nearest line.
  const std::ptrdiff_t bare = map.nearest(0.95, 0.04, 0.0, 0.0, 0.3, 0.8);
  ASSERT_GE(bare, 0);
  EXPECT_DOUBLE_EQ(f[static_cast<std::size_t>(bare)].ny, 1.0);
  EXPECT_DOUBLE_EQ(f[static_cast<std::size_t>(bare)].x_m, 0.9);
  // The gate holds for bare points too.
  EXPECT_EQ(map.nearest(0.5, 0.5, 0.0, 0.0, 0.3, 0.8), -1);
}

}  // namespace
}  // namespace teamscan::registration
